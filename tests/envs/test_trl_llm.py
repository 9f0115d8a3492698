"""One rollout of the docs' TRL setup (cocobench-240, D1_blind, seat agent_1, greedy
partners) played by a real small model to the episode's end: SmolLM2-135M served by
llama.cpp (tests/models/llama_server.py), prompted with the conversation as TRL renders it
(its Qwen2.5 chat template, with the tools), its reply parsed by TRL's response schema into
the tool call that plays the seat, each result appended as TRL appends it. A grammar keeps
every reply a tool call (TRL would end the loop at a reply without one; a 135M model is no
reliable tool caller): what is tested is that the environment's tool traffic carries a real
model's episode to its end within the documented max_completion_length, in the model's own
tokens."""

from __future__ import annotations

import json
import urllib.request

import pytest

from tests.envs.test_trl import (
    DOCUMENTED_MAX_COMPLETION_LENGTH,
    DOCUMENTED_PROMPT,
    tiny_tokenizer,
)
from tests.models.llama_server import start_llama_server

pytestmark = [pytest.mark.llm, pytest.mark.needs_env, pytest.mark.needs_trl,
              pytest.mark.slow]

#: Every reply a tool call of the seat's tools, as Qwen2.5's template writes one.
GRAMMAR = r'''root ::= "<tool_call>\n{\"name\": \"" call "}\n</tool_call>"
call ::= "act\", \"arguments\": {\"action_id\": " id "}" | "done\", \"arguments\": {}"
id ::= [0-9] | [1-9] [0-9]
'''


def _post(server_root: str, path: str, body: dict) -> dict:
    request = urllib.request.Request(f"{server_root}{path}", data=json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=300) as response:
        return json.loads(response.read())


def test_a_real_small_model_plays_one_rollout_to_the_episodes_end():
    from cocobench_agents.envs import trl_environment

    tokenizer = tiny_tokenizer()  # TRL's chat template and response schema
    seat = trl_environment("cocobench-240", condition="D1_blind", seat="agent_1",
                           partner="greedy")()
    tools = [seat.act, seat.done]
    first = seat.reset(task_id=seat._env.team.configs[0].task_id)
    prompt = [{"role": "user", "content": DOCUMENTED_PROMPT[0]["content"] + first}]
    completion: list[dict] = []
    results: list[str] = []

    def rendered(messages: list[dict], *, generation: bool = True) -> str:
        return tokenizer.apply_chat_template(messages, tools=tools, tokenize=False,
                                             add_generation_prompt=generation)

    with start_llama_server(n_ctx=DOCUMENTED_MAX_COMPLETION_LENGTH + 4096) as server:
        root = server.base_url.removesuffix("/v1")

        def tokens(text: str) -> int:
            return len(_post(root, "/tokenize", {"content": text})["tokens"])

        while not results or not results[-1].startswith("The episode has ended"):
            assert len(results) < 200, results[-3:]
            reply = _post(root, "/completion", {
                "prompt": rendered(prompt + completion), "n_predict": 40,
                "temperature": 0, "grammar": GRAMMAR, "cache_prompt": True})["content"]
            message = tokenizer.parse_response(reply + "<|im_end|>", prefix="")
            [call] = message["tool_calls"]
            name, arguments = call["function"]["name"], call["function"]["arguments"]
            results.append(getattr(seat, name)(**arguments))
            completion += [message, {"role": "tool", "name": name, "content": results[-1]}]
        used = tokens(rendered(prompt + completion)) - tokens(rendered(prompt))

    assert used <= DOCUMENTED_MAX_COMPLETION_LENGTH, used
    assert len(results) > 1 and not any("YOUR ACTION MENU" in r for r in results)
    assert isinstance(seat.get_reward(), float)
    assert seat._env.team.loop.is_closed()  # closed at the episode's end (TRL never closes)

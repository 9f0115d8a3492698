"""The TRL contract, checked against TRL's own code: its tool-schema extraction, its chat
template's tool-call parsing feeding the class's tools, and a real GRPO step with a tiny
model built here (no download)."""

from __future__ import annotations

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
    assert "1. Find(agent_1" in following
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

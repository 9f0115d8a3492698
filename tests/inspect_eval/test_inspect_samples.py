"""What an Inspect user reads of a sample: its messages are the episode's model calls (each
decision's prompt and the model's reply, agent by agent, in order), and ``--limit N`` takes
samples from every condition and arm, their ids unchanged."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from .conftest import REPLIES, config_paths, scripted_mockllm

pytestmark = pytest.mark.needs_inspect


def _eval(tmp_path: Path, replies: list[str], limit: int | None = None, **task_args):
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.task import cocobench

    roles = {f"agent_{i}": scripted_mockllm(replies) for i in (1, 2)}
    [log] = inspect_eval(cocobench(**task_args), model=scripted_mockllm(replies),
                         model_roles=roles, log_dir=str(tmp_path / "logs"), display="none",
                         limit=limit)
    return read_eval_log(log.location, resolve_attachments=True)


def _text(message) -> str:
    content = message.content
    return content if isinstance(content, str) else "".join(
        part.text for part in content if part.type == "text")


def test_a_samples_messages_are_its_prompts_and_replies(tmp_path: Path):
    from inspect_ai.model import ContentImage

    from benchmark_adapter.trajectory import PROMPTS_FIELD
    from cocobench_agents.inspect_eval.solver import TRAJECTORY

    log = _eval(tmp_path, REPLIES, task=config_paths()[0], conditions="C0_image,D1_blind",
                max_steps=6)
    assert log.status == "success", log.error
    assert len(log.samples) == 2
    for sample in log.samples:
        document = sample.store[TRAJECTORY]
        calls = [d for d in document["planner_decisions"] if d.get("prompt_hash")]
        prompts = document[PROMPTS_FIELD]
        assert len(calls) > 2, sample.id
        # one user message per decision (its prompt), then the reply, in the decisions' order
        assert [m.role for m in sample.messages] == ["user", "assistant"] * len(calls)
        users, replies = sample.messages[0::2], sample.messages[1::2]
        assert [m.metadata["agent"] for m in users] == [d["agent"] for d in calls]
        assert [m.metadata["agent"] for m in replies] == [d["agent"] for d in calls]
        assert [m.text for m in replies] == [d["raw_output"] for d in calls]
        assert {m.model for m in replies} == {d["model"] for d in calls}
        # the prompts are the ones the model was sent (the transcript's model events)
        events = [e for e in sample.events if e.event == "model"]
        sent = [_text(e.input[0]) for e in events]
        assert [prompts[d["prompt_hash"]] for d in calls] == sent
        # no frame copied into the messages: under an image condition a line stands for it
        assert not [part for m in users if isinstance(m.content, list)
                    for part in m.content if isinstance(part, ContentImage)]
        if sample.id.startswith("C0_image"):
            assert {m.metadata["agent"] for m in users} == {None}
            assert all(_text(m) == text + "[image: the team's merged view, sent as a PNG "
                       "frame; not kept in the sample's messages, the model event of the "
                       "transcript shows it]" for m, text in zip(users, sent, strict=True))
        else:
            assert {m.metadata["agent"] for m in users} == {"agent_1", "agent_2"}
            assert [m.content for m in users] == sent
        # legality is scored outside D2 too (this is a D1 instance), 0 or 1
        assert sample.metadata["dim"] == "D1"
        assert sample.scores["cocobench_scorer"].value["legal_plan"] in (0, 1)


def test_limit_takes_samples_from_every_condition_and_arm(tmp_path: Path):
    from cocobench_agents.inspect_eval.task import cocobench

    args = {"task": config_paths(), "conditions": "C0_blind,D1_blind",
            "prompt_suite": "cocobench-v1,cocobench-v1+no-hint"}
    ids = [str(sample.id) for sample in cocobench(**args).dataset]
    assert len(ids) == len(set(ids)) == 8
    # the ids are those of each condition and arm alone: the order changed none
    alone = {str(s.id) for cond in ("C0_blind", "D1_blind")
             for suite in ("cocobench-v1", "cocobench-v1+no-hint")
             for s in cocobench(**{**args, "conditions": cond, "prompt_suite": suite}).dataset}
    assert set(ids) == alone
    # Inspect's --limit 4 runs one sample of each condition x arm
    log = _eval(tmp_path, ["I am not sure."], limit=4, **args)
    assert log.status == "success", log.error
    cells = {(s.metadata["condition"], s.metadata["prompt_suite"]) for s in log.samples}
    assert cells == {(c, p) for c in ("C0_blind", "D1_blind")
                     for p in ("cocobench-v1", "cocobench-v1+no-hint")}
    # an episode that landed no step has no plan to judge: its legality is NaN
    assert all(math.isnan(s.scores["cocobench_scorer"].value["legal_plan"])
               for s in log.samples)

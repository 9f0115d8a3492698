"""Common random numbers (issue 36, item 6): the built-in `random` model's stream depends on
the instance, the seat and the epoch (and the seed, the model and the condition), not on the
prompt-suite arm. Two arms that differ only in prompt text, which `random` never reads, are
compared on the same draws: every paired difference is exactly 0."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.models.builtin import RandomClient, stream_episode
from cocobench_agents.models.protocol import MenuOption, ModelRequest

BASE, NO_HINT = "cocobench-v1", "cocobench-v1+no-hint"


def lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def landed(out: Path, record: dict) -> list[str]:
    document = json.loads((out / record["trajectory"]).read_text())
    return [d["parsed_call"] for d in document["planner_decisions"]]


@pytest.mark.slow
def test_random_under_two_prompt_arms_has_a_paired_difference_of_exactly_0(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--model", "random:3", "--suite", "demo", "--epochs", "2",
                 "--prompt-suite", BASE, "--prompt-suite", NO_HINT, "--out", str(out)]) == 0
    by_arm: dict[str, dict[tuple, dict]] = {BASE: {}, NO_HINT: {}}
    for record in lines(out):
        by_arm[record["arm"]][record["task_id"], record["epoch"]] = record
    assert by_arm[BASE].keys() == by_arm[NO_HINT].keys() and len(by_arm[BASE]) == 8
    for episode, base in by_arm[BASE].items():
        ablated = by_arm[NO_HINT][episode]
        for field in ("task_success", "task_progress", "construct_score", "num_steps",
                      "legal_plan"):
            assert base[field] == ablated[field], (episode, field)
        assert landed(out, base) == landed(out, ablated)
    # The arms did differ in what the model was sent.
    prompts = {arm: {d["prompt_hash"] for record in rows.values() for d in json.loads(
        (out / record["trajectory"]).read_text())["planner_decisions"]}
        for arm, rows in by_arm.items()}
    assert prompts[BASE] - prompts[NO_HINT]
    # Epochs still draw apart: the second epoch is not the first one again.
    assert any(landed(out, by_arm[BASE][task, 0]) != landed(out, by_arm[BASE][task, 1])
               for task, _ in by_arm[BASE])


def test_a_key_without_an_arm_draws_what_it_always_drew():
    assert stream_episode("random_3/C0_image/G_D1__x@e1") == "random_3/C0_image/G_D1__x@e1"
    assert stream_episode("G_D1__x") == "G_D1__x"
    assert stream_episode("random_3/C0_image/cocobench-v1_no-hint/G_D1__x@e1") == \
        "random_3/C0_image/G_D1__x@e1"


def test_arms_share_draws_and_seats_instances_and_epochs_do_not():
    menu = tuple(MenuOption(i, "Find", f"find({i})") for i in range(1, 40))

    def draws(episode: str, agent: str | None = "agent_1", sample: int = 0) -> list[str]:
        client = RandomClient("random", seed=0, episode=episode, agent=agent)
        request = ModelRequest("p", menu=menu, sample_index=sample)
        return [asyncio.run(client.complete(request)).text for _ in range(12)]

    base = draws("random/C0_image/a/T1")
    assert draws("random/C0_image/b/T1") == base  # another arm
    assert draws("random/C0_image/T1") == base  # no arm
    assert draws("random/C0_image/a/T2") != base  # another instance
    assert draws("random/C0_image/a/T1", agent="agent_2") != base  # another seat
    assert draws("random/C0_image/a/T1", sample=1) != base  # another epoch

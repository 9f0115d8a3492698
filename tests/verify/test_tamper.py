"""Every tamper of issue 40's acceptance is a `mismatch` naming the step and the field; an
untouched run verifies; what cannot be replayed is `unverifiable`, saying why."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from cocobench_agents.runfolder import result_key
from cocobench_agents.verify import Verdict, verify_run
from tests.verify.conftest import (
    episode_line,
    lines,
    prompts,
    trajectory,
    write_lines,
    write_trajectory,
)

CopyRun = Callable[[], Path]


def verdict_of(run: Path, line: dict[str, Any]) -> Verdict:
    outcome = verify_run(run, jobs=1)
    by_key = dict(outcome.verdicts)
    others = [v for k, v in outcome.verdicts if k != result_key(line)]
    assert all(v.status == "verified" for v in others), others  # only the tampered one
    return by_key[result_key(line)]


def landed(document: dict[str, Any]) -> list[int]:
    """Indexes of the trajectory items that landed a call."""
    return [i for i, item in enumerate(document["trajectory"]) if "skill_result" in item]


def test_an_untouched_run_verifies_and_exits_0(demo_run: Path, capsys) -> None:
    outcome = verify_run(demo_run, jobs=1)
    assert outcome.ok and outcome.counts["verified"] == 8, outcome.verdicts
    assert main(["verify", str(demo_run)]) == 0
    assert "8/8 episodes verified" in capsys.readouterr().out


def test_a_flipped_task_success_in_the_result_line(copy_run: CopyRun, capsys) -> None:
    run = copy_run()
    rows = lines(run)
    target = next(r for r in rows if r["condition"] == "C0_blind")
    target["task_success"] = 1 - target["task_success"]
    write_lines(run, rows)
    verdict = verdict_of(run, target)
    assert (verdict.status, verdict.field, verdict.step) == ("mismatch", "task_success", None)
    assert main(["verify", str(run)]) == 1
    out = capsys.readouterr().out
    assert "mismatch" in out and "task_success" in out and "7/8 episodes verified" in out


def test_a_flipped_step_success(copy_run: CopyRun) -> None:
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    step = landed(document)[2]
    result = document["trajectory"][step]["skill_result"]
    result["success"] = not result["success"]
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.step, verdict.field) == (
        "mismatch", step, "skill_result.success")


@pytest.mark.parametrize("edit", ["removed", "duplicated", "reordered"])
def test_a_step_removed_duplicated_or_reordered(copy_run: CopyRun, edit: str) -> None:
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    items = document["trajectory"]
    first, second = landed(document)[1:3]
    if edit == "removed":
        del items[first]
    elif edit == "duplicated":
        items.insert(first, json.loads(json.dumps(items[first])))
    else:
        items[first], items[second] = items[second], items[first]
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert verdict.status == "mismatch" and verdict.step is not None
    assert first <= verdict.step <= second + 1, verdict
    assert verdict.field, verdict


def test_a_calls_arguments_changed_with_everything_it_records(copy_run: CopyRun) -> None:
    """The call edited consistently (its label, its result's arguments, its decision):
    the replayed menu says the model's reply chose another call."""
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    step = next(i for i in landed(document)
                if document["trajectory"][i]["skill_result"]["skill"] == "PickUp")
    item = document["trajectory"][step]
    original = item["skill_result"]["args"]["objectId"]
    other = next(o for o in document["task_config"]["init_state"]["objects"].values()
                 if o != original)
    for holder in (item, item["skill_result"]["args"], item["policy_decision"],
                   *[d for d in document["planner_decisions"]
                     if d["step_index"] == item["policy_decision"]["step_index"]]):
        for name in ("label", "objectId", "parsed_call"):
            if isinstance(holder.get(name), str):
                holder[name] = holder[name].replace(original, other)
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert verdict.status == "mismatch" and verdict.step is not None, verdict
    assert verdict.step <= step, verdict
    assert verdict.field in ("skill_result.success", "policy_decision.parsed_call",
                             "state.agents[0].inventory", "skill_result.errorMessage"), verdict


def test_a_calls_label_changed_alone(copy_run: CopyRun) -> None:
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    step = landed(document)[0]
    item = document["trajectory"][step]
    item["label"] = item["label"].replace("agent_1", "agent_2")
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.step) == ("mismatch", step), verdict
    assert verdict.field.startswith(("skill_result", "state", "label")), verdict


def test_an_edited_task_config(copy_run: CopyRun) -> None:
    """Edited in the trajectory, and consistently replayed: the reference's own config of
    the instance (the demo suite's) tells."""
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    document["task_config"]["step_budget"] = 1000
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.field) == ("mismatch", "task_config.step_budget")
    assert "reference" in verdict.detail


def test_a_swapped_prompt_hash(copy_run: CopyRun) -> None:
    """Two decisions' prompt hashes swapped (each still names a kept prompt): the first one's
    prompt does not show its step's replayed menu."""
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    decisions = document["planner_decisions"]
    first, last = decisions[0], decisions[-1]
    assert first["prompt_hash"] != last["prompt_hash"]
    assert {first["prompt_hash"], last["prompt_hash"]} <= set(prompts(run, line))
    first["prompt_hash"], last["prompt_hash"] = last["prompt_hash"], first["prompt_hash"]
    for item in document["trajectory"]:
        decision = item.get("policy_decision")
        if decision is not None and decision["step_index"] in (first["step_index"],
                                                                last["step_index"]):
            item["policy_decision"] = next(d for d in decisions
                                           if d["step_index"] == decision["step_index"])
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.field) == ("mismatch", "policy_decision.prompt_hash")
    assert verdict.step == first["step_index"]


def test_a_prompt_text_edited(copy_run: CopyRun) -> None:
    import gzip

    run = copy_run()
    line = episode_line(run)
    kept = prompts(run, line)
    hashed = trajectory(run, line)["planner_decisions"][0]["prompt_hash"]
    kept[hashed] = kept[hashed].replace("GOAL", "G0AL")
    path = (run / line["trajectory"]).parent / "prompts.json.gz"
    path.write_bytes(gzip.compress(json.dumps(kept).encode()))
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.field, verdict.step) == (
        "mismatch", "policy_decision.prompt_hash", 0)


def test_an_episode_of_another_instance_renamed(copy_run: CopyRun) -> None:
    """Another instance's (better) episode copied over this one's, under this one's id."""
    run = copy_run()
    rows = lines(run)
    target = next(r for r in rows if r["condition"] == "C0_blind"
                  and r["task_id"].startswith("K_D3"))
    donor = next(r for r in rows if r["condition"] == "C0_blind" and r is not target)
    document = trajectory(run, donor)
    write_trajectory(run, target, document)
    verdict = verdict_of(run, target)
    assert (verdict.status, verdict.field) == ("mismatch", "task_id"), verdict
    document["task_id"] = document["task_config"]["task_id"] = target["task_id"]
    write_trajectory(run, target, document)
    verdict = verdict_of(run, target)
    assert verdict.status == "mismatch" and verdict.field.startswith("task_config."), verdict


def test_decentralized_rounds_verify_and_a_message_edit_is_found(copy_run: CopyRun) -> None:
    run = copy_run()
    line = episode_line(run, "D1_blind")
    document = trajectory(run, line)
    step = landed(document)[0]
    assert "round_index" in document["trajectory"][step]
    document["trajectory"][step]["state"]["agents"][1]["inventory"] = ["Apple|1|2|3"]
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.step, verdict.field) == (
        "mismatch", step, "state.agents[1].inventory")
    assert "Apple|1|2|3" in verdict.detail


def test_a_missing_trajectory_is_unverifiable(copy_run: CopyRun, capsys) -> None:
    run = copy_run()
    line = episode_line(run)
    (run / line["trajectory"]).unlink()
    outcome = verify_run(run, jobs=1)
    verdict = dict(outcome.verdicts)[result_key(line)]
    assert verdict.status == "unverifiable" and "no trajectory" in verdict.detail
    assert not outcome.ok
    assert main(["verify", str(run)]) == 1
    assert "unverifiable" in capsys.readouterr().out


def test_an_ai2thor_episode_is_unverifiable_but_its_metrics_are_checked(
        copy_run: CopyRun) -> None:
    run = copy_run()
    rows = lines(run)
    target = next(r for r in rows if r["condition"] == "C0_blind")
    target["backend"] = "ai2thor"
    write_lines(run, rows)
    verdict = verdict_of(run, target)
    assert verdict.status == "unverifiable" and "ai2thor" in verdict.detail
    target["num_steps"] += 1
    write_lines(run, rows)
    verdict = verdict_of(run, target)
    assert (verdict.status, verdict.field) == ("mismatch", "num_steps")


def test_an_infrastructure_error_is_unverifiable(copy_run: CopyRun) -> None:
    run = copy_run()
    rows = lines(run)
    target = rows[0]
    for name in ("trajectory", "num_steps"):
        target.pop(name)
    target["infra_error"] = "RateLimitError: slow down"
    write_lines(run, rows)
    verdict = verdict_of(run, target)
    assert verdict.status == "unverifiable" and "infrastructure" in verdict.detail


def test_an_invalid_result_line_fails_the_run(copy_run: CopyRun, capsys) -> None:
    run = copy_run()
    with (run / "results.jsonl").open("a") as f:
        f.write('{"model": "greedy", "task_success": "yes"}\n')
    assert not verify_run(run, jobs=1).ok
    assert main(["verify", str(run)]) == 1
    assert "invalid result" in capsys.readouterr().err


@pytest.mark.parametrize("path", ["nowhere", "results.jsonl"])
def test_not_a_run_folder_is_a_users_mistake(demo_run: Path, path: str, capsys) -> None:
    target = demo_run / path if path != "nowhere" else demo_run.parent / "nowhere"
    assert main(["verify", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cocobench: error:") and "Traceback" not in err


def test_parallel_and_serial_verdicts_agree(copy_run: CopyRun, monkeypatch) -> None:
    from cocobench_agents.verify import run as verify_module

    run = copy_run()
    rows = lines(run)
    rows[3]["task_success"] = 1 - rows[3]["task_success"]
    write_lines(run, rows)
    serial = verify_run(run, jobs=1)
    monkeypatch.setattr(verify_module, "CHUNK", 2)
    monkeypatch.setattr(verify_module, "PARALLEL_FROM", 1)
    parallel = verify_run(run, jobs=2)
    assert parallel.processes == 2
    assert parallel.verdicts == serial.verdicts
    assert serial.counts == {"verified": 7, "mismatch": 1}


def _leaves(value: Any, path: tuple = ()) -> list[tuple]:
    if isinstance(value, dict):
        return [leaf for k, v in value.items() for leaf in _leaves(v, (*path, k))]
    if isinstance(value, list):
        return [leaf for i, v in enumerate(value) for leaf in _leaves(v, (*path, i))]
    return [path]


JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False)
                    | st.text(max_size=20),
                    lambda inner: st.lists(inner, max_size=3)
                    | st.dictionaries(st.text(max_size=5), inner, max_size=3), max_leaves=6)


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_a_stranger_edits_any_field_and_verify_answers_with_a_verdict(demo_run: Path,
                                                                      data: Any) -> None:
    """Any leaf of a trajectory (its config, items, decisions) replaced by any JSON value:
    a verdict, never an exception; a verdict of `verified` only where the edit is one the
    recording does not depend on (a decision's own usage report). (Without the reference's
    configs, a config field no step reads, such as a resource's name, passed: the reference
    is what pins the config.)"""
    import copy

    from cocobench_agents.verify import reference_configs, verify_episode

    line = episode_line(demo_run)
    original = trajectory(demo_run, line)
    document = copy.deepcopy(original)
    path = data.draw(st.sampled_from(_leaves(document)))
    value = data.draw(JSON)
    holder = document
    for part in path[:-1]:
        holder = holder[part]
    holder[path[-1]] = value
    verdict = verify_episode(document, line, prompts=prompts(demo_run, line),
                             reference=reference_configs())
    assert verdict.status in ("verified", "mismatch")
    if verdict.status == "verified" and document != original:
        assert "policy_decision" in path or "planner_decisions" in path, (path, value)


def test_a_steps_decision_edited_apart_from_the_episodes_decisions(copy_run: CopyRun) -> None:
    run = copy_run()
    line = episode_line(run)
    document = trajectory(run, line)
    step = landed(document)[1]
    document["trajectory"][step]["policy_decision"]["raw_output"] = "ACTION: 13 (edited)"
    write_trajectory(run, line, document)
    verdict = verdict_of(run, line)
    assert (verdict.status, verdict.step, verdict.field) == ("mismatch", step,
                                                             "policy_decision")

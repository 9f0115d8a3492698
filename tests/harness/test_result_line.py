"""The result line's schema is the benchmark's `EpisodeResult` under the run folder's own
fields: its numbers and texts are checked by the types `EpisodeResult` gives them, and an
episode that could not run has a line built from the benchmark's `unrun_result`."""

from __future__ import annotations

import pytest

from benchmark_adapter.metrics import EpisodeResult, unrun_result
from benchmark_adapter.tasks import load_tasks
from cocobench_agents.runfolder import EpisodeKey, ResultLine, infra_error_line, line_error

KEY = EpisodeKey("greedy", "C0_image", "t1", 1)


@pytest.fixture(scope="module")
def infra_line() -> dict:
    config = load_tasks("demo")[0]
    return infra_error_line(KEY, "boom", unrun_result(
        config, planner="centralized", obs_mode="image", backend="embedded",
        prompt_suite="cocobench-v1", elapsed_s=0.5))


def test_an_infrastructure_errors_line_is_a_valid_failure(infra_line):
    assert line_error(infra_line) is None
    assert infra_line["task_success"] == 0 and infra_line["legal_plan"] == 0
    assert infra_line["infra_error"] == "boom"
    assert {k: infra_line[k] for k in ("model", "condition", "task_id", "epoch")} == \
        KEY.as_dict()


def test_the_benchmarks_fields_are_checked_by_their_own_types(infra_line):
    checked = set(ResultLine.model_fields)
    assert {"construct_score", "num_steps", "backend", "failure_kind"} <= checked
    own = {"model", "arm", "infra_error", "planner_error"}  # the run folder's, not the benchmark's
    assert checked - own <= set(EpisodeResult.model_fields)
    assert line_error({**infra_line, "backend": 5}).startswith("invalid result: backend:")
    assert line_error({**infra_line, "num_steps": "3"}).startswith("invalid result: num_steps:")
    assert line_error({**infra_line, "task_success": "1"}) is not None
    for error in ("infra_error", "planner_error"):  # the run folder's own texts
        assert line_error({**infra_line, error: 5}).startswith(f"invalid result: {error}:")
    assert line_error({**infra_line, "node": "n1", "requeued": True}) is None  # kept as is


def test_unrun_result_takes_only_the_runs_identifiers():
    with pytest.raises(TypeError, match="cell"):
        unrun_result(load_tasks("demo")[0], cell="A_D1")


@pytest.mark.parametrize("name", [".", "..", "...", "/..", "../.."])
def test_a_model_or_arm_named_by_dots_stays_in_its_own_folder(name):
    """A model (or arm) string of dots alone would name the folder above `episodes/`."""
    parts = EpisodeKey(name, "C0_blind", "t1", arm=name).folder().split("/")
    assert parts[0] == "episodes" and not {".", ".."} & set(parts)

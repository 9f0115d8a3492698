"""Every path the harness writes stays inside the run folder, whatever the episode key holds
(task ids are checked when configs load; this is the backstop for configs built in Python)."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    plan_episodes,
)
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder import EpisodeKey, RunFolder, RunFolderError


def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file()}


@pytest.mark.parametrize("task_id", ["../../../../escaped", "../../../..", "a\x00b"])
def test_a_key_that_would_leave_the_folder_is_refused(tmp_path: Path, task_id: str) -> None:
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "t"})
    before = files_under(tmp_path)
    with pytest.raises(RunFolderError, match="not inside the run folder"):
        folder.write_trajectory(EpisodeKey("greedy", "C0_blind", task_id), {"x": 1})
    assert files_under(tmp_path) == before


@pytest.mark.parametrize("relative", ["/tmp/abs/x.json", "..", ".", "a/../../x.json"])
def test_paths_outside_or_the_folder_itself_are_refused(tmp_path: Path, relative: str) -> None:
    with pytest.raises(RunFolderError, match="not inside the run folder"):
        RunFolder(tmp_path / "run").inside(relative)


def test_a_normal_key_is_written_inside(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path / "run")
    relative = folder.write_trajectory(EpisodeKey("openai/gpt-4o", "C0_blind", "T_1", 2), {})
    assert relative == "episodes/openai_gpt-4o/C0_blind/T_1@e2/trajectory.json"
    assert (tmp_path / "run" / relative).is_file()
    assert folder.inside("episodes/a/../b") == tmp_path / "run" / "episodes" / "b"


def test_an_escaping_episode_stops_the_run_and_writes_nothing_outside(tmp_path: Path) -> None:
    """A config built in Python skips the load-time checks; its trajectory is still refused."""
    config = next(c for c in load_tasks("demo") if c.cell == "G_D1")
    evil = config.model_copy(update={"task_id": "../../../../escaped"})
    episodes = plan_episodes([evil], ["greedy"], [Condition("centralized", "blind")], 1)
    folder = RunFolder(tmp_path / "out" / "run")
    folder.create({"name": "t"})
    with pytest.raises(RunFolderError, match="not inside the run folder"):
        InProcess().run(episodes, folder, ModelPool(ModelSettings()), ExecutionSettings(jobs=1))
    assert all(folder.path in p.parents for p in files_under(tmp_path))

"""Worker processes: episodes are pulled from one queue; a worker that dies is replaced and
its episodes run again alone; a runaway episode (memory, a loop that never yields) is
stopped and recorded naming the cause while the rest of the run goes on."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    WorkerProcesses,
    plan_episodes,
)
from cocobench_agents.harness.executor import on_recorded
from cocobench_agents.harness.runaway import RunawayLimits
from cocobench_agents.harness.workers import share
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder import RunFolder
from tests.harness.runaway_planners import RUNAWAY_TASK, SLOW_TASK

PLANTED = Path(__file__).with_name("runaway_planners.py")


def plan():
    return plan_episodes(load_tasks("demo"), ["random:7"],
                         [Condition("centralized", "blind"), Condition("decentralized", "blind")],
                         2)


def test_a_killed_worker_is_replaced_and_its_episodes_run_again(tmp_path):
    planned = plan()
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "dies"})
    killed = []

    def kill_a_worker(record):
        if not killed:
            victim = multiprocessing.active_children()[0]
            os.kill(victim.pid, signal.SIGKILL)
            killed.append(victim.name)

    WorkerProcesses().run(planned, folder, ModelPool(), ExecutionSettings(jobs=4, workers=2),
                          on_event=on_recorded(kill_a_worker))
    records = list(folder.results())
    keys = {(r["condition"], r["task_id"], r["epoch"]) for r in records}
    assert len(keys) == len(planned) == len(records)  # every episode once, none lost
    assert not any(r.get("infra_error") for r in records)
    # What the killed worker had in flight ran again (alone), and says so.
    assert any(r.get("requeued") == 1 for r in records)
    assert multiprocessing.active_children() == []


def test_jobs_and_model_limits_are_shared_out():
    assert [share(10, i, 3) for i in range(3)] == [4, 3, 3]
    assert [share(1, i, 2) for i in range(2)] == [1, 1]  # never below one


@pytest.mark.slow
def test_a_slow_episode_holds_back_only_itself(tmp_path):
    """Pulled, not dealt: while one worker (one slot each) waits on the slow episode, the
    other takes every other episode (dealt in turn, longest first, the slow one's worker
    would also have had the third)."""
    out = tmp_path / "run"
    result = _cocobench("run", "--suite", "demo", "--planner", f"{PLANTED}:slow",
                        "--model", "greedy", "--workers", "2", "--jobs", "2",
                        "--out", str(out))
    assert result.returncode == 0, result.stderr
    order = [r["task_id"] for r in _results(out)]
    assert sorted(order) == sorted(t.task_id for t in load_tasks("demo"))
    assert order[-1] == SLOW_TASK


RUNAWAYS = [("hog", ["--episode-memory", "300"], "memory"),
            ("spin", ["--stall-timeout", "3"], "stalled")]
EXECUTORS = [pytest.param(["--workers", "1"], id="1-worker"),
             pytest.param(["--workers", "2"], id="2-workers"),
             pytest.param(["--executor", "ray", "--workers", "2"], id="ray",
                          marks=pytest.mark.needs_ray)]


@pytest.mark.slow
@pytest.mark.parametrize("executor", EXECUTORS)
@pytest.mark.parametrize(("planner", "limit", "cause"), RUNAWAYS)
def test_a_runaway_is_recorded_by_cause_and_the_run_goes_on(tmp_path, executor, planner,
                                                            limit, cause):
    out = tmp_path / "run"
    result = _cocobench("run", "--suite", "demo", "--planner", f"{PLANTED}:{planner}",
                        "--model", "greedy", "--jobs", "4", *executor, *limit,
                        "--out", str(out))
    assert result.returncode == 1, result.stderr
    assert "--resume --retry-errors" in result.stderr
    assert f"stopped as runaways: 1 {cause}" in result.stderr, result.stderr[-3000:]
    records = {r["task_id"]: r for r in _results(out)}
    assert len(records) == 4  # the other episodes are all recorded
    runaway = records.pop(RUNAWAY_TASK)
    assert runaway["infra_error"].startswith(f"{cause}: ")
    assert f"ERROR {cause}: " in result.stdout + result.stderr
    assert not any(r.get("infra_error") for r in records.values())

    # --retry-errors runs it again (and it runs away again: recorded again, not hung).
    # (A planner file is code: a resume runs it only when given again.)
    again = _cocobench("run", "--out", str(out), "--resume", "--retry-errors",
                       "--planner", f"{PLANTED}:{planner}")
    assert again.returncode == 1, again.stderr
    latest = [r for r in _results(out) if r["task_id"] == RUNAWAY_TASK]
    assert len(latest) == 2 and latest[-1]["infra_error"].startswith(f"{cause}: ")


def test_a_ray_worker_builds_the_runs_planners_before_it_is_ready(monkeypatch):
    """A graph-only strategy compiles (and imports LangGraph) as the worker starts, not in
    its first episode: there, seconds of a silent loop on a busy machine were stopped as a
    stall (an innocent episode run alone on a fresh worker, recorded as a runaway)."""
    from cocobench_agents.graphs import compiled_graph, lookup
    from cocobench_agents.harness.ray_worker import EpisodeWorker
    from cocobench_agents.models import ModelSettings

    planner = f"{PLANTED}:spin"
    monkeypatch.setattr(lookup, "_COMPILED", {})
    EpisodeWorker(ModelSettings(), None, "worker-1", "embedded", (), (planner,))

    def compile_again(spec):
        raise AssertionError(f"{spec.name} compiled after the worker started")

    monkeypatch.setattr(lookup, "_compile", compile_again)
    assert compiled_graph(planner) is not None


def test_the_limits_say_what_stopped_a_worker():
    limits = RunawayLimits(episode_memory_mb=100, stall_s=5)
    mb = 1 << 20
    assert limits.breach(grown_bytes=150 * mb, in_flight=2, silent_s=0) is None
    assert limits.breach(grown_bytes=250 * mb, in_flight=2, silent_s=0) == "memory"
    assert limits.breach(grown_bytes=None, in_flight=1, silent_s=6) == "stalled"
    assert limits.breach(grown_bytes=0, in_flight=0, silent_s=60) is None  # idle: no stall
    assert limits.error("memory").startswith("memory: ")
    assert "--stall-timeout" in limits.error("stalled")


def _cocobench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cocobench_agents.cli", *args],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "NO_COLOR": "1"})


def _results(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def test_workers_that_always_crash_leave_every_episode_recorded_as_an_error(tmp_path,
                                                                             monkeypatch):
    """A worker process that dies at once, every time (a broken install, a native crash):
    each episode runs again alone once, then is recorded as an infrastructure error naming
    the exit code; the run ends, nothing is lost and no process is left behind."""
    from cocobench_agents.harness import workers

    monkeypatch.setattr(workers, "_work", lambda *args: os._exit(3))  # forked: inherited
    planned = plan()[:3]
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "crashes"})
    WorkerProcesses().run(planned, folder, ModelPool(), ExecutionSettings(jobs=2, workers=2))
    records = list(folder.results())
    assert len(records) == len(planned)
    assert all("worker process died (exit code 3)" in r["infra_error"] for r in records)
    assert multiprocessing.active_children() == []

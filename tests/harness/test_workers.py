"""Worker processes: a worker that dies is reported, loses only its unfinished episodes, and
the folder stays whole for --resume; the jobs and per-model limits are shared out."""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import signal

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    RunFolder,
    RunOptions,
    WorkerError,
    execute,
    execute_in_workers,
    pending_episodes,
    plan_episodes,
)
from cocobench_agents.harness.workers import _share_settings, share
from cocobench_agents.models import ModelPool, ModelSettings


def plan():
    return plan_episodes(load_tasks("demo"), ["random:7"],
                         [Condition("centralized", "blind"), Condition("decentralized", "blind")],
                         2, RunOptions())


def test_a_dead_worker_is_reported_and_the_rest_is_kept(tmp_path):
    planned = plan()
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "dies"})
    killed = []

    def kill_a_worker(record):
        if not killed:
            victim = multiprocessing.active_children()[0]
            os.kill(victim.pid, signal.SIGKILL)
            killed.append(victim.name)

    with pytest.raises(WorkerError, match="--resume") as info:
        execute_in_workers(planned, folder, ModelSettings(), jobs=2, workers=2,
                           on_result=kill_a_worker)
    assert killed[0] in str(info.value) and "exit code -9" in str(info.value)
    kept = list(folder.results())
    assert 1 <= len(kept) < len(planned)
    assert multiprocessing.active_children() == []

    todo = pending_episodes(planned, folder, retry_errors=False)
    assert len(todo) == len(planned) - len(kept)
    asyncio.run(execute(todo, folder, ModelPool(), jobs=4))
    keys = {(r["condition"], r["task_id"], r["epoch"]) for r in folder.results()}
    assert len(keys) == len(planned) == len(list(folder.results()))


def test_jobs_and_model_limits_are_shared_out():
    assert [share(10, i, 3) for i in range(3)] == [4, 3, 3]
    assert [share(1, i, 2) for i in range(2)] == [1, 1]  # never below one
    settings = ModelSettings(max_concurrency=16)
    assert [_share_settings(settings, i, 2).max_concurrency for i in range(2)] == [8, 8]

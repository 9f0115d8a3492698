"""The executors behind one interface: every name a request may give is registered, each
executor tells the same events in the same order, and an episode's settings have the run
request's defaults."""

from __future__ import annotations

import dataclasses
from typing import get_args

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec
from cocobench_agents.harness import Condition, plan_episodes
from cocobench_agents.harness.execution_settings import ExecutionSettings, ExecutorName
from cocobench_agents.harness.executor import (
    EpisodeRecorded,
    EpisodeStarted,
    Executor,
    ExecutorStarted,
    ExecutorStopped,
)
from cocobench_agents.harness.executors import EXECUTORS, IN_PROCESS, executor_named
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder import RunFolder


def test_every_executor_a_request_may_name_is_registered():
    assert set(EXECUTORS) == {*get_args(ExecutorName), IN_PROCESS}
    for name in get_args(ExecutorName):
        executor: Executor = executor_named(name)
        assert callable(executor.run) and callable(executor.check)


@pytest.mark.parametrize("name", [IN_PROCESS, "local"])
def test_an_executor_tells_the_run_in_order(name, tmp_path):
    planned = plan_episodes(load_tasks("demo")[:2], ["greedy"],
                            [Condition("centralized", "blind")], 1, max_steps=2)
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "events"})
    told: list = []
    executor_named(name).run(planned, folder, ModelPool(), ExecutionSettings(jobs=2),
                             on_event=told.append)
    kinds = [type(event) for event in told]
    assert kinds[0] is ExecutorStarted and kinds[-1] is ExecutorStopped
    assert kinds.count(EpisodeStarted) == kinds.count(EpisodeRecorded) == len(planned)
    recorded = [e.record for e in told if isinstance(e, EpisodeRecorded)]
    assert sorted(r["task_id"] for r in recorded) == sorted(p.key.task_id for p in planned)
    assert len(list(folder.results())) == len(planned)


def test_an_episodes_defaults_are_the_run_requests():
    defaults = {f.name: f.default for f in dataclasses.fields(EpisodeSpec)
                if f.default is not dataclasses.MISSING}
    fields = RunRequest.model_fields
    request = {name: info.get_default(call_default_factory=True)
               for name, info in fields.items() if name != "out"}
    assert defaults["planner"] == request["planners"][0]
    assert defaults["obs_mode"] == request["obs_modes"][0]
    assert defaults["prompt_suite"] == request["prompt_suites"][0]
    for name in ("backend", "max_steps", "stable_ids"):
        assert defaults[name] == request[name], name
    models = next(f for f in dataclasses.fields(EpisodeSpec) if f.name == "models")
    assert set(models.default_factory()) == {DEFAULT_MODEL_KEY}  # type: ignore[misc]

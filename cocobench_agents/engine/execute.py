"""Executing a run: its pending episodes handed to the executor the request names
(`harness.executors`), its limits made the executor's `Bounds`, the executor's events made
the engine's. A run a person plays runs in this process, in turn, whatever the request
names. Nothing here imports Ray until a Ray run starts."""

from __future__ import annotations

from collections.abc import Sequence

from cocobench_agents.engine import events
from cocobench_agents.engine.events import EventHandler
from cocobench_agents.engine.request import ExecutionSettings, RunRequest
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.executor import (
    Bounds,
    ExecutorEvent,
    ExecutorStarted,
    ExecutorStopped,
)
from cocobench_agents.harness.executors import IN_PROCESS, executor_named
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder.folder import RunFolder


def check_executor(execution: ExecutionSettings) -> None:
    """What can be checked of the executor before anything is recorded (Ray installed, the
    cluster's address answering: `RayUnavailable`, a user error)."""
    executor_named(execution.executor).check(execution)


def execute(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            request: RunRequest, *, limit: SpendLimit | None, emit: EventHandler) -> None:
    """Run `episodes` into `folder` with `pool`, as `request.execution` says, within `limit`
    and the request's limits; `emit` hears what the executor tells (where a Ray run's
    workers are, each episode's start, steps of episodes run here, and each result line)."""
    execution = request.execution
    name = execution.executor
    if request.has_human_seats:  # one person answers one decision at a time
        name, execution = IN_PROCESS, execution.model_copy(update={"jobs": 1})
    limits = request.limits
    bounds = Bounds(limit, limits.episode_timeout_s(human=False),
                    limits.episode_timeout_s(human=True), limits.runaway(request.backend))
    executor_named(name).run(episodes, folder, pool, execution, bounds=bounds,
                             on_event=lambda event: _tell(event, emit))


def _tell(event: ExecutorEvent, emit: EventHandler) -> None:
    """An executor's event as the engine's (the episode events are the same types)."""
    if isinstance(event, ExecutorStarted):
        if event.where is not None:
            emit(events.Notice(event.where, warning=False))
    elif not isinstance(event, ExecutorStopped):
        emit(event)

"""The interface every executor implements: what it is given, what it tells.

An executor runs a run's pending episodes into its run folder: in this process
(`batch.InProcess`), in worker processes (`workers.WorkerProcesses`) or on Ray
(`ray_executor.RayExecutor`); `executors` names them. Each is called the same way and tells
the same events, whichever it is, so the engine (and a test) never asks which one runs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.runaway import DEFAULT_LIMITS, RunawayLimits

if TYPE_CHECKING:
    from cocobench_agents.harness.episodes import PlannedEpisode
    from cocobench_agents.harness.execution_settings import ExecutionSettings
    from cocobench_agents.models import ModelPool
    from cocobench_agents.runfolder import RunFolder


@dataclass(frozen=True)
class ExecutorStarted:
    """The executor can start episodes: `capacities`, the episodes each of its workers runs
    at once; `where`, what the user is told of where they run (None: nothing to tell)."""

    capacities: tuple[int, ...]
    where: str | None = None


@dataclass(frozen=True)
class EpisodeStarted:
    """An episode began (its key as in result lines: model, condition, arm, task, epoch,
    and its seats' `models`)."""

    key: dict[str, Any]


@dataclass(frozen=True)
class StepLanded:
    """One step of an episode run in this process landed in the simulator (its trajectory
    item); executors that run episodes elsewhere tell none."""

    key: dict[str, Any]
    step: dict[str, Any]


@dataclass(frozen=True)
class EpisodeRecorded:
    """An episode's result line was appended to the run folder."""

    record: dict[str, Any]


@dataclass(frozen=True)
class ExecutorStopped:
    """The executor started its last episode and recorded every one it started (or stopped
    early: the exception it raises next says why)."""


ExecutorEvent = ExecutorStarted | EpisodeStarted | StepLanded | EpisodeRecorded | ExecutorStopped
ExecutorEventHandler = Callable[[ExecutorEvent], None]


def ignore(event: ExecutorEvent) -> None:
    """The handler of a run nobody watches."""


@dataclass(frozen=True)
class Bounds:
    """What stops episodes: the run's `spend` limit (no episode starts once it is reached),
    each episode's wall-clock timeout (with a human seat, `human_timeout_s`), and the watch
    on workers that run away (`runaway`)."""

    spend: SpendLimit | None = None
    episode_timeout_s: float | None = None
    human_timeout_s: float | None = None
    runaway: RunawayLimits = field(default=DEFAULT_LIMITS)


NO_BOUNDS = Bounds()


class Executor(Protocol):
    """Runs episodes into a run folder, as the request's `ExecutionSettings` say.

    `run` appends each result line as its episode ends (the executor is the run folder's
    single writer) and tells `on_event`: `ExecutorStarted` before the first episode,
    `EpisodeStarted` and `EpisodeRecorded` for each, `ExecutorStopped` once it is done. It
    raises `FatalModelError` once the episodes in flight are recorded, when one met a fatal
    model error; `RunFolderWriteError` when the folder cannot be written; `WorkerError` (or
    `WorkersLost`) when its workers cannot run episodes."""

    def check(self, settings: ExecutionSettings) -> None:
        """What can be checked before anything is recorded (a user error if it fails)."""

    def run(self, episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            settings: ExecutionSettings, *, bounds: Bounds = NO_BOUNDS,
            on_event: ExecutorEventHandler = ignore) -> None: ...


def on_recorded(callback: Callable[[dict[str, Any]], None]) -> ExecutorEventHandler:
    """A handler that gives `callback` each recorded result line, and ignores the rest."""

    def handle(event: ExecutorEvent) -> None:
        if isinstance(event, EpisodeRecorded):
            callback(event.record)

    return handle

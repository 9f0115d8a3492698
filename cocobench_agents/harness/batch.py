"""The in-process executor: a run's episodes as asyncio tasks of this process.

Model calls are the bottleneck and overlap, while simulator steps run on the event loop
between them. Results for a deterministic model do not depend on `jobs` (each episode owns
its world, clients and random streams). A run a person plays runs here, one episode at a
time (one person answers one decision at a time), those with a human seat first; the other
executors run each episode with `run_one` too.
"""

from __future__ import annotations

import asyncio
import functools
import time
from collections.abc import Callable, Sequence
from typing import Any

from benchmark_adapter.metrics import unrun_result
from cocobench_agents.episode_runner import ClientFactory, has_human_seat, run_episode
from cocobench_agents.graphs.node_errors import PlannerNodeError, is_strategy_code
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.errors import FatalModelError, fatal_model_error
from cocobench_agents.harness.execution_settings import ExecutionSettings
from cocobench_agents.harness.executor import (
    NO_BOUNDS,
    Bounds,
    EpisodeRecorded,
    EpisodeStarted,
    ExecutorEventHandler,
    ExecutorStarted,
    ExecutorStopped,
    StepLanded,
    ignore,
)
from cocobench_agents.models import ModelPool
from cocobench_agents.models.secrets import redact
from cocobench_agents.runfolder.errors import RunFolderError, RunFolderWriteError
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.result_line import infra_error_line, planner_error_line

StepCallback = Callable[[dict[str, Any], dict[str, Any]], None]  # key, landed step


class InProcess:
    """The `Executor` that runs episodes in this process, `settings.jobs` at a time."""

    def check(self, settings: ExecutionSettings) -> None:
        """Nothing to check: this process runs them."""

    def run(self, episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            settings: ExecutionSettings, *, bounds: Bounds = NO_BOUNDS,
            on_event: ExecutorEventHandler = ignore) -> None:
        """Run every episode, those with a human seat first, then close the pool: its
        kept-alive connections belong to this run's event loop."""
        on_event(ExecutorStarted((settings.jobs,)))
        try:
            asyncio.run(_run_and_close(episodes, folder, pool, jobs=settings.jobs,
                                       bounds=bounds, on_event=on_event))
        finally:
            on_event(ExecutorStopped())


async def _run_and_close(episodes: Sequence[PlannedEpisode], folder: RunFolder,
                         pool: ModelPool, **options: Any) -> None:
    try:
        await run_batch(episodes, folder, pool, **options)
    finally:
        await pool.aclose()


async def run_batch(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ClientFactory,
                    *, jobs: int = 1, bounds: Bounds = NO_BOUNDS,
                    on_event: ExecutorEventHandler = ignore) -> None:
    """Run every episode, at most `jobs` at a time, those with a human seat first (the
    person is there when the run starts), then longest step budget first, appending each
    result as it finishes and telling `on_event` of its start, steps and result line. Once
    the spend limit is reached, or an episode met a fatal model error, no further episode
    starts.

    A fatal model error (`fatal_model_error`: the key refused, no such model) halts the batch:
    every later episode would fail the same way. Once the episodes in
    flight are stored, that `FatalModelError` is raised."""
    gate = asyncio.Semaphore(max(1, jobs))
    limit = bounds.spend
    fatal: list[FatalModelError] = []

    def on_step(key: dict[str, Any], step: dict[str, Any]) -> None:
        on_event(StepLanded(key, step))

    async def one(planned: PlannedEpisode, human: bool) -> None:
        async with gate:
            # Left pending: --resume (with a higher limit, or once the key is fixed) runs it.
            if fatal or (limit is not None and limit.reached()):
                return
            on_event(EpisodeStarted(start_key(planned)))
            timeout = bounds.human_timeout_s if human else bounds.episode_timeout_s
            record, document = await run_one(planned, folder, pool, timeout_s=timeout,
                                             on_step=None if on_event is ignore else on_step)
        folder.append_result(record)
        on_event(EpisodeRecorded(record))
        error = fatal_model_error(record, document)
        if error is not None:
            fatal.append(error)

    humans = {id(p): has_human_seat(p.spec) for p in episodes}
    ordered = sorted(longest_first(episodes), key=lambda p: not humans[id(p)])
    # Tasks take the gate in creation order.
    await asyncio.gather(*(one(p, humans[id(p)]) for p in ordered))
    if fatal:
        raise fatal[0]


def start_key(planned: PlannedEpisode) -> dict[str, Any]:
    """What `EpisodeStarted` tells of an episode: its key and its seats' `models`."""
    return {**planned.key.as_dict(), "models": planned.spec.identifiers()["models"]}


def longest_first(episodes: Sequence[PlannedEpisode]) -> list[PlannedEpisode]:
    """`episodes` by step budget, longest first (stable): a long episode started last would
    run alone at the end of a run; this order keeps every slot busy until near the end."""
    return sorted(episodes, key=lambda p: -(p.spec.budget or 0))


async def run_one(planned: PlannedEpisode, folder: RunFolder, pool: ClientFactory, *,
                  timeout_s: float | None = None,
                  on_step: StepCallback | None = None
                  ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """One episode → its result line and its trajectory document (None when it could not
    run). Whatever the episode raises, in any phase (a model's reply, parsing, the simulator,
    scoring, writing its trajectory), and running past `timeout_s` of wall-clock time, make
    it an infrastructure error naming the exception's type and message; only a run folder
    that cannot be used (`RunFolderError`, `RunFolderWriteError`) is raised: it is not this
    episode failing, and the run stops with it."""
    started = time.perf_counter()
    try:
        return await _run_and_write(planned, folder, pool, timeout_s=timeout_s,
                                    on_step=on_step, started=started)
    except (RunFolderError, RunFolderWriteError):
        raise
    except Exception as exc:  # noqa: BLE001 - one broken episode must not stop the run
        elapsed = time.perf_counter() - started
        error = redact(repr(exc), _secrets(pool))  # a dead Unity's reads `ThorCrashed(…`
        if isinstance(exc, TimeoutError) and timeout_s is not None and elapsed >= timeout_s:
            error = timeout_error(timeout_s)
        return infra_error_record(planned, error, elapsed), None


async def _run_and_write(planned: PlannedEpisode, folder: RunFolder, pool: ClientFactory, *,
                         timeout_s: float | None, on_step: StepCallback | None,
                         started: float) -> tuple[dict[str, Any], dict[str, Any] | None]:
    key, spec = planned.key, planned.spec
    step_hook = None if on_step is None else functools.partial(on_step, key.as_dict())
    try:
        document, result = await asyncio.wait_for(
            run_episode(spec, pool, controller=spec.controller(), on_step=step_hook),
            timeout_s)
    except PlannerNodeError as exc:  # its trajectory shows what led to the node's exception
        # A researcher's strategy failed on its own; a built-in planner's failure is ours.
        kind = planner_error_record if is_strategy_code(spec.planner) else infra_error_record
        record = kind(planned, redact(str(exc), _secrets(pool)), time.perf_counter() - started)
        return store_trajectory(folder, planned, record, exc.document)
    result = result.model_copy(update={
        "condition": key.condition, "epoch": key.epoch,
        "elapsed_s": round(time.perf_counter() - started, 3)})
    return store_trajectory(folder, planned, {**result.model_dump(mode="json"),
                                              **key.as_dict()}, document)


def store_trajectory(folder: RunFolder, planned: PlannedEpisode, record: dict[str, Any],
                     document: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Write `document`, the trajectory of `record`'s episode, and name it in `record`. A
    document the run folder cannot hold (text that is not valid UTF-8, a value JSON cannot
    write) makes the episode an infrastructure error naming why (then no document); a folder
    that cannot be written raises (`RunFolderWriteError`): the run stops."""
    try:
        record["trajectory"] = folder.write_trajectory(planned.key, document)
    except (RunFolderError, RunFolderWriteError):
        raise
    except Exception as exc:  # noqa: BLE001 - the document's fault, not the folder's
        error = f"the trajectory could not be written: {described(exc)}"
        elapsed = float(record.get("elapsed_s") or 0.0)
        if record.get("planner_error"):  # still the strategy's failure, first of all
            return planner_error_record(planned, f"{record['planner_error']}\n{error}",
                                        elapsed), None
        before = record.get("infra_error")
        return infra_error_record(planned, f"{before}; {error}" if before else error,
                                  elapsed), None
    return record, document


def described(exc: BaseException) -> str:
    """An exception as a result line names it: its type and its message."""
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def timeout_error(timeout_s: float) -> str:
    """The `infra_error` of an episode that ran past `timeout_s` (``--episode-timeout``)."""
    return f"episode timed out after {timeout_s:g} s of wall-clock time (--episode-timeout)"


def infra_error_record(planned: PlannedEpisode, error: str, elapsed: float) -> dict[str, Any]:
    """The result line of an episode that could not run (scored as a failure, as the
    reference does for runner_failed / timeout)."""
    return infra_error_line(planned.key, _writable(error), _unrun(planned, elapsed))


def planner_error_record(planned: PlannedEpisode, error: str, elapsed: float
                         ) -> dict[str, Any]:
    """The result line of an episode the planner's own code ended (`PlannerNodeError`):
    a failure, counted apart from infrastructure errors and never retried as one."""
    return planner_error_line(planned.key, _writable(error), _unrun(planned, elapsed))


def _unrun(planned: PlannedEpisode, elapsed: float) -> dict[str, Any]:
    spec = planned.spec
    return unrun_result(spec.config, planner=spec.planner, obs_mode=spec.obs_mode,
                        backend=spec.backend, prompt_suite=spec.prompt_suite,
                        elapsed_s=round(elapsed, 3))


def _writable(error: str) -> str:
    """An exception's message may hold text no UTF-8 file holds (a lone surrogate): escaped,
    so that the line can be written."""
    return error.encode("utf-8", "backslashreplace").decode("utf-8")


def _secrets(pool: ClientFactory) -> list[str]:
    """The credentials the pool's settings carry (inline keys, URL passwords), to scrub."""
    settings = getattr(pool, "settings", None)
    return settings.secrets() if settings is not None else []

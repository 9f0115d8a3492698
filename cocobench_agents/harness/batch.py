"""Running a plan into a run folder with bounded concurrency.

Episodes run as asyncio tasks: model calls are the bottleneck and overlap, while simulator
steps run on the event loop between them. Results for a deterministic model do not depend on
`jobs` (each episode owns its world, clients and random streams).
"""

from __future__ import annotations

import asyncio
import functools
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from benchmark_adapter.metrics import unrun_result
from cocobench_agents.episode_runner import ClientFactory, run_episode
from cocobench_agents.graphs.node_errors import PlannerNodeError
from cocobench_agents.harness.errors import FatalModelError, fatal_model_error
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.models import ModelPool
from cocobench_agents.models.secrets import redact
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.result_line import infra_error_line

ResultCallback = Callable[[dict[str, Any]], None]
# The episode's key and its seats' `models`, as in result lines.
StartCallback = Callable[[dict[str, Any]], None]
StepCallback = Callable[[dict[str, Any], dict[str, Any]], None]  # key, landed step


class Halt(Protocol):
    """A flag that stops the starting of episodes: a `threading.Event`, or a
    `multiprocessing` one that worker processes share."""

    def is_set(self) -> bool: ...

    def set(self) -> None: ...


async def execute(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ClientFactory,
                  *, jobs: int = 1, on_result: ResultCallback | None = None,
                  store_result: ResultCallback | None = None,
                  limit: SpendLimit | None = None,
                  episode_timeout_s: float | None = None,
                  on_start: StartCallback | None = None,
                  on_step: StepCallback | None = None,
                  halt: Halt | None = None) -> None:
    """Run every episode, at most `jobs` at a time, longest step budget first, storing each
    result as it finishes (appended to the folder's results, unless `store_result` takes it),
    then `on_result`. Once `limit` is reached, or `halt` is set, no further episode starts.
    `on_start` and `on_step` hear of each episode's start and landed steps.

    An episode that met a fatal model error (`fatal_model_error`: the key refused, no such
    model) sets `halt`: every later episode would fail the same way. Once the episodes in
    flight are stored, that `FatalModelError` is raised."""
    gate = asyncio.Semaphore(max(1, jobs))
    store = folder.append_result if store_result is None else store_result
    halt = threading.Event() if halt is None else halt
    fatal: list[FatalModelError] = []

    async def one(planned: PlannedEpisode) -> None:
        async with gate:
            # Left pending: --resume (with a higher limit, or once the key is fixed) runs it.
            if halt.is_set() or (limit is not None and limit.reached()):
                return
            if on_start is not None:
                on_start(start_key(planned))
            record, document = await run_one(planned, folder, pool,
                                             timeout_s=episode_timeout_s, on_step=on_step)
        store(record)
        if on_result is not None:
            on_result(record)
        error = fatal_model_error(record, document)
        if error is not None:
            fatal.append(error)
            halt.set()

    # Tasks take the gate in creation order.
    await asyncio.gather(*(one(p) for p in longest_first(episodes)))
    if fatal:
        raise fatal[0]


async def execute_and_close(episodes: Sequence[PlannedEpisode], folder: RunFolder,
                            pool: ModelPool, **options: Any) -> None:
    """`execute`, then close the pool: its kept-alive connections belong to this event loop."""
    try:
        await execute(episodes, folder, pool, **options)
    finally:
        await pool.aclose()


def start_key(planned: PlannedEpisode) -> dict[str, Any]:
    """What `on_start` hears of an episode: its key and its seats' `models`."""
    return {**planned.key.as_dict(), "models": planned.spec.identifiers()["models"]}


def longest_first(episodes: Sequence[PlannedEpisode]) -> list[PlannedEpisode]:
    """`episodes` by step budget, longest first (stable): a long episode started last would
    run alone at the end of a run; this order keeps every slot busy until near the end."""
    return sorted(episodes, key=lambda p: -(p.spec.budget or 0))


async def run_one(planned: PlannedEpisode, folder: RunFolder, pool: ClientFactory, *,
                  timeout_s: float | None = None,
                  on_step: StepCallback | None = None
                  ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """One episode → its result line (an infrastructure failure, or running past `timeout_s`
    of wall-clock time, becomes an error line) and its trajectory document (None when it
    could not run)."""
    key, spec = planned.key, planned.spec
    started = time.perf_counter()
    step_hook = None if on_step is None else functools.partial(on_step, key.as_dict())
    try:
        document, result = await asyncio.wait_for(
            run_episode(spec, pool, controller=spec.controller(), on_step=step_hook),
            timeout_s)
    except PlannerNodeError as exc:  # its trajectory shows what led to the node's exception
        record = infra_error_record(planned, redact(str(exc), _secrets(pool)),
                                    time.perf_counter() - started)
        record["trajectory"] = folder.write_trajectory(key, exc.document)
        return record, exc.document
    except Exception as exc:  # noqa: BLE001 - one broken episode must not stop the run
        elapsed = time.perf_counter() - started
        error = redact(repr(exc), _secrets(pool))
        if isinstance(exc, TimeoutError) and timeout_s is not None and elapsed >= timeout_s:
            error = (f"episode timed out after {timeout_s:g} s of wall-clock time "
                     "(--episode-timeout)")
        return infra_error_record(planned, error, elapsed), None
    # Outside the try: a run folder that cannot be written stops the run
    # (`RunFolderWriteError`); it is not this episode failing.
    relative = folder.write_trajectory(key, document)
    result = result.model_copy(update={
        "condition": key.condition, "epoch": key.epoch, "trajectory": relative,
        "elapsed_s": round(time.perf_counter() - started, 3)})
    return {**result.model_dump(mode="json"), **key.as_dict()}, document


def infra_error_record(planned: PlannedEpisode, error: str, elapsed: float) -> dict[str, Any]:
    """The result line of an episode that could not run (scored as a failure, as the
    reference does for runner_failed / timeout)."""
    spec = planned.spec
    return infra_error_line(planned.key, error, unrun_result(
        spec.config, planner=spec.planner, obs_mode=spec.obs_mode, backend=spec.backend,
        prompt_suite=spec.prompt_suite, elapsed_s=round(elapsed, 3)))


def _secrets(pool: ClientFactory) -> list[str]:
    """The credentials the pool's settings carry (inline keys, URL passwords), to scrub."""
    settings = getattr(pool, "settings", None)
    return settings.secrets() if settings is not None else []

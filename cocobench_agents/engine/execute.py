"""Running the pending episodes of a run on the executor the request names: worker processes
watched by this one (local), or Ray; a run a person plays runs here, in turn. Nothing here
imports Ray until a Ray run starts."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from typing import Any

from cocobench_agents.engine.request import ExecutionSettings, RunRequest
from cocobench_agents.episode_runner import has_human_seat
from cocobench_agents.harness.batch import ResultCallback
from cocobench_agents.harness.batch import execute as execute_batch
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.workers import available_cores, execute_in_workers
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder.folder import RunFolder


def check_executor(execution: ExecutionSettings) -> None:
    """What can be checked of the executor before anything is recorded: Ray installed, the
    cluster's address answering (`RayUnavailable`, a user error)."""
    if execution.executor != "ray":
        return
    from cocobench_agents.harness.ray_session import check_reachable, require_ray

    require_ray()
    if execution.ray_address:
        check_reachable(execution.ray_address)


def execute(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            request: RunRequest, *, on_result: ResultCallback, limit: SpendLimit | None,
            notify: Callable[[str], None], **hooks: Any) -> None:
    """Run `episodes` into `folder` as `request.execution` says (a run with human seats: in
    turn, here, whatever it says); each result goes to `on_result` once appended. `hooks`:
    ``on_start`` hears of every episode's start, ``on_step`` of the steps of episodes run in
    this process (a person's)."""
    execution = request.execution
    if request.has_human_seats:
        asyncio.run(_in_turn(episodes, folder, pool, request, on_result=on_result,
                             limit=limit, **hooks))
        return
    options: dict[str, Any] = {"limit": limit,
                               "episode_timeout_s": request.limits.episode_timeout_s(human=False),
                               "runaway": request.limits.runaway(request.backend)}
    if execution.executor == "ray":
        _on_ray(episodes, folder, pool, execution, on_result, notify, options)
        return
    workers = 1 if execution.workers is None else execution.workers or available_cores()
    execute_in_workers(episodes, folder, pool.settings, jobs=execution.jobs, workers=workers,
                       on_result=on_result, on_start=hooks.get("on_start"), **options)


async def _in_turn(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
                   request: RunRequest, **options: Any) -> None:
    """A run a person plays: one episode after another in this process (one person answers
    the decisions one at a time), those with a human seat first (the person is there when
    the run starts), each under its own kind's episode timeout."""
    with_person = [p for p in episodes if has_human_seat(p.spec)]
    models_only = [p for p in episodes if not has_human_seat(p.spec)]
    try:
        for group, human in ((with_person, True), (models_only, False)):
            if group:
                timeout = request.limits.episode_timeout_s(human=human)
                await execute_batch(group, folder, pool, jobs=1, episode_timeout_s=timeout,
                                    **options)
    finally:
        await pool.aclose()


def _on_ray(episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            execution: ExecutionSettings, on_result: ResultCallback,
            notify: Callable[[str], None], options: dict[str, Any]) -> None:
    from cocobench_agents.harness.ray_executor import RayOptions, execute_on_ray

    ray_options = RayOptions(address=execution.ray_address, workers=execution.workers or 0,
                             thor_gpus_per_worker=execution.thor_gpus_per_worker,
                             wait_s=execution.ray_wait)
    where = execution.ray_address or "a local Ray"
    execute_on_ray(episodes, folder, pool.settings, jobs=execution.jobs, options=ray_options,
                   on_result=on_result, **options,
                   on_start=lambda shape: notify(f"{shape.describe()} on {where}"))

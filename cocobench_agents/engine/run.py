"""The engine: `run(request)` runs a `RunRequest` into its run folder and returns the results.

Every door ends here: `cocobench run` (flags, config files, ``COCOBENCH_RUN_*``) and
`evaluate()` build a request and call `run`; the executors it picks (this process, worker
processes, the Ray driver) take the request's own settings types. The engine
prints nothing and imports neither click nor rich; it tells a front end what happens through
`on_event` (`events`), and raises `RequestError` for a mistake in the request (nothing run)
or `RunStopped` when a run stops early (what finished is recorded).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from cocobench_agents.engine import events
from cocobench_agents.engine.errors import (
    ExecutorFailed,
    ModelRefused,
    RequestError,
    RunFolderFailed,
    RunInterrupted,
    resume_command,
)
from cocobench_agents.engine.events import EventHandler
from cocobench_agents.engine.execute import check_executor, execute
from cocobench_agents.engine.records import request_from_record, run_record
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.engine.resolve import ResolvedRun, canonical, resolve
from cocobench_agents.engine.results import EvalResults, collect_results
from cocobench_agents.engine.resume import (
    check_credentials_given,
    check_same_plan,
    refused_changes,
)
from cocobench_agents.episode_runner import has_human_seat
from cocobench_agents.graphs import NO_MODEL
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.errors import FatalModelError, WorkerError, WorkersLost
from cocobench_agents.harness.human_log import LoggedDesk
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.pending import pending_episodes
from cocobench_agents.models import ModelPool
from cocobench_agents.models.human import SeatDesk
from cocobench_agents.models.settings import unset_sampling_notice
from cocobench_agents.runfolder.errors import RunFolderWriteError
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.summary import latest

_NO_DESK = ("human seats need a player: run it with `cocobench run` (it serves a play page), "
            "or pass desk=… to run()")
_HUMAN_ON_RAY = ("human seats need the local executor (--executor local): the person answers "
                 "through this process, which Ray workers cannot reach")


def run(request: RunRequest, *, resume: bool = False, retry_errors: bool = False,
        on_event: EventHandler | None = None, desk: SeatDesk | None = None) -> EvalResults:
    """Run every episode of `request` into ``request.out`` and return the results of every
    planned episode. With `resume`, complete the run recorded there (a shaping setting that
    differs from the record is refused); with `retry_errors` too, run its infrastructure
    failures again.

    Human seats (the model ``human``) are asked on `desk`, one decision at a time, awaited
    on the run's own event loop; their answers are logged in the run folder
    (`harness.human_log`), so a resumed run asks none of them again."""
    emit = on_event or events.ignore
    request = canonical(request)
    folder = RunFolder(request.out)
    with folder.lock() as lock:
        if lock.stale_pid:
            emit(events.Notice(f"{folder.path}: taking over the lock of pid {lock.stale_pid}, "
                               "which ended without releasing it"))
        try:
            record = folder.open_for_resume() if resume else None
        except RunFolderWriteError as exc:  # a torn last line that cannot be cut off
            raise RunFolderFailed(folder.path, exc) from None
        if not resume:  # an occupied folder is refused before any check that calls a model
            folder.check_unused()
        for warning in folder.warnings:
            emit(events.Notice(warning))
        resolved = _checked(request, record, folder, emit)
        todo = resolved.episodes if record is None else pending_episodes(
            resolved.episodes, folder, retry_errors=retry_errors)
        pool = ModelPool(request.model_settings, desk=_logged_desk(desk, request, todo, folder))
        limits = request.limits
        limit = SpendLimit(limits.max_cost, limits.max_total_tokens,
                           spent=latest(folder.results()))
        # A finished run is only summarised (no model stack to load, no key to need), and a
        # run already at its spend limit starts nothing: neither calls a model.
        if todo and not limit.reached():
            if record is not None:  # a new run's names were checked before it resolved
                _check_model_names(request)
            _check_planners_and_endpoints(pool, resolved)
            if resolved.remote_model_modes and (notice := unset_sampling_notice(
                    request.model_settings, resolved.called_models)):
                emit(events.Notice(notice))
        if record is None:
            folder.create(run_record(resolved))
        total = len(resolved.episodes)
        emit(events.RunStarted(folder.path, total, total - len(todo),
                               _recorded(resolved.episodes, todo, folder)))
        stopped = _execute(todo, folder, pool, request, emit, total, limit) if todo else None
    return collect_results(folder, stopped)


async def run_async(request: RunRequest, **options: Any) -> EvalResults:
    """`run` for code already inside an event loop (notebooks, servers): the run goes on a
    thread, which runs its own event loop."""
    return await asyncio.to_thread(run, request, **options)


def _checked(request: RunRequest, record: dict[str, Any] | None, folder: RunFolder,
             emit: EventHandler) -> ResolvedRun:
    """The resolved request, after every check that needs nothing but the request and the
    recorded run (each failure a `RequestError` or another user error: nothing written)."""
    check_credentials_given(request)
    if record is None:  # a new run: a mistyped model or a missing key is told before any
        _check_model_names(request)  # instance loads (a resume may have nothing to run)
    else:
        recorded = canonical(request_from_record(record, folder.record_path))
        refused = refused_changes(recorded, request)
        if refused:
            raise RequestError("\n".join(refused))
    if request.has_human_seats and request.execution.executor == "ray":
        raise RequestError(_HUMAN_ON_RAY)
    check_executor(request.execution)
    if request.execution.executor == "local":  # Ray workers check the node they run on
        from benchmark_adapter.sim.backends import check_backend

        check_backend(request.backend)
    resolved = resolve(request, lambda message: emit(events.Notice(message)))
    if record is not None:
        from cocobench_agents.graphs.plugins import check_unchanged as planners_unchanged
        from cocobench_agents.prompts import check_unchanged as suite_unchanged

        planners_unchanged([c.planner for c in resolved.conditions],
                           record.get("planners") or {})
        check_same_plan(resolved, record)
        _check_suites_unchanged(resolved, record, suite_unchanged)
    return resolved


def _check_suites_unchanged(resolved: ResolvedRun, record: dict[str, Any],
                            unchanged: Callable[..., None]) -> None:
    """Refuse a resumed run's prompt suite whose files changed since it was recorded."""
    if not resolved.arms:
        unchanged(resolved.suites[0], record.get("prompt_suite") or {})
        return
    recorded = {r.get("arm"): r for r in record.get("prompt_suites") or []
                if isinstance(r, dict)}
    for suite in resolved.suites:  # the arms themselves are checked with the plan
        unchanged(suite, recorded.get(suite.label) or {})


def _recorded(planned: list[PlannedEpisode], todo: list[PlannedEpisode],
              folder: RunFolder) -> tuple[dict[str, Any], ...]:
    """The result lines of the planned episodes that will not run again."""
    if len(todo) == len(planned):  # a new run, or nothing recorded yet
        return ()
    pending = {p.key for p in todo}
    done = folder.scan_results().done
    return tuple(done[p.key] for p in planned if p.key not in pending and p.key in done)


def _logged_desk(desk: SeatDesk | None, request: RunRequest, todo: list[PlannedEpisode],
                 folder: RunFolder) -> LoggedDesk | None:
    """`desk` behind the run's answer logs, when an episode to run has a human seat (a
    `RequestError` without a desk); None when none has."""
    if not request.has_human_seats or not any(has_human_seat(p.spec) for p in todo):
        return None
    if desk is None:
        raise RequestError(_NO_DESK)
    return LoggedDesk(desk, folder)


def _check_model_names(request: RunRequest) -> None:
    """Unknown models and missing API keys among the models `request` names."""
    pool = ModelPool(request.model_settings)
    for model in [*request.models, *request.agent_models.values()]:
        if model != NO_MODEL:  # the rows of a planner that calls no model
            pool.validate(model)


def _check_planners_and_endpoints(pool: ModelPool, resolved: ResolvedRun) -> None:
    """User planners (one demo episode each) and, unless the request says not to, one
    pre-flight call per remote model and input kind."""
    from cocobench_agents.harness.planner_check import check_planners

    check_planners(c.planner for c in resolved.conditions)
    if resolved.request.preflight:
        from cocobench_agents.models.preflight import preflight

        preflight(pool, resolved.called_models, resolved.remote_model_modes)


def _execute(todo: list, folder: RunFolder, pool: ModelPool, request: RunRequest,
             emit: EventHandler, total: int, limit: SpendLimit) -> str | None:
    """Run the pending episodes within `limit`; why the run stopped starting episodes (a
    spend limit), or None. Interruptions and failures of the folder or executor raise
    `RunStopped`."""
    recorded = 0

    def on_event(event: events.Event) -> None:
        nonlocal recorded
        if isinstance(event, events.EpisodeRecorded):
            recorded += 1
            limit.add(event.record)  # before the executor asks whether to start another
        emit(event)

    try:
        execute(todo, folder, pool, request, limit=limit if limit.active else None,
                emit=on_event)
    except RunFolderWriteError as exc:
        raise RunFolderFailed(folder.path, exc) from None
    except KeyboardInterrupt:
        raise RunInterrupted(folder.path, total - len(todo) + recorded, total) from None
    except FatalModelError as exc:
        raise ModelRefused(folder.path, exc) from None
    except WorkersLost as exc:
        raise ExecutorFailed(f"{exc}: {resume_command(folder.path)}", folder.path) from None
    except WorkerError as exc:
        raise ExecutorFailed(str(exc), folder.path) from None
    left = len(todo) - recorded
    if left and limit.reached():
        flag = ("--max-cost USD" if request.limits.max_cost is not None
                else "--max-total-tokens N")
        message = (f"spend limit reached ({limit.describe()}): {left} episodes not started; "
                   "raise the limit and finish the run with: "
                   f"{resume_command(folder.path, flag)}")
        emit(events.LimitReached(limit.describe(), left))
        return message
    return None

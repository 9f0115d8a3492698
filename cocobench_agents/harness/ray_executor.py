"""The Ray executor: episodes spread over worker actors on one machine or a cluster.

The driver stays the single writer of the run folder: workers return each episode's
trajectory and result line, and the driver writes and appends them with the same
`RunFolder` methods as a local run, so a folder written through Ray is the same as a local
one (resume rules included) but for two fields of its result lines: ``node``, the Ray node
that ran the episode, and ``requeued``, on an episode that was queued again.

The fleet follows the cluster. Episodes wait in one queue, and every started worker takes
from it, the least busy first, with at most `jobs` episodes in flight across the cluster. A
worker that dies (its process, its node, its Unity) is dropped, and its episodes in flight go
back to the front of the queue, once each, to run alone. The driver also watches each worker
(`runaway`): one past its memory budget, or whose event loop stops answering, is killed; the
episode that does it again alone is recorded as an infrastructure error naming the cause; an
episode still in flight `OVERDUE_GRACE_S` past its timeout is recorded as timed out and its
worker stopped, so the driver never waits on one that will not come back. A new worker
starts whenever Ray has room for one (a node that joined, resources set free), up to
`workers`; the run never waits for one while another can take episodes, and stops
(`WorkersLost`) when none has been alive for `ray_wait`.
Model calls hold a permit of the run's `ConcurrencyLimiter`, so `max_concurrency` is a limit
per model across the cluster.

This module is the driver's loop: it keeps the workers busy; `ray_fleet` starts and ends
them, `ray_watch` watches for runaways, `ray_results` records what comes back. Importing it
does not import Ray.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from collections.abc import Sequence
from typing import Any

from benchmark_adapter.vocabulary import AI2THOR
from cocobench_agents.graphs import planner_spec
from cocobench_agents.harness.batch import longest_first, start_key, timeout_error
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.execution_settings import ExecutionSettings
from cocobench_agents.harness.executor import (
    NO_BOUNDS,
    Bounds,
    EpisodeStarted,
    ExecutorEventHandler,
    ExecutorStarted,
    ExecutorStopped,
    ignore,
)
from cocobench_agents.harness.ray_fleet import WAIT_S, Fleet, Halt, WorkerSpec, fleet_shape
from cocobench_agents.harness.ray_results import InFlight, ResultCollector
from cocobench_agents.harness.ray_session import ray_session
from cocobench_agents.harness.ray_watch import RunawayWatch
from cocobench_agents.harness.ray_worker import run_key_variables
from cocobench_agents.harness.workers import OVERDUE_GRACE_S, available_cores
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder import RunFolder


class RayExecutor:
    """The `Executor` of ``--executor ray``: the request's `ExecutionSettings` say which
    cluster (`ray_address`; None starts a private local Ray), how many workers (`workers`;
    None or 0: as many as the cluster allows, following it as nodes join and leave), each
    AI2-THOR worker's GPU share and how long the run goes on with no worker alive
    (`ray_wait`). What a request does not say: a private local Ray's `local_cpus` (default:
    this machine's cores, at least the workers) and `local_gpus` (default: those Ray
    detects), and the workers' Ray `runtime_env` (environment variables, a setup hook, …)."""

    def __init__(self, *, local_cpus: int | None = None, local_gpus: float | None = None,
                 runtime_env: dict[str, Any] | None = None) -> None:
        self.local_cpus, self.local_gpus, self.runtime_env = local_cpus, local_gpus, runtime_env

    def check(self, settings: ExecutionSettings) -> None:
        """Ray installed, the cluster's address answering (`RayUnavailable`, a user error)."""
        from cocobench_agents.harness.ray_session import check_reachable, require_ray

        require_ray()
        if settings.ray_address:
            check_reachable(settings.ray_address)

    def run(self, episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            settings: ExecutionSettings, *, bounds: Bounds = NO_BOUNDS,
            on_event: ExecutorEventHandler = ignore) -> None:
        """Run every episode on Ray, its workers calling models as `pool.settings` say,
        appending each result as it arrives; `ExecutorStarted` tells the first fleet before
        the first episode. Once the spend limit is reached no further episode is
        dispatched; an episode running past its timeout ends as an infrastructure error,
        and one that runs away (`bounds.runaway`) as one naming the cause (as in a local
        run).

        The run stops early, what finished recorded, with `WorkerError` (workers cannot
        start), `WorkerEnvironmentError` (a worker's node lacks a key variable of the run),
        both before any episode when the first fleet starts (after the episodes in flight,
        for a worker that joins later); with `WorkersLost` when no worker has been alive for
        `settings.ray_wait`; and with `FatalModelError` once the episodes in flight are
        recorded, as a local run."""
        if not episodes:
            return
        workers = settings.workers or 0
        local_cpus = self.local_cpus or max(available_cores(), workers)
        with ray_session(settings.ray_address, local_cpus=local_cpus,
                         local_gpus=self.local_gpus, runtime_env=self.runtime_env):
            import ray

            jobs, backend = settings.jobs, episodes[0].spec.backend
            shape = fleet_shape(ray.cluster_resources(), backend=backend, jobs=jobs,
                                workers=workers,
                                thor_gpus_per_worker=settings.thor_gpus_per_worker,
                                episodes=len(episodes))
            where = settings.ray_address or "a local Ray"
            on_event(ExecutorStarted(shape.capacities, f"{shape.describe()} on {where}"))
            spec = WorkerSpec(shape, backend, per_worker=1 if backend == AI2THOR else jobs,
                              most=min(workers or jobs, jobs),
                              keys=run_key_variables(pool.settings, _models(episodes)),
                              planners=tuple(dict.fromkeys(p.spec.planner for p in episodes)))
            fleet = Fleet(ray, spec, pool.settings, run_name=folder.path.name,
                          wait_s=settings.ray_wait, halt=Halt())
            dispatch = _Dispatch(fleet, folder, jobs=jobs, bounds=bounds, on_event=on_event)
            try:
                # As many as Ray can place now (a node still counted but just lost holds
                # none); the others start once there is room.
                fleet.start(min(len(shape.capacities),
                                max(1, shape.fits(ray.available_resources()))))
                dispatch.run(longest_first(episodes))
            finally:
                dispatch.stop()
                on_event(ExecutorStopped())


def _models(episodes: Sequence[PlannedEpisode]) -> list[str]:
    """The models the episodes call (the oracle's condition calls none)."""
    calls: dict[str, bool] = {}
    out: dict[str, None] = {}
    for planned in episodes:
        planner = planned.spec.planner
        if planner not in calls:
            calls[planner] = planner_spec(planner).uses_models
        if calls[planner]:
            out.update(dict.fromkeys(planned.spec.models.values()))
    return list(out)


class _Dispatch:
    """The driver's loop: the queue, the episodes in flight, at most `jobs` of them."""

    def __init__(self, fleet: Fleet, folder: RunFolder, *, jobs: int, bounds: Bounds,
                 on_event: ExecutorEventHandler) -> None:
        self.fleet, self.ray, self.halt = fleet, fleet.ray, fleet.halt
        self.jobs, self.limit, self.timeout_s = jobs, bounds.spend, bounds.episode_timeout_s
        self.on_event = on_event
        self.watch = RunawayWatch(fleet, bounds.runaway)
        self.results = ResultCollector(fleet, folder, runaway=bounds.runaway, halt=fleet.halt,
                                       on_event=on_event)
        self.in_flight: dict[Any, InFlight] = {}

    def run(self, episodes: list[PlannedEpisode]) -> None:
        """Keep the workers busy until every episode has a result line (or the run stops:
        then raise why, once the episodes in flight are recorded)."""
        queue = deque(episodes)
        while queue or self.in_flight:
            if self.halt.reason is not None or (self.limit is not None
                                                and self.limit.reached()):
                queue.clear()  # left pending: --resume runs them
            self.fleet.grow(len(queue))
            self._fill(queue)
            self.watch.watch()
            self._end_overdue()
            self.fleet.check_alive(len(queue) + len(self.in_flight))
            waiting = [*self.in_flight, *self.fleet.starting]
            if not waiting:  # no worker, none starting: the cluster has no room yet
                time.sleep(WAIT_S)
                continue
            ready, _ = self.ray.wait(waiting, num_returns=1, timeout=WAIT_S)
            for ref in ready:
                if ref in self.fleet.starting:
                    self.fleet.started(ref)
                else:
                    self.results.collect(ref, self.in_flight.pop(ref), queue)
        if self.halt.reason is not None:
            raise self.halt.reason

    def _end_overdue(self) -> None:
        """Record an episode still in flight `OVERDUE_GRACE_S` past its timeout as timed out
        (its worker's own timeout should have ended it) and stop that worker: the driver
        never waits on an episode that will not come back. The worker's other episodes are
        lost with it (queued again alone, once)."""
        if self.timeout_s is None:
            return
        now = time.perf_counter()
        for ref, job in list(self.in_flight.items()):
            if now - job.started > self.timeout_s + OVERDUE_GRACE_S:
                del self.in_flight[ref]
                self.results.overdue(job, timeout_error(self.timeout_s))

    def _fill(self, queue: deque[PlannedEpisode]) -> None:
        """Send queued episodes to the least busy workers, `jobs` in flight at most; an
        episode that must run alone waits for an idle worker."""
        while queue and len(self.in_flight) < self.jobs:
            alone = queue[0].key in self.results.alone
            free = [w for w in self.fleet.workers if not w.alone
                    and (w.busy == 0 if alone else w.busy < self.fleet.spec.per_worker)]
            if not free:
                return
            worker = min(free, key=lambda w: w.busy)
            planned = queue.popleft()
            self.in_flight[worker.actor.run.remote(planned, self.timeout_s)] = (
                InFlight(planned, worker, alone=alone))
            worker.busy += 1
            worker.alone = alone
            self.on_event(EpisodeStarted(start_key(planned)))

    def stop(self) -> None:
        """Cancel what is in flight; let workers stop their Unity, then end them."""
        # On the way out (maybe after Ctrl-C, maybe with the cluster gone): do what can be
        # done, never hide the reason for leaving.
        with contextlib.suppress(self.ray.exceptions.RayError):
            for ref in self.in_flight:
                self.ray.cancel(ref)
            self.fleet.stop()

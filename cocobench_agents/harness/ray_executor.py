"""Running a plan on Ray: episodes spread over worker actors on one machine or a cluster.

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
episode that does it again alone is recorded as an infrastructure error naming the cause. A
new worker starts whenever Ray has room for one
(a node that joined, resources set free), up to `workers`; the run never waits for one while
another can take episodes, and stops (`WorkersLost`) when none has been alive for `wait_s`.
Model calls hold a permit of the run's `ConcurrencyLimiter`, so `max_concurrency` is a limit
per model across the cluster.

Importing this module does not import Ray.
"""

from __future__ import annotations

import contextlib
import time
import uuid
from collections import Counter, deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.vocabulary import AI2THOR
from cocobench_agents.graphs import planner_spec
from cocobench_agents.harness.batch import ResultCallback, infra_error_record, longest_first
from cocobench_agents.harness.errors import (
    WorkerEnvironmentError,
    WorkerError,
    WorkersLost,
    fatal_model_error,
)
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.ray_limit import limiter_actor
from cocobench_agents.harness.ray_session import RayUnavailable, ray_session
from cocobench_agents.harness.ray_worker import (
    WATCH_GROUP,
    EpisodeWorker,
    KeyVariables,
    WorkerInfo,
    run_key_variables,
    unity_died,
)
from cocobench_agents.harness.runaway import DEFAULT_LIMITS, RunawayLimits
from cocobench_agents.harness.workers import available_cores, share
from cocobench_agents.models import ModelSettings, redact
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.folder import RunFolder

WAIT_S = 0.5  # the driver wakes this often: Ctrl-C, room for a worker, the wait_s clock
GROW_EVERY_S = 1.0  # how often the driver asks Ray whether another worker would fit
HEALTH_EVERY_S = 1.0  # how often the driver asks each worker for its memory
CLOSE_TIMEOUT_S = 30.0  # for workers to stop their Unity before they are killed


@dataclass(frozen=True)
class RayOptions:
    """How to run on Ray.

    * `address`: the cluster's head (``HOST:PORT``, or ``auto``); None starts a private local
      Ray with `local_cpus` CPUs (default: this machine's cores, at least `workers`) and
      `local_gpus` GPUs (default: those Ray detects).
    * `workers`: the most worker actors at once; 0 = as many as the cluster's resources allow
      (and `jobs`), following the cluster as nodes join and leave.
    * `thor_gpus_per_worker`: the GPU share each AI2-THOR worker asks for (0: CPU nodes).
    * `runtime_env`: Ray's runtime environment of the run's workers (environment variables,
      a setup hook, …).
    * `wait_s`: how long the run goes on with no worker alive (its nodes lost, no room for
      another) before it stops with `WorkersLost` (``--ray-wait``).
    """

    address: str | None = None
    workers: int = 0
    thor_gpus_per_worker: float = 0.25
    local_cpus: int | None = None
    local_gpus: float | None = None
    runtime_env: dict[str, Any] | None = None
    wait_s: float = 300.0

    def __post_init__(self) -> None:
        if self.wait_s <= 0:
            raise ValueError(f"wait_s must be > 0, got {self.wait_s}")


@dataclass(frozen=True)
class FleetShape:
    """The first workers of a run: how many episodes each runs at once, what each asks Ray
    for."""

    capacities: tuple[int, ...]
    num_cpus: float = 1.0
    num_gpus: float = 0.0

    def describe(self) -> str:
        gpus = f", {self.num_gpus:g} GPU each" if self.num_gpus else ""
        return (f"{len(self.capacities)} Ray worker{'s' if len(self.capacities) > 1 else ''}"
                f" ({sum(self.capacities)} episodes at once{gpus})")

    def fits(self, resources: Mapping[str, float]) -> int:
        """How many more workers `resources` (what Ray has free) would hold."""
        count = int(resources.get("CPU", 0) / self.num_cpus + 1e-9)
        if self.num_gpus:
            count = min(count, int(resources.get("GPU", 0) / self.num_gpus + 1e-9))
        return count


def fleet_shape(resources: Mapping[str, float], *, backend: str, jobs: int, workers: int,
                thor_gpus_per_worker: float, episodes: int) -> FleetShape:
    """How many workers fit the cluster's `resources` and the request: an embedded worker
    takes a CPU and shares the `jobs`; an AI2-THOR worker (one Unity) takes a CPU and its GPU
    share and runs one episode at a time."""
    cpus = int(resources.get("CPU", 0))
    if cpus < 1:
        raise RayUnavailable("the Ray cluster has no CPU to run workers on")
    if backend != AI2THOR:
        count = max(1, min(workers or cpus, cpus, jobs, episodes))
        return FleetShape(tuple(share(jobs, i, count) for i in range(count)))
    fit = cpus
    if thor_gpus_per_worker > 0:
        gpus = float(resources.get("GPU", 0))
        if gpus < thor_gpus_per_worker:
            raise RayUnavailable(
                f"the Ray cluster has {gpus:g} GPUs and each AI2-THOR worker asks for "
                f"{thor_gpus_per_worker:g} (--thor-gpus-per-worker): add GPU nodes, or pass "
                "--thor-gpus-per-worker 0 to render on CPU nodes (X display needed)")
        fit = min(cpus, int(gpus / thor_gpus_per_worker + 1e-9))
    count = max(1, min(workers or fit, fit, jobs, episodes))
    return FleetShape((1,) * count, num_gpus=thor_gpus_per_worker)


def execute_on_ray(episodes: Sequence[PlannedEpisode], folder: RunFolder,
                   settings: ModelSettings, *, jobs: int, options: RayOptions = RayOptions(),
                   on_result: ResultCallback | None = None,
                   on_start: Callable[[FleetShape], None] | None = None,
                   limit: SpendLimit | None = None,
                   episode_timeout_s: float | None = None,
                   runaway: RunawayLimits = DEFAULT_LIMITS) -> None:
    """Run every episode on Ray, appending each result as it arrives, then `on_result`;
    `on_start(shape)` is told the first fleet before the first episode. Once `limit` is
    reached no further episode is dispatched; an episode running past `episode_timeout_s`
    ends as an infrastructure error, and one that runs away (`runaway`) as one naming the
    cause (as in a local run).

    The run stops early, what finished recorded, with `WorkerError` (workers cannot start),
    `WorkerEnvironmentError` (a worker's node lacks a key variable of the run), both before
    any episode when the first fleet starts (after the episodes in flight, for a worker
    that joins later); with `WorkersLost` when no worker has been alive for
    `options.wait_s`; and with `FatalModelError` once the episodes in flight are recorded,
    as a local run."""
    if not episodes:
        return
    local_cpus = options.local_cpus or max(available_cores(), options.workers)
    with ray_session(options.address, local_cpus=local_cpus, local_gpus=options.local_gpus,
                     runtime_env=options.runtime_env):
        import ray

        backend = episodes[0].spec.backend
        shape = fleet_shape(ray.cluster_resources(), backend=backend,
                            jobs=jobs, workers=options.workers,
                            thor_gpus_per_worker=options.thor_gpus_per_worker,
                            episodes=len(episodes))
        if on_start is not None:
            on_start(shape)
        fleet = _Fleet(shape, backend, per_worker=1 if backend == AI2THOR else jobs,
                       most=min(options.workers or jobs, jobs),
                       keys=run_key_variables(settings, _models(episodes)))
        run = _Run(folder, settings, fleet, jobs=jobs, wait_s=options.wait_s,
                   on_result=on_result, limit=limit, episode_timeout_s=episode_timeout_s,
                   runaway=runaway)
        try:
            # As many as Ray can place now (a node still counted but just lost holds none);
            # the others start once there is room.
            run.start(min(len(shape.capacities),
                          max(1, shape.fits(ray.available_resources()))))
            run.dispatch(longest_first(episodes))
        finally:
            run.stop()


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


@dataclass(frozen=True)
class _Fleet:
    """What every worker of the run is: its Ray resources and backend, the episodes it runs
    at once at most (`per_worker`), how many there may be (`most`), the key variables its
    node must have."""

    shape: FleetShape
    backend: str
    per_worker: int
    most: int
    keys: KeyVariables


@dataclass(eq=False)
class _Worker:
    """A worker actor: `info` once it has started; its permits are held as `holder`."""

    actor: Any
    holder: str
    info: WorkerInfo | None = None
    busy: int = 0
    alone: bool = False  # running an episode that must run by itself
    health: Any = None  # the `health` call in flight
    asked: float = 0.0  # when it was sent
    stopped_for: str | None = None  # the runaway cause it was killed for


@dataclass
class _InFlight:
    planned: PlannedEpisode
    worker: _Worker
    started: float = field(default_factory=time.perf_counter)
    alone: bool = False


class _Run:
    """The driver's side of a Ray run: the fleet, the queue, the single writer."""

    def __init__(self, folder: RunFolder, settings: ModelSettings, fleet: _Fleet, *,
                 jobs: int, wait_s: float, on_result: ResultCallback | None,
                 limit: SpendLimit | None, episode_timeout_s: float | None,
                 runaway: RunawayLimits = DEFAULT_LIMITS) -> None:
        import ray

        self.ray, self.folder, self.settings, self.fleet = ray, folder, settings, fleet
        self.jobs, self.wait_s, self.on_result = jobs, wait_s, on_result
        self.limit, self.episode_timeout_s, self.runaway = limit, episode_timeout_s, runaway
        self.actor_class = ray.remote(concurrency_groups={WATCH_GROUP: 1})(EpisodeWorker)
        self.limiter: Any = None
        self.launched = 0
        self.starting: dict[Any, _Worker] = {}  # the `ready` call of each → the worker
        self.workers: list[_Worker] = []  # started, and not known dead
        self.in_flight: dict[Any, _InFlight] = {}
        self.requeued: Counter[EpisodeKey] = Counter()
        self.alone: set[EpisodeKey] = set()  # queued again: they run by themselves
        self.halt: Exception | None = None  # why no further episode is dispatched
        self.alone_since: float | None = None  # since when no worker has been alive
        self.ever_alive = False
        self.next_growth = 0.0

    # -- the fleet --------------------------------------------------------------------------

    def start(self, count: int) -> None:
        """Start the limiter and `count` workers, and wait (up to `wait_s`) until each has
        started: a worker that cannot start, or whose node lacks a key, stops the run before
        any episode. Workers still waiting for room after `wait_s` join when placed."""
        name = f"cocobench-limiter-{self.folder.path.name}-{uuid.uuid4().hex[:8]}"
        self.limiter = limiter_actor(self.settings.max_concurrency, name)
        for _ in range(count):
            self._launch()
        self.alone_since = time.monotonic()
        while self.starting and time.monotonic() < self.alone_since + self.wait_s:
            ready, _ = self.ray.wait(list(self.starting), num_returns=1, timeout=WAIT_S)
            for ref in ready:
                self._started(ref)
            if self.halt is not None:
                raise self.halt

    def _launch(self) -> None:
        self.launched += 1
        holder = f"worker-{self.launched}"
        actor = self.actor_class.options(
            num_cpus=self.fleet.shape.num_cpus, num_gpus=self.fleet.shape.num_gpus,
            max_concurrency=self.fleet.per_worker + 1,  # one more for close()
        ).remote(self.settings, self.limiter, holder, self.fleet.backend, self.fleet.keys)
        self.starting[actor.ready.remote()] = _Worker(actor, holder)

    def _started(self, ref: Any) -> None:
        """A worker answered `ready` (or failed to start)."""
        worker = self.starting.pop(ref)
        try:
            info: WorkerInfo = self.ray.get(ref)
        except self.ray.exceptions.RayActorError as exc:
            self._kill(worker)
            if exc.actor_init_failed:  # its __init__ raised: any worker of the run would
                # The last line of a failed start is the error its __init__ raised.
                self._stop_with(WorkerError(f"Ray workers could not start: "
                                            f"{_gist(exc, last=True)}"))
            return  # its node went away first: another takes its place when there is room
        if info.missing:
            self._kill(worker)
            self._stop_with(WorkerEnvironmentError(info.missing, info.node, info.host))
            return
        worker.info = info
        self.workers.append(worker)
        self.ever_alive = True

    def _grow(self, queued: int) -> None:
        """Start workers for queued episodes where Ray has room now (a node joined, a lost
        worker's resources came free), at most once a second and a batch at a time: while a
        worker is starting (or waiting for room) none is added, so workers the cluster
        cannot place never pile up."""
        now = time.monotonic()
        if self.halt is not None or self.starting or not queued or now < self.next_growth:
            return
        self.next_growth = now + GROW_EVERY_S
        wanted = min(self.fleet.most - len(self.workers), queued)
        if wanted > 0:
            for _ in range(min(wanted, self.fleet.shape.fits(self.ray.available_resources()))):
                self._launch()

    def _drop(self, worker: _Worker, *, graceful: bool) -> None:
        """Take a dead (or Unity-less) worker out of the fleet and hand back its permits."""
        if worker not in self.workers:
            return  # another of its episodes reported it first
        self.workers.remove(worker)
        self.limiter.release_holder.remote(worker.holder)
        if graceful:
            self._close([worker.actor])
        else:
            self._kill(worker)

    def _kill(self, worker: _Worker) -> None:
        # A worker Ray reports unavailable may still be running: end it, so that it spends
        # no more model calls on episodes queued again elsewhere, and its share of the
        # cluster comes free for a replacement.
        with contextlib.suppress(self.ray.exceptions.RayError):
            self.ray.kill(worker.actor)

    def _check_alive(self, left: int) -> None:
        """Raise `WorkersLost` when no worker has been alive for `wait_s`."""
        if self.workers:
            self.alone_since = None
            return
        now = time.monotonic()
        if self.alone_since is None:
            self.alone_since = now
        elif left and now - self.alone_since >= self.wait_s:
            cause = ("the nodes that ran them are gone" if self.ever_alive
                     else "none could start")
            raise WorkersLost(self.wait_s, left, f"{cause}, and the cluster has no room for "
                                                 f"one ({self.fleet.shape.describe()})")

    def stop(self) -> None:
        """Cancel what is in flight; let workers stop their Unity, then end them."""
        # On the way out (maybe after Ctrl-C, maybe with the cluster gone): do what can be
        # done, never hide the reason for leaving.
        with contextlib.suppress(self.ray.exceptions.RayError):
            for ref in self.in_flight:
                self.ray.cancel(ref)
            for worker in self.starting.values():
                self._kill(worker)
            self._close([worker.actor for worker in self.workers])
            if self.limiter is not None:
                self.ray.kill(self.limiter)

    def _close(self, actors: list[Any]) -> None:
        closing = [actor.close.remote() for actor in actors]
        self.ray.wait(closing, num_returns=len(closing), timeout=CLOSE_TIMEOUT_S)
        for actor in actors:
            self.ray.kill(actor)

    # -- the queue --------------------------------------------------------------------------

    def dispatch(self, episodes: list[PlannedEpisode]) -> None:
        """Keep the workers busy until every episode has a result line (or the run stops:
        then raise why, once the episodes in flight are recorded)."""
        queue = deque(episodes)
        while queue or self.in_flight:
            if self.halt is not None or (self.limit is not None and self.limit.reached()):
                queue.clear()  # left pending: --resume runs them
            self._grow(len(queue))
            self._fill(queue)
            self._watch()
            self._check_alive(len(queue) + len(self.in_flight))
            waiting = [*self.in_flight, *self.starting]
            if not waiting:  # no worker, none starting: the cluster has no room yet
                time.sleep(WAIT_S)
                continue
            ready, _ = self.ray.wait(waiting, num_returns=1, timeout=WAIT_S)
            for ref in ready:
                if ref in self.starting:
                    self._started(ref)
                else:
                    self._collect(ref, queue)
        if self.halt is not None:
            raise self.halt

    def _fill(self, queue: deque[PlannedEpisode]) -> None:
        """Send queued episodes to the least busy workers, `jobs` in flight at most; an
        episode that must run alone waits for an idle worker."""
        while queue and len(self.in_flight) < self.jobs:
            alone = queue[0].key in self.alone
            free = [w for w in self.workers if not w.alone
                    and (w.busy == 0 if alone else w.busy < self.fleet.per_worker)]
            if not free:
                return
            worker = min(free, key=lambda w: w.busy)
            planned = queue.popleft()
            self.in_flight[worker.actor.run.remote(planned, self.episode_timeout_s)] = (
                _InFlight(planned, worker, alone=alone))
            worker.busy += 1
            worker.alone = alone

    def _watch(self) -> None:
        """Ask each worker for its memory every `HEALTH_EVERY_S`; kill one past its budget,
        or busy and silent past the stall limit (its episodes then fail in `_collect`)."""
        now = time.monotonic()
        for worker in list(self.workers):
            if worker.health is not None:
                ready, _ = self.ray.wait([worker.health], timeout=0)
                if not ready:  # the whole process is stuck (frozen, swapping)
                    self._stop_runaway(worker, self.runaway.breach(
                        grown_bytes=None, in_flight=worker.busy, silent_s=now - worker.asked))
                    continue
                rss, silent = self._answer(worker.health)
                worker.health = None
                start = worker.info.rss if worker.info is not None else None
                grown = None if rss is None or start is None else rss - start
                if self._stop_runaway(worker, self.runaway.breach(
                        grown_bytes=grown, in_flight=worker.busy, silent_s=silent)):
                    continue
            if now - worker.asked >= HEALTH_EVERY_S:
                worker.asked = now
                worker.health = worker.actor.health.options(
                    concurrency_group=WATCH_GROUP).remote()

    def _answer(self, ref: Any) -> tuple[int | None, float]:
        try:
            return self.ray.get(ref)
        except self.ray.exceptions.RayError:
            return None, 0.0  # the worker is gone: its episodes report it

    def _stop_runaway(self, worker: _Worker, cause: str | None) -> bool:
        if cause is None:
            return False
        worker.stopped_for = cause
        self._drop(worker, graceful=False)
        return True

    def _collect(self, ref: Any, queue: deque[PlannedEpisode]) -> None:
        job = self.in_flight.pop(ref)
        job.worker.busy -= 1
        if job.alone:
            job.worker.alone = False
        try:
            document, record = self.ray.get(ref)
        except self.ray.exceptions.RayActorError as exc:  # the worker or its node is lost
            self._drop(job.worker, graceful=False)
            cause = job.worker.stopped_for
            if job.alone or not self._requeue(job.planned, queue):
                error = (self.runaway.error(cause) if cause else
                         f"Ray worker died twice running it: {_gist(exc)}")
                self._record(job, None, self._error(job, error))
            return
        except self.ray.exceptions.RayError as exc:
            document, record = None, self._error(job, _gist(exc))
        if unity_died(record):
            self._drop(job.worker, graceful=True)
            if self._requeue(job.planned, queue):
                return
        self._record(job, document, record)

    def _requeue(self, planned: PlannedEpisode, queue: deque[PlannedEpisode]) -> bool:
        """Queue a lost episode again (next in line, for any worker), once."""
        self.requeued[planned.key] += 1
        if self.requeued[planned.key] > 1:
            return False
        self.alone.add(planned.key)
        queue.appendleft(planned)
        return True

    def _error(self, job: _InFlight, error: str) -> dict[str, Any]:
        return infra_error_record(job.planned, redact(error, self.settings.secrets()),
                                  time.perf_counter() - job.started)

    def _stop_with(self, error: Exception | None) -> None:
        if self.halt is None and error is not None:
            self.halt = error

    # -- the single writer ------------------------------------------------------------------

    def _record(self, job: _InFlight, document: dict[str, Any] | None,
                record: dict[str, Any]) -> None:
        """As a local run records an episode: the trajectory, then its result line (a folder
        that cannot be written stops the run, as in `run_one`), with where it ran; a fatal
        model error in it stops the dispatch."""
        assert job.worker.info is not None  # only started workers are sent episodes
        record["node"] = job.worker.info.node
        if self.requeued[job.planned.key]:
            record["requeued"] = self.requeued[job.planned.key]
        if document is not None:
            record["trajectory"] = self.folder.write_trajectory(job.planned.key, document)
        self.folder.append_result(record)
        if self.on_result is not None:
            self.on_result(record)
        self._stop_with(fatal_model_error(record, document))


def _gist(exc: BaseException, *, last: bool = False) -> str:
    """The first (or last) line of a Ray error (they carry whole remote tracebacks)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()] or [""]
    return f"{type(exc).__name__}: {lines[-1] if last else lines[0]}"[:600]

"""Running a plan on Ray: episodes spread over worker actors on one machine or a cluster.

The driver stays the single writer of the run folder: workers return each episode's
trajectory and result line, and the driver writes and appends them with the same
`RunFolder` methods as a local run, so a folder written through Ray is indistinguishable from
a local one (resume rules included). The driver keeps at most `jobs` episodes in flight,
each worker at most its share; a worker that dies is replaced and its episodes are queued
again, once; so is an AI2-THOR episode whose Unity died. Model calls hold a permit of the
run's `ConcurrencyLimiter`, so `max_concurrency` is a limit per model across the cluster.

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

from cocobench_agents.harness.batch import ResultCallback, infra_error_record, longest_first
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.ray_limit import limiter_actor
from cocobench_agents.harness.ray_session import RayUnavailable, ray_session
from cocobench_agents.harness.ray_worker import EpisodeWorker, unity_died
from cocobench_agents.harness.store import EpisodeKey, RunFolder
from cocobench_agents.harness.workers import WorkerError, available_cores, share
from cocobench_agents.models import ModelSettings, redact

WAIT_S = 0.5  # the driver wakes this often, so Ctrl-C is handled promptly
CLOSE_TIMEOUT_S = 30.0  # for workers to stop their Unity before they are killed


@dataclass(frozen=True)
class RayOptions:
    """How to run on Ray.

    * `address`: the cluster's head (``HOST:PORT``, or ``auto``); None starts a private local
      Ray with `local_cpus` CPUs (default: this machine's cores, at least `workers`) and
      `local_gpus` GPUs (default: those Ray detects).
    * `workers`: worker actors; 0 = as many as the cluster's resources allow.
    * `thor_gpus_per_worker`: the GPU share each AI2-THOR worker asks for (0: CPU nodes).
    * `runtime_env`: Ray's runtime environment of the run's workers (environment variables,
      a setup hook, …).
    """

    address: str | None = None
    workers: int = 0
    thor_gpus_per_worker: float = 0.25
    local_cpus: int | None = None
    local_gpus: float | None = None
    runtime_env: dict[str, Any] | None = None


@dataclass(frozen=True)
class FleetShape:
    """The workers of a run: how many episodes each runs at once, what each asks Ray for."""

    capacities: tuple[int, ...]
    num_cpus: float = 1.0
    num_gpus: float = 0.0

    def describe(self) -> str:
        gpus = f", {self.num_gpus:g} GPU each" if self.num_gpus else ""
        return (f"{len(self.capacities)} Ray worker{'s' if len(self.capacities) > 1 else ''}"
                f" ({sum(self.capacities)} episodes at once{gpus})")


def fleet_shape(resources: Mapping[str, float], *, backend: str, jobs: int, workers: int,
                thor_gpus_per_worker: float, episodes: int) -> FleetShape:
    """How many workers fit the cluster's `resources` and the request: an embedded worker
    takes a CPU and shares the `jobs`; an AI2-THOR worker (one Unity) takes a CPU and its GPU
    share and runs one episode at a time."""
    cpus = int(resources.get("CPU", 0))
    if cpus < 1:
        raise RayUnavailable("the Ray cluster has no CPU to run workers on")
    if backend != "ai2thor":
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
                   episode_timeout_s: float | None = None) -> None:
    """Run every episode on Ray, appending each result as it arrives, then `on_result`;
    `on_start(shape)` is told the fleet before the first episode. Once `limit` is reached no
    further episode is dispatched; an episode running past `episode_timeout_s` ends as an
    infrastructure error (as in a local run)."""
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
        run = _Run(folder, settings, shape, backend, on_result, limit, episode_timeout_s)
        try:
            run.start()
            run.dispatch(longest_first(episodes))
        finally:
            run.stop()


@dataclass
class _Slot:
    """A worker's place in the fleet; its actor is replaced when it dies."""

    index: int
    capacity: int
    actor: Any = None
    generation: int = 0
    busy: int = 0

    @property
    def holder(self) -> str:
        return f"worker-{self.index}.{self.generation}"


@dataclass
class _InFlight:
    planned: PlannedEpisode
    slot: _Slot
    generation: int
    started: float = field(default_factory=time.perf_counter)


class _Run:
    """The driver's side of a Ray run: the fleet, the queue, the single writer."""

    def __init__(self, folder: RunFolder, settings: ModelSettings, shape: FleetShape,
                 backend: str, on_result: ResultCallback | None,
                 limit: SpendLimit | None = None, episode_timeout_s: float | None = None
                 ) -> None:
        import ray

        self.limit, self.episode_timeout_s = limit, episode_timeout_s
        self.ray, self.folder, self.settings, self.shape = ray, folder, settings, shape
        self.backend = backend
        self.on_result = on_result
        self.slots = [_Slot(i, c) for i, c in enumerate(shape.capacities)]
        self.in_flight: dict[Any, _InFlight] = {}
        self.requeued: Counter[EpisodeKey] = Counter()
        self.limiter: Any = None

    # -- the fleet --------------------------------------------------------------------------

    def start(self) -> None:
        """Start the limiter and the workers; fail (nothing run yet) if a worker cannot."""
        name = f"cocobench-limiter-{self.folder.path.name}-{uuid.uuid4().hex[:8]}"
        self.limiter = limiter_actor(self.settings.max_concurrency, name)
        for slot in self.slots:
            slot.actor = self._new_actor(slot)
        try:
            self.ray.get([slot.actor.ready.remote() for slot in self.slots])
        except self.ray.exceptions.RayError as exc:
            # The last line of a failed start is the error its __init__ raised.
            raise WorkerError(f"Ray workers could not start: {_gist(exc, last=True)}") from None

    def _new_actor(self, slot: _Slot) -> Any:
        worker = self.ray.remote(EpisodeWorker).options(
            name=None, num_cpus=self.shape.num_cpus, num_gpus=self.shape.num_gpus,
            max_concurrency=slot.capacity + 1)  # one more for close()
        return worker.remote(self.settings, self.limiter, slot.holder, self.backend)

    def _replace(self, slot: _Slot, *, graceful: bool) -> None:
        old = slot.actor
        self.limiter.release_holder.remote(slot.holder)
        slot.generation += 1
        slot.busy = 0
        slot.actor = self._new_actor(slot)
        if graceful:
            self._close([old])

    def stop(self) -> None:
        """Cancel what is in flight; let workers stop their Unity, then end them."""
        # On the way out (maybe after Ctrl-C, maybe with the cluster gone): do what can be
        # done, never hide the reason for leaving.
        with contextlib.suppress(self.ray.exceptions.RayError):
            for ref in self.in_flight:
                self.ray.cancel(ref)
            self._close([slot.actor for slot in self.slots if slot.actor is not None])
            if self.limiter is not None:
                self.ray.kill(self.limiter)

    def _close(self, actors: list[Any]) -> None:
        closing = [actor.close.remote() for actor in actors]
        self.ray.wait(closing, num_returns=len(closing), timeout=CLOSE_TIMEOUT_S)
        for actor in actors:
            self.ray.kill(actor)

    # -- the queue --------------------------------------------------------------------------

    def dispatch(self, episodes: list[PlannedEpisode]) -> None:
        """Keep every worker at its capacity until every episode has a result line."""
        queue = deque(episodes)
        while queue or self.in_flight:
            if self.limit is not None and self.limit.reached():
                queue.clear()  # left pending: --resume with a higher limit runs them
            for slot in self.slots:
                while queue and slot.busy < slot.capacity:
                    planned = queue.popleft()
                    call = slot.actor.run.remote(planned, self.episode_timeout_s)
                    self.in_flight[call] = _InFlight(
                        planned, slot, slot.generation)
                    slot.busy += 1
            ready, _ = self.ray.wait(list(self.in_flight), num_returns=1, timeout=WAIT_S)
            for ref in ready:
                self._collect(ref, queue)

    def _collect(self, ref: Any, queue: deque[PlannedEpisode]) -> None:
        job = self.in_flight.pop(ref)
        slot = job.slot
        if slot.generation == job.generation:
            slot.busy -= 1
        try:
            document, record = self.ray.get(ref)
        except self.ray.exceptions.RayActorError as exc:
            if slot.generation == job.generation:  # the first of its episodes to report it
                self._replace(slot, graceful=False)
            if not self._requeue(job.planned, queue):
                self._record(job.planned, None, self._error(job, f"Ray worker died twice "
                                                                 f"running it: {_gist(exc)}"))
            return
        except self.ray.exceptions.RayError as exc:
            document, record = None, self._error(job, _gist(exc))
        if unity_died(record):
            self._replace(slot, graceful=True)
            if self._requeue(job.planned, queue):
                return
        self._record(job.planned, document, record)

    def _requeue(self, planned: PlannedEpisode, queue: deque[PlannedEpisode]) -> bool:
        """Queue a lost episode again (next in line), once."""
        self.requeued[planned.key] += 1
        if self.requeued[planned.key] > 1:
            return False
        queue.appendleft(planned)
        return True

    def _error(self, job: _InFlight, error: str) -> dict[str, Any]:
        return infra_error_record(job.planned, redact(error, self.settings.secrets()),
                                  time.perf_counter() - job.started)

    # -- the single writer ------------------------------------------------------------------

    def _record(self, planned: PlannedEpisode, document: dict[str, Any] | None,
                record: dict[str, Any]) -> None:
        """As a local run records an episode: the trajectory, then its result line (a folder
        that cannot be written stops the run, as in `run_one`)."""
        if document is not None:
            record["trajectory"] = self.folder.write_trajectory(planned.key, document)
        self.folder.append_result(record)
        if self.on_result is not None:
            self.on_result(record)


def _gist(exc: BaseException, *, last: bool = False) -> str:
    """The first (or last) line of a Ray error (they carry whole remote tracebacks)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()] or [""]
    return f"{type(exc).__name__}: {lines[-1] if last else lines[0]}"[:600]

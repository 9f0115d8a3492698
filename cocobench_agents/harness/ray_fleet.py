"""The worker actors of a Ray run: how many fit (`fleet_shape`), and the `Fleet` that starts
them, grows with the cluster, drops the dead and ends them all.

The fleet follows the cluster: a new worker starts whenever Ray has room for one (a node
that joined, resources set free), up to the most the run allows; the run stops
(`WorkersLost`) when none has been alive for `wait_s`. Importing this module does not import
Ray.
"""

from __future__ import annotations

import contextlib
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.vocabulary import AI2THOR
from cocobench_agents.harness.errors import WorkerEnvironmentError, WorkerError, WorkersLost
from cocobench_agents.harness.ray_limit import limiter_actor
from cocobench_agents.harness.ray_session import RayUnavailable
from cocobench_agents.harness.ray_worker import WATCH_GROUP, EpisodeWorker, KeyVariables, WorkerInfo
from cocobench_agents.harness.workers import share
from cocobench_agents.models import ModelSettings

WAIT_S = 0.5  # the driver wakes this often: Ctrl-C, room for a worker, the wait_s clock
GROW_EVERY_S = 1.0  # how often the driver asks Ray whether another worker would fit
CLOSE_TIMEOUT_S = 30.0  # for workers to stop their Unity before they are killed


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


@dataclass(frozen=True)
class WorkerSpec:
    """What every worker of the run is: its Ray resources and backend, the episodes it runs
    at once at most (`per_worker`), how many there may be (`most`), the key variables its
    node must have, the planners it builds before it is ready."""

    shape: FleetShape
    backend: str
    per_worker: int
    most: int
    keys: KeyVariables
    planners: tuple[str, ...] = ()


@dataclass(eq=False)
class RayWorker:
    """A worker actor: `info` once it has started; its permits are held as `holder`."""

    actor: Any
    holder: str
    info: WorkerInfo | None = None
    busy: int = 0
    alone: bool = False  # running an episode that must run by itself
    health: Any = None  # the `health` call in flight
    asked: float = 0.0  # when it was sent
    stopped_for: str | None = None  # the runaway cause it was killed for


class Halt:
    """Why no further episode is dispatched: the first reason given wins."""

    def __init__(self) -> None:
        self.reason: Exception | None = None

    def stop_with(self, error: Exception | None) -> None:
        if self.reason is None and error is not None:
            self.reason = error


def worker_actor_class(ray: Any) -> Any:
    """`EpisodeWorker` as a Ray actor class: its `health` answers on the watch's own
    concurrency group (`WATCH_GROUP`), beside the episodes' loop."""
    return ray.remote(concurrency_groups={WATCH_GROUP: 1})(EpisodeWorker)


class Fleet:
    """The run's worker actors and the limiter their model calls share."""

    def __init__(self, ray: Any, spec: WorkerSpec, settings: ModelSettings, *, run_name: str,
                 wait_s: float, halt: Halt) -> None:
        self.ray, self.spec, self.settings = ray, spec, settings
        self.run_name, self.wait_s, self.halt = run_name, wait_s, halt
        self.actor_class = worker_actor_class(ray)
        self.limiter: Any = None
        self.launched = 0
        self.starting: dict[Any, RayWorker] = {}  # the `ready` call of each → the worker
        self.workers: list[RayWorker] = []  # started, and not known dead
        self.alone_since: float | None = None  # since when no worker has been alive
        self.ever_alive = False
        self.next_growth = 0.0

    def start(self, count: int) -> None:
        """Start the limiter and `count` workers, and wait (up to `wait_s`) until each has
        started: a worker that cannot start, or whose node lacks a key, stops the run before
        any episode. Workers still waiting for room after `wait_s` join when placed."""
        name = f"cocobench-limiter-{self.run_name}-{uuid.uuid4().hex[:8]}"
        self.limiter = limiter_actor(self.settings.max_concurrency, name)
        for _ in range(count):
            self._launch()
        self.alone_since = time.monotonic()
        while self.starting and time.monotonic() < self.alone_since + self.wait_s:
            ready, _ = self.ray.wait(list(self.starting), num_returns=1, timeout=WAIT_S)
            for ref in ready:
                self.started(ref)
            if self.halt.reason is not None:
                raise self.halt.reason

    def _launch(self) -> None:
        self.launched += 1
        holder = f"worker-{self.launched}"
        actor = self.actor_class.options(
            num_cpus=self.spec.shape.num_cpus, num_gpus=self.spec.shape.num_gpus,
            max_concurrency=self.spec.per_worker + 1,  # one more for close()
        ).remote(self.settings, self.limiter, holder, self.spec.backend, self.spec.keys,
                 self.spec.planners)
        self.starting[actor.ready.remote()] = RayWorker(actor, holder)

    def started(self, ref: Any) -> None:
        """A worker answered `ready` (or failed to start)."""
        worker = self.starting.pop(ref)
        try:
            info: WorkerInfo = self.ray.get(ref)
        except self.ray.exceptions.RayActorError as exc:
            self.kill(worker)
            if exc.actor_init_failed:  # its __init__ raised: any worker of the run would
                # The last line of a failed start is the error its __init__ raised.
                self.halt.stop_with(WorkerError(f"Ray workers could not start: "
                                                f"{gist(exc, last=True)}"))
            return  # its node went away first: another takes its place when there is room
        if info.missing:
            self.kill(worker)
            self.halt.stop_with(WorkerEnvironmentError(info.missing, info.node, info.host))
            return
        worker.info = info
        self.workers.append(worker)
        self.ever_alive = True

    def grow(self, queued: int) -> None:
        """Start workers for queued episodes where Ray has room now (a node joined, a lost
        worker's resources came free), at most once a second and a batch at a time: while a
        worker is starting (or waiting for room) none is added, so workers the cluster
        cannot place never pile up."""
        now = time.monotonic()
        if (self.halt.reason is not None or self.starting or not queued
                or now < self.next_growth):
            return
        self.next_growth = now + GROW_EVERY_S
        wanted = min(self.spec.most - len(self.workers), queued)
        if wanted > 0:
            for _ in range(min(wanted, self.spec.shape.fits(self.ray.available_resources()))):
                self._launch()

    def drop(self, worker: RayWorker, *, graceful: bool) -> None:
        """Take a dead (or Unity-less) worker out of the fleet and hand back its permits."""
        if worker not in self.workers:
            return  # another of its episodes reported it first
        self.workers.remove(worker)
        self.limiter.release_holder.remote(worker.holder)
        if graceful:
            self._close([worker.actor])
        else:
            self.kill(worker)

    def kill(self, worker: RayWorker) -> None:
        # A worker Ray reports unavailable may still be running: end it, so that it spends
        # no more model calls on episodes queued again elsewhere, and its share of the
        # cluster comes free for a replacement.
        with contextlib.suppress(self.ray.exceptions.RayError):
            self.ray.kill(worker.actor)

    def check_alive(self, left: int) -> None:
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
                                                 f"one ({self.spec.shape.describe()})")

    def stop(self) -> None:
        """Let workers stop their Unity, then end them, and the limiter."""
        for worker in self.starting.values():
            self.kill(worker)
        self._close([worker.actor for worker in self.workers])
        if self.limiter is not None:
            self.ray.kill(self.limiter)

    def _close(self, actors: list[Any]) -> None:
        closing = [actor.close.remote() for actor in actors]
        self.ray.wait(closing, num_returns=len(closing), timeout=CLOSE_TIMEOUT_S)
        for actor in actors:
            self.ray.kill(actor)


def gist(exc: BaseException, *, last: bool = False) -> str:
    """The first (or last) line of a Ray error (they carry whole remote tracebacks)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()] or [""]
    return f"{type(exc).__name__}: {lines[-1] if last else lines[0]}"[:600]

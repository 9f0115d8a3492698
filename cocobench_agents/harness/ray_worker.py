"""The body of a Ray worker actor: it runs the episodes it is sent and returns each one's
trajectory and result line to the driver, which alone writes the run folder.

An embedded-simulator worker runs several episodes at once on its event loop (as a local
run does); an AI2-THOR worker runs one at a time in the Unity it keeps in its process's
controller pool between episodes. A worker tells the driver which node it is on, and which
of the run's key variables that node lacks, before it is sent any episode.
"""

from __future__ import annotations

import asyncio
import os
import socket
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.sim.backends import check_backend
from benchmark_adapter.vocabulary import EMBEDDED
from cocobench_agents.graphs import build_planners
from cocobench_agents.harness.batch import run_one
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.ray_limit import LimitedPool
from cocobench_agents.harness.runaway import rss_bytes
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.models.pool import needed_key_variables
from cocobench_agents.runfolder.episode_key import EpisodeKey

THOR_GPU_VARIABLE = "COCOBENCH_THOR_GPU_DEVICE"
WATCH_GROUP = "watch"  # the concurrency group (own thread, own loop) of `health`
BEAT_S = 0.1  # how often the episodes' loop says it runs
UNITY_DIED = "ThorCrashed("  # how an infrastructure error from a dead Unity starts

KeyVariables = tuple[tuple[str, ...], ...]  # per model: the variables any one of which will do


@dataclass(frozen=True)
class WorkerInfo:
    """A started worker: its Ray node, its host and process, and the run's key variables
    that are not set there ("A or B" when either would do)."""

    node: str
    host: str
    pid: int
    missing: tuple[str, ...] = ()
    rss: int | None = None  # its memory when it started, for the driver's watch


class TrajectoryPath:
    """Stands in for the run folder in a worker: the driver writes the trajectory it is sent
    back; this only says where."""

    def write_trajectory(self, key: EpisodeKey, document: dict[str, Any]) -> str:
        return f"{key.folder()}/trajectory.json"


class EpisodeWorker:
    """Runs episodes for the driver (an async Ray actor's body)."""

    def __init__(self, settings: ModelSettings, limiter: Any, holder: str,
                 backend: str, keys: KeyVariables = (), planners: Sequence[str] = ()) -> None:
        self.missing = missing_variables(keys)
        self.last_beat, self.beat = time.monotonic(), None
        self.pool = LimitedPool(ModelPool(settings), limiter, holder)
        if backend != EMBEDDED:
            _use_assigned_gpu()
            try:
                check_backend(backend)  # this node's renderer and build, before any episode
            except Exception as exc:  # noqa: BLE001 - Ray cannot carry our exception types
                detail = " ".join(str(exc).split())  # one line: the driver shows the last
                raise RuntimeError(f"{type(exc).__name__}: {detail}") from None
        # Before `ready`: the runaway watch counts a worker's silence once it has started.
        build_planners(planners)

    async def ready(self) -> WorkerInfo:
        """Where this worker runs and what its node lacks (answered once it has started).
        From here its episodes' loop beats, idle or not: the driver sends a started worker
        its first episode and its first health question together, and an answer that came
        before the episode reached the loop counted the worker's start (its planners'
        compile, seconds) as an episode's silence."""
        import ray

        if self.beat is None:  # on the episodes' loop (the default concurrency group's)
            self.last_beat = time.monotonic()
            self.beat = asyncio.create_task(self._beat())
        return WorkerInfo(ray.get_runtime_context().get_node_id(), socket.gethostname(),
                          os.getpid(), self.missing, rss_bytes(os.getpid()))

    async def health(self) -> tuple[int | None, float]:
        """This worker's memory now, and for how long its episodes' event loop has not run
        (`runaway`). Called in the `WATCH_GROUP` concurrency group, whose own thread and
        loop answer while an episode blocks the main loop."""
        return rss_bytes(os.getpid()), time.monotonic() - self.last_beat

    async def _beat(self) -> None:
        while True:
            self.last_beat = time.monotonic()
            await asyncio.sleep(BEAT_S)

    async def run(self, planned: PlannedEpisode, timeout_s: float | None = None
                  ) -> tuple[dict[str, Any] | None, dict[str, Any]]:
        """One episode (ended as an infrastructure error after `timeout_s`) → (its trajectory
        document, or None if it failed to run; its result line)."""
        record, document = await run_one(planned, TrajectoryPath(),  # type: ignore[arg-type]
                                         self.pool, timeout_s=timeout_s)
        return document, record

    async def close(self) -> None:
        """Close model connections and stop this process's AI2-THOR, if it started one."""
        await self.pool.aclose()
        thor = sys.modules.get("benchmark_adapter.sim.thor.pool")  # loaded if it was used
        if thor is not None:
            thor.POOL.close()


def run_key_variables(settings: ModelSettings, models: Iterable[str]) -> KeyVariables:
    """The variables the run's `models` read their keys from, told as `ModelPool.validate`
    tells them on the driver (names only); a provider only LiteLLM knows the variable of is
    left out (its calls then fail on the node, and stop the run as an authentication
    error)."""
    needed = (needed_key_variables(settings, model) for model in dict.fromkeys(models))
    return tuple(dict.fromkeys(names for names in needed if names))


def missing_variables(keys: Sequence[Sequence[str]]) -> tuple[str, ...]:
    """Of `keys` (per model, the variables any one of which will do), those this process's
    environment has none of."""
    return tuple(" or ".join(names) for names in keys
                 if not any(os.environ.get(name) for name in names))


def unity_died(record: dict[str, Any]) -> bool:
    """Whether an episode failed because its Unity process died under it."""
    return str(record.get("infra_error") or "").startswith(UNITY_DIED)


def _use_assigned_gpu() -> None:
    # Ray tells an actor which GPU it was given; AI2-THOR's CloudRendering picks its GPU by
    # `gpu_device`, so point it there unless the node's configuration says otherwise.
    import ray

    gpus = ray.get_gpu_ids()
    if gpus and THOR_GPU_VARIABLE not in os.environ:
        os.environ[THOR_GPU_VARIABLE] = str(gpus[0])

"""The body of a Ray worker actor: it runs the episodes it is sent and returns each one's
trajectory and result line to the driver, which alone writes the run folder.

An embedded-simulator worker runs several episodes at once on its event loop (as a local
run does); an AI2-THOR worker runs one at a time in the Unity it keeps in its process's
controller pool between episodes.
"""

from __future__ import annotations

import os
import socket
import sys
from typing import Any

from benchmark_adapter.sim.backends import check_backend
from cocobench_agents.harness.batch import run_one
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.ray_limit import LimitedPool
from cocobench_agents.harness.store import EpisodeKey
from cocobench_agents.models import ModelPool, ModelSettings

THOR_GPU_VARIABLE = "COCOBENCH_THOR_GPU_DEVICE"
UNITY_DIED = "ThorCrashed("  # how an infrastructure error from a dead Unity starts


class CapturedTrajectory:
    """Stands in for the run folder in a worker: keeps the trajectory for the driver."""

    def __init__(self) -> None:
        self.document: dict[str, Any] | None = None

    def write_trajectory(self, key: EpisodeKey, document: dict[str, Any]) -> str:
        self.document = document
        return f"{key.folder()}/trajectory.json"  # the driver records where it wrote it


class EpisodeWorker:
    """Runs episodes for the driver (an async Ray actor's body)."""

    def __init__(self, settings: ModelSettings, limiter: Any, holder: str,
                 backend: str) -> None:
        self.pool = LimitedPool(ModelPool(settings), limiter, holder)
        if backend != "embedded":
            _use_assigned_gpu()
            try:
                check_backend(backend)  # this node's renderer and build, before any episode
            except Exception as exc:  # noqa: BLE001 - Ray cannot carry our exception types
                detail = " ".join(str(exc).split())  # one line: the driver shows the last
                raise RuntimeError(f"{type(exc).__name__}: {detail}") from None

    def ready(self) -> str:
        """Where this worker runs (answered once it has started)."""
        return f"{socket.gethostname()} pid {os.getpid()}"

    async def run(self, planned: PlannedEpisode, timeout_s: float | None = None
                  ) -> tuple[dict[str, Any] | None, dict[str, Any]]:
        """One episode (ended as an infrastructure error after `timeout_s`) → (its trajectory
        document, or None if it failed to run; its result line)."""
        captured = CapturedTrajectory()
        record = await run_one(planned, captured, self.pool,  # type: ignore[arg-type]
                               timeout_s=timeout_s)
        return (None if record.get("infra_error") else captured.document), record

    async def close(self) -> None:
        """Close model connections and stop this process's AI2-THOR, if it started one."""
        await self.pool.aclose()
        thor = sys.modules.get("benchmark_adapter.sim.thor.pool")  # loaded if it was used
        if thor is not None:
            thor.POOL.close()


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

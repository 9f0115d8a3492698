"""`ExecutionSettings`: where and how many episodes run, the run request's group that every
executor takes as it is (`RunRequest.execution`). It is defined here, beside the executors,
which sit below the engine; `engine.request` imports it."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, model_validator

from cocobench_agents.setting_kinds import run_setting

#: The executors a request may name (``--executor``), each registered in `executors`.
ExecutorName = Literal["local", "ray"]


class ExecutionSettings(BaseModel):
    """Where and how many episodes run at once. Results do not depend on these."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    executor: ExecutorName = run_setting(
        "local", flag="--executor",
        description="Where episodes run: this process (and --workers processes), or Ray "
                    "workers on this machine or a cluster (pip install "
                    "'cocobench-agents[ray]'; see docs/distributed.md).")
    jobs: int = run_setting(8, flag="--jobs", ge=1, description="Episodes run concurrently.")
    workers: int | None = run_setting(
        None, flag="--workers", ge=0,
        description="Processes sharing the jobs (0: one per core; default 1). With ray: Ray "
                    "workers (default: as many as fit).")
    ray_address: str | None = run_setting(
        None, flag="--ray-address",
        description="With executor ray: join the cluster whose head is at HOST:PORT "
                    "(default: start a private local Ray).")
    thor_gpus_per_worker: float = run_setting(
        0.25, flag="--thor-gpus-per-worker", ge=0,
        description="With executor ray and backend ai2thor: the GPU share of each worker "
                    "(one Unity each); 0 for CPU nodes.")
    ray_wait: float = run_setting(
        300.0, flag="--ray-wait", gt=0,
        description="With executor ray: seconds the run goes on with no worker alive (every "
                    "node lost, none with room) before it stops; --resume finishes it.")

    @model_validator(mode="after")
    def _address_needs_ray(self) -> ExecutionSettings:
        if self.ray_address and self.executor != "ray":
            raise ValueError("ray_address (--ray-address) needs executor ray (--executor ray)")
        return self

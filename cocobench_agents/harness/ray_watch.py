"""The driver's watch on Ray workers that run away (`runaway`): each is asked for its memory
every `HEALTH_EVERY_S` on a thread of its own (`WATCH_GROUP`); one past its memory budget, or
busy and silent past the stall limit, is killed, and its episodes then fail as lost
(`ray_results`): queued again alone, once; the one that does it again is recorded as an
infrastructure error naming the cause."""

from __future__ import annotations

import time
from typing import Any

from cocobench_agents.harness.ray_fleet import Fleet, RayWorker
from cocobench_agents.harness.ray_worker import WATCH_GROUP
from cocobench_agents.harness.runaway import RunawayLimits

HEALTH_EVERY_S = 1.0  # how often the driver asks each worker for its memory


class RunawayWatch:
    """Asks the fleet's workers how they are, and kills those that run away."""

    def __init__(self, fleet: Fleet, runaway: RunawayLimits) -> None:
        self.fleet, self.ray, self.runaway = fleet, fleet.ray, runaway

    def watch(self) -> None:
        """Read each worker's answer (or its silence); ask again every `HEALTH_EVERY_S`."""
        now = time.monotonic()
        for worker in list(self.fleet.workers):
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

    def _stop_runaway(self, worker: RayWorker, cause: str | None) -> bool:
        if cause is None:
            return False
        worker.stopped_for = cause
        self.fleet.drop(worker, graceful=False)
        return True

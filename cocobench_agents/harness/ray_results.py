"""What comes back from a Ray worker, made a result line: the driver is the run folder's
single writer. A lost episode (its worker or node died, its Unity died) goes back to the
front of the queue once, to run alone; the one lost again is recorded as an infrastructure
error. Every line says the Ray node that ran it (``node``) and, for an episode queued again,
``requeued``."""

from __future__ import annotations

import time
from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Any

from cocobench_agents.harness.batch import infra_error_record, store_trajectory
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.errors import fatal_model_error
from cocobench_agents.harness.executor import EpisodeRecorded, ExecutorEventHandler
from cocobench_agents.harness.ray_fleet import Fleet, Halt, RayWorker, gist
from cocobench_agents.harness.ray_worker import unity_died
from cocobench_agents.harness.runaway import RunawayLimits
from cocobench_agents.models import redact
from cocobench_agents.runfolder import EpisodeKey, RunFolder


@dataclass
class InFlight:
    """An episode sent to a worker."""

    planned: PlannedEpisode
    worker: RayWorker
    started: float = field(default_factory=time.perf_counter)
    alone: bool = False


class ResultCollector:
    """Takes each finished (or lost) episode back from the workers and records it."""

    def __init__(self, fleet: Fleet, folder: RunFolder, *, runaway: RunawayLimits,
                 halt: Halt, on_event: ExecutorEventHandler) -> None:
        self.fleet, self.ray, self.folder = fleet, fleet.ray, folder
        self.runaway, self.halt, self.on_event = runaway, halt, on_event
        self.requeued: Counter[EpisodeKey] = Counter()
        self.alone: set[EpisodeKey] = set()  # queued again: they run by themselves

    def collect(self, ref: Any, job: InFlight, queue: deque[PlannedEpisode]) -> None:
        """The episode `ref` ran, from the worker it ran on: recorded, or queued again."""
        job.worker.busy -= 1
        if job.alone:
            job.worker.alone = False
        try:
            document, record = self.ray.get(ref)
        except self.ray.exceptions.RayActorError as exc:  # the worker or its node is lost
            self.fleet.drop(job.worker, graceful=False)
            cause = job.worker.stopped_for
            if job.alone or not self._requeue(job.planned, queue):
                error = (self.runaway.error(cause) if cause else
                         f"Ray worker died twice running it: {gist(exc)}")
                self._record(job, None, self._error(job, error))
            return
        except self.ray.exceptions.RayError as exc:
            document, record = None, self._error(job, gist(exc))
        if unity_died(record):
            self.fleet.drop(job.worker, graceful=True)
            if self._requeue(job.planned, queue):
                return
        self._record(job, document, record)

    def overdue(self, job: InFlight, error: str) -> None:
        """An episode the driver stopped waiting for (past its timeout): recorded as `error`,
        its worker stopped."""
        job.worker.busy -= 1
        self.fleet.drop(job.worker, graceful=False)
        self._record(job, None, self._error(job, error))

    def _requeue(self, planned: PlannedEpisode, queue: deque[PlannedEpisode]) -> bool:
        """Queue a lost episode again (next in line, for any worker), once."""
        self.requeued[planned.key] += 1
        if self.requeued[planned.key] > 1:
            return False
        self.alone.add(planned.key)
        queue.appendleft(planned)
        return True

    def _error(self, job: InFlight, error: str) -> dict[str, Any]:
        return infra_error_record(job.planned, redact(error, self.fleet.settings.secrets()),
                                  time.perf_counter() - job.started)

    def _record(self, job: InFlight, document: dict[str, Any] | None,
                record: dict[str, Any]) -> None:
        """As a local run records an episode: the trajectory, then its result line (a folder
        that cannot be written stops the run, as in `run_one`), with where it ran; a fatal
        model error in it stops the dispatch."""
        assert job.worker.info is not None  # only started workers are sent episodes
        if document is not None:  # one the folder cannot hold makes it an error line
            record, document = store_trajectory(self.folder, job.planned, record, document)
        record["node"] = job.worker.info.node
        if self.requeued[job.planned.key]:
            record["requeued"] = self.requeued[job.planned.key]
        self.folder.append_result(record)
        self.on_event(EpisodeRecorded(record))
        self.halt.stop_with(fatal_model_error(record, document))

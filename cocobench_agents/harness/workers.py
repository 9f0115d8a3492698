"""Running a plan in worker processes that pull episodes from one queue, watched by this
process.

Every model episode of a local run runs in a worker process, one by default: a worker is an
event loop running up to its share of ``--jobs`` episodes at once, and one process runs out of
CPU long before a fast model server runs out of answers, so ``--workers`` spreads them over
cores. This process (the supervisor) holds the queue, longest step budget first, and hands the
next episode to a worker as soon as it has a free slot, so a slow episode costs only its own
time. It is the single writer of ``results.jsonl`` (workers write trajectories and send each
result line back), and it watches each worker from outside (`runaway`): a worker past its
memory budget or whose event loop stopped is killed, as is the only way to stop code that
never yields. A worker that dies or is killed is replaced; the episodes it had in flight run
again alone, once, and the one that fails again is recorded as an infrastructure error naming
the cause. A worker reports every episode it is given, whatever escapes it (an
infrastructure error naming the exception), and the supervisor ends one still in flight
`OVERDUE_GRACE_S` past its timeout itself, so it never waits on an episode that has ended. A
worker that cannot write the run folder sends the error and the run stops with it; a fatal
model error stops the handing out of episodes, and is raised once those in flight are
recorded.
"""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
import os
import signal
import time
from collections import Counter, deque
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from cocobench_agents.graphs import build_planners
from cocobench_agents.harness.batch import (
    described,
    infra_error_record,
    longest_first,
    run_one,
    start_key,
    timeout_error,
)
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.harness.errors import FatalModelError, WorkerError, fatal_model_error
from cocobench_agents.harness.execution_settings import ExecutionSettings
from cocobench_agents.harness.executor import (
    NO_BOUNDS,
    Bounds,
    EpisodeRecorded,
    EpisodeStarted,
    ExecutorEventHandler,
    ExecutorStarted,
    ExecutorStopped,
    ignore,
)
from cocobench_agents.harness.runaway import MEMORY, machine_memory_low, rss_bytes
from cocobench_agents.models import ModelPool, ModelSettings, redact
from cocobench_agents.runfolder.errors import RunFolderError, RunFolderWriteError
from cocobench_agents.runfolder.folder import RunFolder

POLL_S = 0.2  # how often the supervisor looks at its workers when no message arrives
BEAT_S = 0.1  # how often a worker's event loop says it is alive
MAX_IDLE_DEATHS = 3  # workers dying with no episode in flight: something else is broken
#: How long past `--episode-timeout` the supervisor waits for a worker to end an episode
#: before it stops the worker itself (the worker's own timeout should have fired).
OVERDUE_GRACE_S = 30.0


def available_cores() -> int:
    """Cores this process may use (its CPU affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def share(total: int, index: int, parts: int) -> int:
    """Worker `index`'s part of `total` (parts differ by at least one, never below one)."""
    return max(1, total // parts + (1 if index < total % parts else 0))


class WorkerProcesses:
    """The `Executor` of ``--executor local``: `settings.workers` processes (0: one per
    core; None: one) sharing `settings.jobs`."""

    def check(self, settings: ExecutionSettings) -> None:
        """Nothing to check: the backend is checked with the request."""

    def run(self, episodes: Sequence[PlannedEpisode], folder: RunFolder, pool: ModelPool,
            settings: ExecutionSettings, *, bounds: Bounds = NO_BOUNDS,
            on_event: ExecutorEventHandler = ignore) -> None:
        """Run every episode in worker processes that call models as `pool.settings` say
        (sharing each model's `max_concurrency`); append each result as it arrives. Once
        the spend limit is reached no further episode starts; an episode past its timeout
        ends as an infrastructure error, and one that runs away (`bounds.runaway`) as one
        naming the cause. Raises the first `FatalModelError` a worker met once the episodes
        in flight are recorded, a run-folder error at once, and `WorkerError` when workers
        keep dying with nothing in flight."""
        workers = 1 if settings.workers is None else settings.workers or available_cores()
        if not episodes:
            return
        jobs = settings.jobs
        count = max(1, min(workers, jobs, len(episodes)))
        _warm_up(episodes)
        capacities = [share(jobs, i, count) for i in range(count)]
        supervisor = _Supervisor(longest_first(episodes), folder, pool.settings,
                                 capacities=capacities, bounds=bounds, on_event=on_event)
        on_event(ExecutorStarted(tuple(capacities)))
        try:
            supervisor.run()
        finally:
            on_event(ExecutorStopped())


@dataclass(eq=False)
class _Worker:
    """A worker process as the supervisor sees it."""

    process: multiprocessing.process.BaseProcess
    conn: Connection
    heartbeat: Any  # a shared double: the worker loop's last `time.monotonic()`
    capacity: int
    in_flight: dict[int, float] = field(default_factory=dict)  # episode index → since
    alone: bool = False  # running an episode that must run by itself
    start_rss: int | None = None

    def free(self) -> int:
        return 0 if self.alone else self.capacity - len(self.in_flight)


class _Supervisor:
    """This process's side of a local run: the fleet of workers, the queue, the watch and
    the single writer of the result lines."""

    def __init__(self, episodes: list[PlannedEpisode], folder: RunFolder,
                 settings: ModelSettings, *, capacities: list[int], bounds: Bounds,
                 on_event: ExecutorEventHandler) -> None:
        self.episodes, self.folder, self.settings = episodes, folder, settings
        self.capacities, self.runaway = capacities, bounds.runaway
        self.on_event, self.limit = on_event, bounds.spend
        self.episode_timeout_s = bounds.episode_timeout_s
        self.context = _context()
        self.queue: deque[tuple[int, bool]] = deque((i, False) for i in range(len(episodes)))
        self.workers: list[_Worker] = []
        self.requeued: Counter[int] = Counter()
        self.fatal: FatalModelError | None = None
        self.idle_deaths = 0
        self.launched = 0
        self.next_watch = 0.0
        self.writer = _ResultWriter(folder, on_event)

    def run(self) -> None:
        try:
            for capacity in self.capacities:
                self._launch(capacity)
            while self.queue or any(w.in_flight for w in self.workers):
                if self.limit is not None and self._can_hand_out():
                    # The limit counts what `on_event` was told: tell all before deciding
                    # whether another episode starts (and only then: a drain waits on fsync).
                    self.writer.drain()
                if self.fatal is not None or (self.limit is not None and self.limit.reached()):
                    self.queue.clear()  # left pending: --resume runs them
                self._hand_out()
                self._receive()
                self._watch()
                self.writer.pump()
            self.writer.close()
            for worker in self.workers:  # let each close its model connections
                with contextlib.suppress(OSError):
                    worker.conn.send(None)
            for worker in self.workers:
                worker.process.join(timeout=10)
        finally:
            self.writer.close()  # on Ctrl-C, what finished is kept
            for worker in self.workers:  # on Ctrl-C or an error here: stop them all
                if worker.process.is_alive():
                    worker.process.kill()
                worker.process.join()
        if self.fatal is not None:
            raise self.fatal  # it says what to fix; --resume --retry-errors runs the rest

    # -- the fleet --------------------------------------------------------------------------

    def _launch(self, capacity: int) -> None:
        index = self.launched
        self.launched += 1
        parent_end, child_end = self.context.Pipe()
        heartbeat = self.context.RawValue("d", time.monotonic())
        settings = self.settings.model_copy(update={"max_concurrency": share(
            self.settings.max_concurrency, index % len(self.capacities), len(self.capacities))})
        process = self.context.Process(
            target=_work, name=f"cocobench-worker-{index}", daemon=True,
            args=(child_end, self.episodes, self.folder.path, settings, heartbeat,
                  self.episode_timeout_s))
        process.start()
        child_end.close()  # the worker holds the only other end: EOF means it has ended
        self.workers.append(_Worker(process, parent_end, heartbeat, capacity,
                                    start_rss=rss_bytes(process.pid or 0)))

    def _replace(self, worker: _Worker) -> None:
        """Take `worker` (dead, or killed) out of the fleet and start another in its place
        while there is work left."""
        self.workers.remove(worker)
        worker.process.join()
        worker.conn.close()
        if self.queue:
            self._launch(worker.capacity)

    # -- the queue --------------------------------------------------------------------------

    def _can_hand_out(self) -> bool:
        """Whether `_hand_out` would start the next queued episode now."""
        return bool(self.queue) and bool(self._ready(alone=self.queue[0][1]))

    def _ready(self, *, alone: bool) -> list[_Worker]:
        """The workers that can take an episode now (one that must run alone: idle ones)."""
        return [w for w in self.workers if (not w.in_flight if alone else w.free() > 0)]

    def _hand_out(self) -> None:
        """Queued episodes to workers with free slots, the least busy first; an episode that
        must run alone waits for an idle worker."""
        while self.queue:
            index, alone = self.queue[0]
            ready = self._ready(alone=alone)
            if not ready:
                return
            worker = min(ready, key=lambda w: len(w.in_flight))
            self.queue.popleft()
            worker.in_flight[index] = time.monotonic()
            worker.alone = alone
            with contextlib.suppress(OSError):  # it died: its EOF comes next, and requeues
                worker.conn.send(index)

    def _receive(self) -> None:
        """Every message the workers have sent, or wait up to `POLL_S` for one."""
        by_conn = {w.conn: w for w in self.workers}
        for conn in wait(list(by_conn), timeout=POLL_S):
            worker = by_conn[conn]  # type: ignore[index]
            try:
                while worker in self.workers and conn.poll():
                    self._handle(worker, conn.recv())
            except (EOFError, OSError):
                self._lost(worker, None)

    def _handle(self, worker: _Worker, message: tuple) -> None:
        kind = message[0]
        if kind == "started":
            self.on_event(EpisodeStarted(start_key(self.episodes[message[1]])))
        elif kind == "done":
            _, index, record, fatal = message
            self._record(worker, index, record)
            if fatal is not None and self.fatal is None:
                self.fatal = fatal
        elif kind == "failed":  # the episode's result line could not be made there
            _, index, error = message
            since = worker.in_flight.get(index, time.monotonic())
            self._record(worker, index, infra_error_record(
                self.episodes[index], redact(error, self.settings.secrets()),
                time.monotonic() - since))
        elif kind == "error":
            raise message[1]  # the run folder cannot be written: the run stops

    def _watch(self) -> None:
        """Every `POLL_S`: kill a worker past its memory budget or whose loop stopped; when
        the machine is about to run out of memory, the one that grew most."""
        now = time.monotonic()
        if now < self.next_watch:
            return
        self.next_watch = now + POLL_S
        grown: dict[_Worker, int | None] = {}
        for worker in list(self.workers):
            overdue = self._overdue(worker, now)
            if overdue:
                self._stop_overdue(worker, overdue, now)
                continue
            rss = rss_bytes(worker.process.pid or 0)
            grown[worker] = (None if rss is None or worker.start_rss is None
                             else rss - worker.start_rss)
            cause = self.runaway.breach(grown_bytes=grown[worker],
                                        in_flight=len(worker.in_flight),
                                        silent_s=now - worker.heartbeat.value)
            if cause is not None:
                self._kill(worker, cause)
                grown.pop(worker)
        busy = {w: g for w, g in grown.items() if w.in_flight and g is not None}
        if busy and machine_memory_low():
            self._kill(max(busy, key=lambda w: busy[w]), MEMORY)

    def _overdue(self, worker: _Worker, now: float) -> list[int]:
        """The episodes of `worker` past their timeout by more than `OVERDUE_GRACE_S`: its
        own timeout should have ended them, so something there is broken."""
        if self.episode_timeout_s is None:
            return []
        deadline = self.episode_timeout_s + OVERDUE_GRACE_S
        return [index for index, since in worker.in_flight.items() if now - since > deadline]

    def _stop_overdue(self, worker: _Worker, overdue: list[int], now: float) -> None:
        """Record `overdue` episodes as timed out and stop their worker (nothing else ends
        them there); its other episodes run again alone, as a lost worker's do."""
        assert self.episode_timeout_s is not None
        worker.process.kill()
        for index in overdue:
            since = worker.in_flight.pop(index)
            self._store(index, infra_error_record(
                self.episodes[index], timeout_error(self.episode_timeout_s), now - since))
        if worker.in_flight:
            self._lost(worker, "its worker was stopped: another episode there ran past "
                               "--episode-timeout")
        else:
            worker.process.join()
            self._replace(worker)

    def _kill(self, worker: _Worker, cause: str) -> None:
        worker.process.kill()
        self._lost(worker, cause)

    def _lost(self, worker: _Worker, cause: str | None) -> None:
        """`worker` ended (by itself, or killed for `cause`): its episodes in flight run again
        alone, once; one that ran alone, or ran again, is recorded as its failure."""
        worker.process.join()
        if cause is None:
            cause = f"worker process died (exit code {worker.process.exitcode})"
        if not worker.in_flight:
            self.idle_deaths += 1
            if self.idle_deaths >= MAX_IDLE_DEATHS:
                raise WorkerError(f"{worker.process.name}: {cause}, with no episode running "
                                  f"({self.idle_deaths} times): run again with --resume")
        for index, since in sorted(worker.in_flight.items()):
            if worker.alone or self.requeued[index]:
                planned = self.episodes[index]
                error = self.runaway.error(cause)
                self._store(index, infra_error_record(planned, error, time.monotonic() - since))
            else:
                self.requeued[index] += 1
                self.queue.appendleft((index, True))
        worker.in_flight.clear()
        self._replace(worker)

    # -- the single writer ------------------------------------------------------------------

    def _record(self, worker: _Worker, index: int, record: dict[str, Any]) -> None:
        worker.in_flight.pop(index, None)
        if not worker.in_flight:
            worker.alone = False
        self._store(index, record)

    def _store(self, index: int, record: dict[str, Any]) -> None:
        if self.requeued[index]:
            record["requeued"] = self.requeued[index]
        self.writer.add(record)


class _ResultWriter:
    """Appends result lines on a thread of its own, all that arrived while the last batch
    synced with one fsync, while the supervisor goes on handing out episodes; tells
    `on_event` of each line once it is written, on the supervisor's thread. (An fsync per
    line in the supervisor was the bottleneck of 16 workers: 2,691 fsyncs at 5.8 ms each
    here, with every worker waiting for its next episode meanwhile.)"""

    def __init__(self, folder: RunFolder, on_event: ExecutorEventHandler) -> None:
        self.folder, self.on_event = folder, on_event
        self.thread = ThreadPoolExecutor(1, thread_name_prefix="cocobench-results")
        self.waiting: list[dict[str, Any]] = []
        self.writing: tuple[Future[None], list[dict[str, Any]]] | None = None
        self.failed = False

    def add(self, record: dict[str, Any]) -> None:
        self.waiting.append(record)

    def pump(self, *, block: bool = False) -> None:
        """Report the batch written (waiting for it if `block`), and start the next;
        `RunFolderWriteError` stops the run."""
        if self.writing is not None and (block or self.writing[0].done()):
            future, records = self.writing
            self.writing = None
            try:
                future.result()
            except RunFolderWriteError:
                self.failed = True
                raise
            for record in records:
                self.on_event(EpisodeRecorded(record))
        if self.writing is None and self.waiting:
            records, self.waiting = self.waiting, []
            self.writing = self.thread.submit(self.folder.append_results, records), records

    def drain(self) -> None:
        """Write and report everything that arrived (unless writing failed)."""
        while not self.failed and (self.writing is not None or self.waiting):
            self.pump(block=True)

    def close(self) -> None:
        """`drain`, then end the thread."""
        self.drain()
        self.thread.shutdown()


# -- the worker's side -----------------------------------------------------------------------


def _work(conn: Connection, episodes: list[PlannedEpisode], folder_path: Path,
          settings: ModelSettings, heartbeat: Any, timeout_s: float | None) -> None:
    # The supervisor owns Ctrl-C (it stops the workers); a worker must not outlive it either.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent()
    asyncio.run(_serve(conn, episodes, RunFolder(folder_path), ModelPool(settings),
                       heartbeat, timeout_s))
    conn.close()


async def _serve(conn: Connection, episodes: list[PlannedEpisode], folder: RunFolder,
                 pool: ModelPool, heartbeat: Any, timeout_s: float | None) -> None:
    """Start each episode the supervisor sends (an index into `episodes`) until it sends
    None; say when each starts and send its result line."""
    loop = asyncio.get_running_loop()
    inbox: asyncio.Queue[int | None] = asyncio.Queue()
    loop.add_reader(conn.fileno(), _read, conn, inbox)
    beat = asyncio.create_task(_beat(heartbeat))
    running: set[asyncio.Task[None]] = set()

    async def one(index: int) -> None:
        conn.send(("started", index))
        message: tuple
        try:
            record, document = await run_one(episodes[index], folder, pool,
                                             timeout_s=timeout_s)
            message = ("done", index, record, fatal_model_error(record, document))
        except (RunFolderError, RunFolderWriteError) as exc:
            message = ("error", exc)  # the supervisor stops the run with it
        except Exception as exc:  # noqa: BLE001 - the supervisor must hear of every episode
            message = ("failed", index, described(exc))
        try:
            conn.send(message)
        except OSError:
            raise  # the supervisor is gone: nobody to tell
        except Exception as exc:  # noqa: BLE001 - a message that cannot be sent (pickled)
            conn.send(("failed", index, f"its result could not be sent: {described(exc)}"))

    try:
        while (index := await inbox.get()) is not None:
            task = asyncio.create_task(one(index))
            running.add(task)
            task.add_done_callback(running.discard)
        await asyncio.gather(*running)
    finally:
        loop.remove_reader(conn.fileno())
        beat.cancel()
        await pool.aclose()


def _read(conn: Connection, inbox: asyncio.Queue[int | None]) -> None:
    try:
        inbox.put_nowait(conn.recv())
    except (EOFError, OSError):  # the supervisor is gone: finish what runs, then end
        asyncio.get_running_loop().remove_reader(conn.fileno())
        inbox.put_nowait(None)


async def _beat(heartbeat: Any) -> None:
    while True:
        heartbeat.value = time.monotonic()
        await asyncio.sleep(BEAT_S)


def _warm_up(episodes: Sequence[PlannedEpisode]) -> None:
    """Build the plan's planners here, before the workers fork, so that each inherits them
    instead of building its own (a worker's first episode took 7.7 s instead of 0.35 s on a
    busy 2-core machine when each imported LangGraph and compiled)."""
    if _context().get_start_method() == "fork":
        build_planners(p.spec.planner for p in episodes)


def _context() -> multiprocessing.context.BaseContext:
    # Fork where there is one: the parent has built the planners (and for a graph-only
    # strategy imported LangGraph) and the clients already (seconds per spawned worker
    # otherwise), and a forked worker inherits the plan.
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _die_with_parent() -> None:
    """Linux: have the kernel kill this worker when the parent dies (even by SIGKILL)."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL)
    except (OSError, AttributeError):
        pass  # elsewhere a worker ends at its next result, when the pipe is gone


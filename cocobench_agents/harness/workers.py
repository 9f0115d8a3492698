"""Running a plan across worker processes, each an event loop with its share of the episodes
and of the concurrency.

One process runs out of CPU long before a fast model server runs out of answers (the graph,
the simulator and the client cost milliseconds per call): ``--workers`` spreads the episodes
over cores. Workers write trajectories; only the parent appends to ``results.jsonl`` (one
writer keeps every line whole), as each worker sends a result back. A worker that dies loses
only the episodes it had in flight: ``--resume`` runs them again. A worker that cannot write
the run folder sends the error instead, and the parent stops the run with it. A worker that
meets a fatal model error stops every worker from starting episodes (a shared flag) and
sends the error; the parent raises it once the episodes in flight are recorded.
"""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import signal
from collections.abc import Sequence
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from cocobench_agents.harness.batch import (
    Halt,
    ResultCallback,
    execute_and_close,
    longest_first,
)
from cocobench_agents.harness.errors import FatalModelError, WorkerError
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.store import RunFolder, RunFolderError, RunFolderWriteError
from cocobench_agents.models import ModelPool, ModelSettings


def available_cores() -> int:
    """Cores this process may use (its CPU affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def execute_in_workers(episodes: Sequence[PlannedEpisode], folder: RunFolder,
                       settings: ModelSettings, *, jobs: int, workers: int,
                       on_result: ResultCallback | None = None,
                       **run_options: Any) -> None:
    """Run every episode in `workers` processes sharing `jobs` (and each model's
    `max_concurrency`) between them; append each result as it arrives, then `on_result`.
    `run_options` (a spend limit, the episode timeout) go to `execute` in every worker.
    Raises the first `FatalModelError` a worker met, once every worker has ended."""
    workers = max(1, min(workers, jobs, len(episodes)))
    episodes = longest_first(episodes)  # dealt in turn: each worker gets long and short ones
    context = _context()
    halt = context.Event()
    running: dict[Connection, multiprocessing.process.BaseProcess] = {}
    try:
        for index in range(workers):
            receive, send = context.Pipe(duplex=False)
            process = context.Process(
                target=_work, name=f"cocobench-worker-{index}", daemon=True,
                args=(episodes[index::workers], folder.path, _share_settings(settings, index,
                      workers), share(jobs, index, workers), send, halt, run_options))
            process.start()
            send.close()  # the worker holds the only sending end: EOF means it has ended
            running[receive] = process
        _collect(running, folder, on_result)
    finally:
        for process in running.values():  # on Ctrl-C or an error here: stop them all
            if process.is_alive():
                process.terminate()
            process.join()


def _collect(running: dict[Connection, Any], folder: RunFolder,
             on_result: ResultCallback | None) -> None:
    died = []
    fatal: list[FatalModelError] = []
    open_ends = dict(running)
    while open_ends:
        for end in wait(list(open_ends)):
            try:
                record = end.recv()
            except EOFError:
                process = open_ends.pop(end)
                process.join()
                if process.exitcode != 0:
                    died.append(f"{process.name} (exit code {process.exitcode})")
                continue
            if isinstance(record, (RunFolderError, RunFolderWriteError)):
                raise record  # a worker could not write the run folder: the run stops
            if isinstance(record, FatalModelError):
                fatal.append(record)  # its worker has set `halt`: the others start no more
                continue
            folder.append_result(record)
            if on_result is not None:
                on_result(record)
    if fatal:
        raise fatal[0]  # it says what to fix; --resume --retry-errors runs the rest
    if died:
        raise WorkerError(f"{', '.join(died)} stopped early: the episodes it had not finished "
                          "are missing; run again with --resume to complete them")


def _work(episodes: list[PlannedEpisode], folder_path: Path, settings: ModelSettings,
          jobs: int, send: Connection, halt: Halt, run_options: dict[str, Any]) -> None:
    # The parent owns Ctrl-C (it stops the workers); a worker must not outlive it either.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent()
    try:
        asyncio.run(execute_and_close(episodes, RunFolder(folder_path), ModelPool(settings),
                                      jobs=jobs, store_result=send.send, halt=halt,
                                      **run_options))
    except (RunFolderError, RunFolderWriteError, FatalModelError) as exc:
        send.send(exc)  # the parent stops the run with it (no traceback from here)
    send.close()


def share(total: int, index: int, parts: int) -> int:
    """Worker `index`'s part of `total` (parts differ by at least one, never below one)."""
    return max(1, total // parts + (1 if index < total % parts else 0))


def _share_settings(settings: ModelSettings, index: int, parts: int) -> ModelSettings:
    return settings.model_copy(
        update={"max_concurrency": share(settings.max_concurrency, index, parts)})


def _context() -> multiprocessing.context.BaseContext:
    # Fork where there is one: the parent has imported LangGraph and the clients already
    # (seconds per spawned worker otherwise) and runs no event loop or thread yet.
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

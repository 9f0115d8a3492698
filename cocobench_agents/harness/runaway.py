"""Runaway episodes: what counts as one, and how its result line says so.

An episode runs inside a worker (a process of a local run, an actor of a Ray run) that its
executor watches from outside: the worker's memory, and whether its event loop still runs. A
worker past its memory budget, or silent past the stall limit, is stopped — the only way to
stop a computation that never yields — and the episodes it had in flight run again *alone*,
once: the one that runs away again is the culprit, and is recorded as an infrastructure error
whose text starts with the cause (``memory: …`` or ``stalled: …``). ``--resume
--retry-errors`` runs such episodes again, as any infrastructure failure.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

MEMORY, STALLED = "memory", "stalled"
MB = 1 << 20
LOW_MEMORY_SHARE = 0.05  # the machine is about to run out below this share of its memory


@dataclass(frozen=True)
class RunawayLimits:
    """When a worker is stopped: its resident memory past what it had when it started by
    more than `episode_memory_mb` per episode in flight, or its event loop silent for more
    than `stall_s` seconds (a healthy episode yields within milliseconds)."""

    episode_memory_mb: float = 2048.0
    stall_s: float = 120.0

    def breach(self, *, grown_bytes: int | None, in_flight: int, silent_s: float
               ) -> str | None:
        """The cause (`MEMORY`, `STALLED`) for which a worker with `in_flight` episodes that
        grew by `grown_bytes` since its start and whose loop was silent for `silent_s`
        must stop, or None."""
        if in_flight and silent_s > self.stall_s:
            return STALLED
        if grown_bytes is not None and grown_bytes > self.budget_bytes(in_flight):
            return MEMORY
        return None

    def budget_bytes(self, in_flight: int) -> int:
        """What a worker with `in_flight` episodes may grow by."""
        return int(self.episode_memory_mb * MB * max(1, in_flight))

    def error(self, cause: str) -> str:
        """The `infra_error` of an episode stopped for `cause` twice, the second time while it
        ran alone (so it is the culprit)."""
        again = " (again when it ran alone)"
        if cause == MEMORY:
            return (f"memory: the episode grew its worker by more than "
                    f"{self.episode_memory_mb:g} MB (--episode-memory){again}; it was stopped")
        if cause == STALLED:
            return (f"stalled: the episode stopped yielding for more than {self.stall_s:g} s "
                    f"(--stall-timeout){again}; it was stopped")
        return f"{cause}{again}"


DEFAULT_LIMITS = RunawayLimits()


def runaway_causes(records: Iterable[Mapping[str, Any]]) -> dict[str, int]:
    """How many of `records` were stopped as runaways, by cause."""
    causes = (str(r.get("infra_error") or "").partition(":")[0] for r in records)
    return dict(Counter(c for c in causes if c in (MEMORY, STALLED)))


def rss_bytes(pid: int) -> int | None:
    """The resident memory of process `pid` (None where /proc cannot tell: not Linux, or the
    process is gone)."""
    try:
        with open(f"/proc/{pid}/statm", "rb") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def machine_memory_low() -> bool:
    """Whether the machine is about to run out of memory (less than `LOW_MEMORY_SHARE` of it
    available); False where /proc cannot tell."""
    fields: dict[str, int] = {}
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                name, _, value = line.partition(":")
                fields[name] = int(value.split()[0])
    except (OSError, ValueError, IndexError):
        return False
    total, available = fields.get("MemTotal"), fields.get("MemAvailable")
    return bool(total and available is not None and available < LOW_MEMORY_SHARE * total)

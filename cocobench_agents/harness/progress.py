"""Progress of a run: one line per finished episode, and a live status line on a terminal.

Off a terminal (CI, files) only the plain per-episode lines are written.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO


class Progress:
    """Counts finished episodes and reports them."""

    def __init__(self, total: int, *, already_done: int = 0, stream: TextIO | None = None,
                 live: bool | None = None) -> None:
        self.stream = stream or sys.stderr
        self.live = self.stream.isatty() if live is None else live
        self.total, self.done = total, already_done
        self.ran = self.successes = self.errors = 0
        self.tokens, self.cost = 0, 0.0
        self.started = time.monotonic()

    def episode_done(self, record: dict[str, Any]) -> None:
        """Account for one result line and print it."""
        self.done += 1
        self.ran += 1
        self.successes += int(record.get("task_success") or 0)
        self.errors += bool(record.get("infra_error"))
        usage = record.get("usage") or {}
        self.tokens += int(usage.get("prompt_tokens") or 0) + int(
            usage.get("completion_tokens") or 0)
        self.cost += float(usage.get("cost_usd") or 0.0)
        self._clear()
        print(f"[{self.done}/{self.total}] {episode_line(record)}", file=self.stream)
        self._status()

    def close(self) -> None:
        """End the live line."""
        if self.live:
            self._clear()
            print(self.status_text(), file=self.stream, flush=True)

    def status_text(self) -> str:
        """done/total, success so far, tokens, cost, ETA."""
        rate = f"{self.successes}/{self.ran}" if self.ran else "0/0"
        elapsed = time.monotonic() - self.started
        left = self.total - self.done
        eta = elapsed / self.ran * left if self.ran else 0.0
        return (f"{self.done}/{self.total} done | success {rate} | {self.tokens:,} tokens | "
                f"${self.cost:.4f} | errors {self.errors} | ETA {_duration(eta)}")

    def _status(self) -> None:
        if self.live:
            self.stream.write(self.status_text())
            self.stream.flush()

    def _clear(self) -> None:
        if self.live:
            self.stream.write("\r\033[K")


def episode_line(record: dict[str, Any]) -> str:
    """The one-line summary of an episode."""
    head = f"{record.get('model')} {record.get('condition')} {record.get('task_id')}"
    if record.get("epoch"):
        head += f" e{record['epoch']}"
    if record.get("infra_error"):
        return f"{head}: ERROR {record['infra_error'][:160]}"
    construct = record.get("construct_score")
    construct_text = f"{construct:.2f}" if construct is not None else record.get(
        "construct_status")
    return (f"{head}: success={record.get('task_success')} "
            f"progress={_num(record.get('task_progress'))} legal={record.get('legal_plan')} "
            f"construct={construct_text} steps={record.get('num_steps')} "
            f"terminal={record.get('terminal_reason')} {record.get('elapsed_s', 0):.1f}s")


def _num(value: Any) -> str:
    return "-" if value is None else f"{value:.2f}"


def _duration(seconds: float) -> str:
    seconds = int(seconds)
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    return f"{seconds // 60}m{seconds % 60:02d}s"

"""Progress of a run: a live bar on a terminal (rich), plain lines elsewhere (CI, files).

Both show done/total, success so far, errors, tokens, cost and the time left; every finished
episode also gets one line. A resumed run counts every episode of the run: those recorded
before it resumed as well as those it runs now.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable
from typing import Any, TextIO

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeRemainingColumn
from rich.progress import Progress as RichProgress

from cocobench_agents.engine import events
from cocobench_agents.runfolder.infra import is_infra_failure, is_planner_failure

#: Off a terminal, a status line every this many seconds (and at the end).
PLAIN_STATUS_EVERY_S = 30.0


class Progress:
    """Counts finished episodes and reports them; `recorded` are the result lines of the
    episodes already done (a resumed run), counted in every total."""

    def __init__(self, total: int, *, recorded: Iterable[dict[str, Any]] = (),
                 stream: TextIO | None = None, live: bool | None = None) -> None:
        self.stream = stream or sys.stderr
        self.live = self.stream.isatty() if live is None else live
        self.total = total
        self.done = self.successes = self.errors = self.planner_errors = 0
        self.tokens, self.cost = 0, 0.0
        for record in recorded:
            self._count(record)
        self._last_status = time.monotonic()
        # Off a terminal the bar is not drawn; it still keeps the rate that estimates the ETA.
        self._bar = _bar(self.stream, total, self.done, self.status_fields())
        if self.live:
            self._bar.start()

    def episode_done(self, record: dict[str, Any]) -> None:
        """Account for one result line and show it."""
        self._count(record)
        line = f"[{self.done}/{self.total}] {episode_line(record)}"
        self._bar.update(self._task, completed=self.done, status=self.status_fields())
        if self.live:
            self._bar.console.print(line, markup=False, highlight=False, soft_wrap=True)
        else:
            print(line, file=self.stream, flush=True)
            if time.monotonic() - self._last_status >= PLAIN_STATUS_EVERY_S:
                self._last_status = time.monotonic()
                print(self.status_text(), file=self.stream, flush=True)

    def _count(self, record: dict[str, Any]) -> None:
        self.done += 1
        self.successes += int(record.get("task_success") or 0)
        self.errors += is_infra_failure(record)
        self.planner_errors += is_planner_failure(record)
        usage = record.get("usage") or {}
        self.tokens += int(usage.get("prompt_tokens") or 0) + int(
            usage.get("completion_tokens") or 0)
        self.cost += float(usage.get("cost_usd") or 0.0)

    def close(self) -> None:
        """End the live bar; off a terminal, print the final status."""
        if self.live:
            self._bar.stop()
        elif self.done:
            print(self.status_text(), file=self.stream, flush=True)

    def status_fields(self) -> str:
        """Success so far, errors, tokens, cost: of every episode done, in this process or
        before a resume."""
        rate = f"{100 * self.successes / self.done:.1f}%" if self.done else "-"
        planner = f" | planner errors {self.planner_errors}" if self.planner_errors else ""
        return (f"SR {rate} ({self.successes}/{self.done}) | errors {self.errors}{planner} | "
                f"{self.tokens:,} tokens | ${self.cost:.4f}")

    def status_text(self) -> str:
        """done/total, the status fields and the time left."""
        eta = self._bar.tasks[0].time_remaining
        eta_text = "-" if eta is None else _duration(eta)
        return f"{self.done}/{self.total} done | {self.status_fields()} | ETA {eta_text}"

    @property
    def _task(self) -> Any:
        return self._bar.task_ids[0]


def _bar(stream: TextIO, total: int, done: int, status: str) -> RichProgress:
    bar = RichProgress(
        MofNCompleteColumn(), BarColumn(), TextColumn("{task.fields[status]}"),
        TextColumn("ETA"), TimeRemainingColumn(),
        console=Console(file=stream), transient=False, refresh_per_second=4)
    bar.add_task("episodes", total=total, completed=done, status=status)
    return bar


def episode_line(record: dict[str, Any]) -> str:
    """The one-line summary of an episode."""
    arm = f" {record['arm']}" if record.get("arm") else ""
    head = f"{record.get('model')} {record.get('condition')}{arm} {record.get('task_id')}"
    if record.get("epoch"):
        head += f" e{record['epoch']}"
    if record.get("infra_error"):
        first, _, frames = record["infra_error"].partition("\n")
        return f"{head}: ERROR {first[:160]}" + (f"\n{frames}" if frames else "")
    if record.get("planner_error"):
        # The node's error is followed by its traceback's last frames: kept whole.
        first, _, frames = record["planner_error"].partition("\n")
        return f"{head}: PLANNER ERROR {first}" + (f"\n{frames}" if frames else "")
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


class RunView:
    """Draws the engine's events: notices on stderr, the run's size, then a `Progress` of
    the episodes as they are recorded."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stderr
        self.progress: Progress | None = None

    def __call__(self, event: events.Event) -> None:
        if isinstance(event, events.Notice):
            prefix = "cocobench: warning: " if event.warning else ""
            print(f"{prefix}{event.message}", file=self.stream, flush=True)
        elif isinstance(event, events.RunStarted):
            print(f"{event.total} episodes ({event.done} already done) → {event.folder}",
                  file=self.stream, flush=True)
            if event.done < event.total:
                self.progress = Progress(event.total, recorded=event.recorded,
                                         stream=self.stream)
        elif isinstance(event, events.EpisodeRecorded) and self.progress is not None:
            self.progress.episode_done(event.record)

    def close(self) -> None:
        """End the live display (the run ended, or stopped)."""
        if self.progress is not None:
            self.progress.close()
            self.progress = None

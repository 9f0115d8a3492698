"""What the engine tells a front end while a run goes: any door (the command line's rich
progress, a notebook, a web page) draws these; the engine itself prints nothing.

Every executor reports each episode's start and result line (`harness.executor`); step
events come from episodes run in this process (those with a human seat).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

# What an executor tells of its episodes, told on as it is.
from cocobench_agents.harness.executor import EpisodeRecorded, EpisodeStarted, StepLanded


@dataclass(frozen=True)
class Notice:
    """Something the user should read that does not stop the run (a repaired results file,
    a lock taken over from a dead process, tasks an index lists but are absent, where Ray
    runs the episodes)."""

    message: str
    warning: bool = True  # False: for information only (where a Ray run's workers are)


@dataclass(frozen=True)
class RunStarted:
    """The plan is made and checked; `total` episodes, `done` of them already recorded
    (`recorded`: their result lines, so that a resumed run's progress counts every episode
    of the run, not only those it runs now)."""

    folder: Path
    total: int
    done: int
    recorded: tuple[dict[str, Any], ...] = ()


@dataclass(frozen=True)
class LimitReached:
    """A spend limit stopped the starting of new episodes."""

    description: str
    left: int


Event = Notice | RunStarted | EpisodeStarted | StepLanded | EpisodeRecorded | LimitReached
EventHandler = Callable[[Event], None]


def ignore(event: Event) -> None:
    """The handler of a run nobody watches."""

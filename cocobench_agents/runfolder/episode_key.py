"""`EpisodeKey`: which episode of a run a trajectory folder or a result line belongs to."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


def model_slug(model: str) -> str:
    """A folder-safe form of a model string (never `.` or `..`, which would name a folder
    above the one it is meant to be in)."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", model).strip("_")
    return slug if slug.strip(".") else "model"


@dataclass(frozen=True)
class EpisodeKey:
    """Identifies one episode of a run."""

    model: str
    condition: str
    task_id: str
    epoch: int = 0
    #: The prompt-suite arm of a run that compares several (`plan.suite_arms`); "" otherwise,
    #: so that a single-suite run's folders and result lines are those of before arms.
    arm: str = ""

    def parts(self) -> list[str]:
        """The names of its folder below `episodes/`: model, condition, arm (when it has
        one), task id with its epoch."""
        leaf = self.task_id if self.epoch == 0 else f"{self.task_id}@e{self.epoch}"
        arm = [model_slug(self.arm)] if self.arm else []
        return [model_slug(self.model), self.condition, *arm, leaf]

    def folder(self) -> str:
        """Where its trajectory lives, relative to the run folder."""
        return "/".join(["episodes", *self.parts()])

    def as_dict(self) -> dict[str, Any]:
        out = {"model": self.model, "condition": self.condition, "task_id": self.task_id,
               "epoch": self.epoch}
        if self.arm:
            out["arm"] = self.arm
        return out

    def name(self) -> str:
        """The episode in a message (``greedy C0_image t1 epoch 1``)."""
        epoch = f" epoch {self.epoch}" if self.epoch else ""
        arm = f" arm {self.arm}" if self.arm else ""
        return f"{self.model} {self.condition}{arm} {self.task_id}{epoch}"


def result_key(record: Mapping[str, Any]) -> EpisodeKey:
    """The episode a result line belongs to."""
    return EpisodeKey(record["model"], record["condition"], record["task_id"],
                      int(record.get("epoch") or 0), record.get("arm") or "")

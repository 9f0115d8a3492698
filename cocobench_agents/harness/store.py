"""The run folder (DESIGN §4): `run.json`, `results.jsonl`, one trajectory per episode.

Crash safety: a trajectory is written atomically (temp file + rename) before its result line;
each result line is appended with a single `write` and fsync'd. A SIGKILL can at worst leave
one partial last line, which readers skip and `open_for_resume` cuts off. So the folder is
never corrupt, and an episode counts as done only once its line is complete.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmark_adapter.trajectory import write_json_atomic


def model_slug(model: str) -> str:
    """A folder-safe form of a model string."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", model).strip("_") or "model"


@dataclass(frozen=True)
class EpisodeKey:
    """Identifies one episode of a run."""

    model: str
    condition: str
    task_id: str
    epoch: int = 0

    def folder(self) -> str:
        """Where its trajectory lives, relative to the run folder."""
        leaf = self.task_id if self.epoch == 0 else f"{self.task_id}@e{self.epoch}"
        return f"episodes/{model_slug(self.model)}/{self.condition}/{leaf}"

    def as_dict(self) -> dict[str, Any]:
        return {"model": self.model, "condition": self.condition, "task_id": self.task_id,
                "epoch": self.epoch}


RESULTS = "results.jsonl"
RUN_FILE = "run.json"


class RunFolderError(ValueError):
    """A run folder that cannot be used as asked (exists without --resume, …)."""


class RunFolder:
    """One run's folder."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    @property
    def results_path(self) -> Path:
        return self.path / RESULTS

    def create(self, run_record: dict[str, Any]) -> None:
        """Start a new run; refuse to touch an existing one."""
        if (self.path / RUN_FILE).exists() or self.results_path.exists():
            raise RunFolderError(f"{self.path} already holds a run: pass --resume to complete "
                                 "it, or choose another --out folder")
        self.path.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.path / RUN_FILE, run_record)

    def open_for_resume(self) -> dict[str, Any] | None:
        """The recorded run (None if the folder holds none yet); a torn last result line
        (from a kill) is cut off."""
        if not (self.path / RUN_FILE).exists():
            if self.results_path.exists():
                raise RunFolderError(f"{self.path} has results but no {RUN_FILE}")
            return None
        self._drop_torn_tail()
        return self.run_record()

    def run_record(self) -> dict[str, Any]:
        with open(self.path / RUN_FILE, encoding="utf-8") as f:
            return json.load(f)

    def update_run_record(self, record: dict[str, Any]) -> None:
        write_json_atomic(self.path / RUN_FILE, record)

    def write_trajectory(self, key: EpisodeKey, document: dict[str, Any]) -> str:
        """Write an episode's trajectory; return its path relative to the run folder."""
        relative = f"{key.folder()}/trajectory.json"
        write_json_atomic(self.path / relative, document)
        return relative

    def append_result(self, record: dict[str, Any]) -> None:
        """Append one result line atomically (one write of a whole line, then fsync)."""
        line = (json.dumps(record, sort_keys=True, ensure_ascii=False) + "\n").encode("utf-8")
        fd = os.open(self.results_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)

    def results(self) -> Iterator[dict[str, Any]]:
        """Complete result lines in file order (a torn last line is skipped)."""
        if not self.results_path.exists():
            return
        with open(self.results_path, encoding="utf-8") as f:
            for line in f:
                if line.endswith("\n"):
                    try:
                        yield json.loads(line)
                    except json.JSONDecodeError:
                        continue

    def _drop_torn_tail(self) -> None:
        if not self.results_path.exists():
            return
        data = self.results_path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end != len(data):
            with open(self.results_path, "r+b") as f:
                f.truncate(end)


def result_key(record: dict[str, Any]) -> EpisodeKey:
    """The episode a result line belongs to."""
    return EpisodeKey(record["model"], record["condition"], record["task_id"],
                      int(record.get("epoch") or 0))

"""Helpers for the report tests: static run folders and variants of them.

`fixtures/run_small` and `fixtures/run_oracle` were written once by `cocobench run` (see
fixtures/README.md) and are kept as static files; trajectories are left out because the report
reads only `run.json` and `results.jsonl`.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

HERE = Path(__file__).parent
FIXTURES = HERE / "fixtures"
GOLDEN = HERE / "golden"
RUN_SMALL = FIXTURES / "run_small"
RUN_ORACLE = FIXTURES / "run_oracle"
RUN_ARMS = FIXTURES / "run_arms"
RUN_ORACLE_SHORT = FIXTURES / "run_oracle_short"


def result_lines(run: Path) -> list[dict[str, Any]]:
    with open(run / "results.jsonl", encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


def write_run(path: Path, lines: list[dict[str, Any]], run_json: Path | None = None,
              tail: str = "") -> Path:
    """A run folder with these result lines (and an optional raw, unterminated tail)."""
    path.mkdir(parents=True, exist_ok=True)
    if run_json is not None:
        shutil.copy(run_json, path / "run.json")
    with open(path / "results.jsonl", "w", encoding="utf-8", newline="\n") as f:
        for line in lines:
            f.write(json.dumps(line, sort_keys=True) + "\n")
        f.write(tail)
    return path


NOT_RUN_FOLDERS = ["missing", "file", "empty"]


def not_a_run_folder(path: Path, make: str) -> Path:
    """A path that is not a run folder: nothing there, a file, or an empty folder."""
    if make == "file":
        path.write_text("{}", encoding="utf-8")
    elif make == "empty":
        path.mkdir()
    return path


#: A result line synthetic episodes (`synthetic_run`) are made from.
TEMPLATE = next(line for line in result_lines(RUN_SMALL)
                if line["model"] == "greedy" and line["condition"] == "C0_image")


def episode(model: str, task: int, epoch: int, success: bool, **more: Any) -> dict[str, Any]:
    """A valid result line of `model` on synthetic instance `task`."""
    return {**TEMPLATE, "model": model, "task_id": f"T{task:03d}", "epoch": epoch,
            "task_success": int(success), "legal_plan": float(success), **more}


def synthetic_run(path: Path, outcomes: dict[str, list[list[bool]]]) -> Path:
    """A run folder: for each model, outcomes[instance][epoch]."""
    return write_run(path, [episode(model, i, e, ok) for model, rows in outcomes.items()
                            for i, row in enumerate(rows) for e, ok in enumerate(row)])


#: A: instances 0-9 always succeed, 10-19 never. B: every instance succeeds in 1 epoch of 3.
CONSISTENT = [[True] * 3] * 10 + [[False] * 3] * 10
FLIPPING = [[(i + e) % 3 == 0 for e in range(3)] for i in range(20)]

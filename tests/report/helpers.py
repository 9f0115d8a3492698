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

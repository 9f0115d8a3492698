"""Replaying a recorded multi-condition run through `replay:RUN` reproduces it episode for
episode (same choices, same scores)."""

from __future__ import annotations

import json
from pathlib import Path

from cocobench_agents.cli import main


def outcomes(folder: Path) -> dict[tuple, tuple]:
    out = {}
    for line in (folder / "results.jsonl").read_text().splitlines():
        r = json.loads(line)
        out[(r["condition"], r["task_id"])] = (r["task_success"], r["num_steps"],
                                               r["construct_score"], r["terminal_reason"])
    return out


def test_a_replayed_run_equals_the_recorded_one(tmp_path: Path, capsys) -> None:
    recorded, replayed = tmp_path / "recorded", tmp_path / "replayed"
    common = ["run", "--suite", "demo", "--conditions", "C0_blind,D1_blind", "--jobs", "4"]
    assert main([*common, "--model", "random:3", "--out", str(recorded)]) == 0
    assert main([*common, "--model", f"replay:{recorded}", "--out", str(replayed)]) == 0
    capsys.readouterr()
    assert outcomes(replayed) == outcomes(recorded)
    decisions = [json.loads(line) for line in (replayed / "results.jsonl").read_text().splitlines()]
    assert all(d["backend_errors"] == 0 for d in decisions)

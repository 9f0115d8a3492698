"""The paper's whole suite finishes: `cocobench-full` with greedy and the baselines over 16
worker processes on whatever cores there are (2 in CI), every episode recorded once."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

FULL_EPISODES = 2691  # 897 instances × (greedy, oracle, random)


@pytest.mark.slow
def test_cocobench_full_with_16_workers_records_every_episode(tmp_path):
    out = tmp_path / "full"
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", "cocobench-full",
         "--model", "greedy", "--baselines", "--workers", "16", "--jobs", "32",
         "--out", str(out)],
        capture_output=True, text=True, timeout=1800, env={**os.environ, "NO_COLOR": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    records = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    keys = {(r["model"], r["condition"], r["task_id"], r["epoch"]) for r in records}
    assert len(records) == len(keys) == FULL_EPISODES
    assert not [r for r in records if r.get("infra_error")]

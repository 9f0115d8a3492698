"""A 5,000-episode run reports whole. How long it takes is bench/report_epochs.py's to
measure (`--instances 500 --epochs 5 --models 1`: 5,000 episodes), not a test's: a timed
test fails on a busy machine."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from cocobench_agents.reports import build_report

from .helpers import RUN_SMALL, result_lines, write_run


@pytest.mark.slow
def test_five_thousand_episodes(tmp_path: Path) -> None:
    base = result_lines(RUN_SMALL)
    rng = random.Random(0)
    lines = []
    for k in range(4):  # 4 models × 6 conditions × 4 tasks × 52 epochs ≈ 5,000 episodes
        for epoch in range(52):
            for line in base:
                if line["model"] != "greedy":
                    continue
                lines.append(dict(
                    line, model=f"model-{k}", epoch=epoch,
                    task_success=int(rng.random() < 0.2 + 0.2 * k),
                    task_progress=rng.random(),
                    construct_score=rng.random() if rng.random() < 0.8 else None,
                    elapsed_s=rng.uniform(1, 100)))
    assert len(lines) == 4992
    run = write_run(tmp_path / "run", lines)
    summary = build_report([run], tmp_path / "out", plots=False)
    assert summary.episodes == 4992

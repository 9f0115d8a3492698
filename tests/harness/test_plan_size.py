"""A plan is bounded (issue 34): every planned episode is held in memory, so a plan of more
than `MAX_EPISODES` is refused before it is built (``--epochs 1000000 --dry-run`` grew past
1.7 GB), in one line naming its size and what to split."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import Condition, PlanError, episodes, plan_episodes


def test_absurd_epochs_are_refused_before_the_plan_is_built(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", "demo", "--model",
         "greedy", "--epochs", "1000000", "--dry-run", "--out", str(tmp_path / "run")],
        capture_output=True, text=True, timeout=60, env={**os.environ, "NO_COLOR": "1"})
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "cocobench: error: the plan holds 4,000,000 episodes (4 per epoch × 1,000,000 "
        "epochs), more than one run takes (250,000): split it into several runs (fewer "
        "--epochs, models, conditions or instances in each)")
    assert not (tmp_path / "run").exists()


def test_the_bound_counts_the_episodes_the_plan_would_hold(monkeypatch):
    monkeypatch.setattr(episodes, "MAX_EPISODES", 8)
    tasks = load_tasks("demo")  # 4 instances
    blind = [Condition("centralized", "blind")]
    assert len(plan_episodes(tasks, ["greedy"], blind, 2)) == 8
    with pytest.raises(PlanError, match="the plan holds 12 episodes"):
        plan_episodes(tasks, ["greedy"], blind, 3)
    # The oracle calls no model: planned once whatever the models, and counted once.
    oracle = [Condition("oracle", "blind")]
    assert len(plan_episodes(tasks, ["greedy", "random:1"], oracle, 2)) == 8

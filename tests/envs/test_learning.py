"""The default rewards teach: `examples/learned-seat`'s linear policy, trained with them on
cocobench-240's first 160 instances, makes more goal progress on held-out instances than the
`random` model's choice and than doing nothing (seeds fixed, so the figures are the same on
every run)."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.needs_env, pytest.mark.slow]

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "learned-seat" / "train.py"


def test_the_example_policy_beats_random_and_doing_nothing_on_held_out_instances():
    example = runpy.run_path(str(EXAMPLE), run_name="learned_seat")
    environment = example["parallel_env"]("cocobench-240", condition="C0_blind")
    tasks = [c.task_id for c in environment.configs]
    train_tasks, held_out = tasks[:160], tasks[160:200]
    policy = example["LinearPolicy"](np.random.default_rng(0))
    example["train"](environment, policy, train_tasks, 200)
    learned = example["evaluate"](environment, held_out, policy)
    random = example["evaluate"](environment, held_out,
                                 example["uniform"](np.random.default_rng(0)))
    nothing = example["evaluate"](environment, held_out, example["do_nothing"])
    assert nothing.progress == 0.0 and nothing.ret == 0.0
    assert learned.progress > random.progress > nothing.progress, (learned, random)

"""Invariant fuzz (issue 41): seeded random menu, off-menu and native steps on a sample of
instances from every cell of cocobench-full and of the shared configs, every invariant of
`benchmark_adapter.invariants` checked after each step, the trajectory checked
for non-finite numbers and replayed byte for byte. The full sweep is `bench/sim_sweep.py`."""

from __future__ import annotations

import functools
import importlib.util
import itertools
import sys
from pathlib import Path

import pytest

from benchmark_adapter.invariants import InvariantBroken, play
from benchmark_adapter.sim.embedded import actions
from benchmark_adapter.sim.embedded.world import World
from benchmark_adapter.tasks import TaskConfig, load_task, load_tasks
from tests.paths import SHARED_TASKS

REPO = Path(__file__).resolve().parents[2]
STEPS = 120
PER_CELL = 2


def cell_of(config: TaskConfig) -> str:
    return config.task_id.split("__")[0]  # family and dimension: A_D1, C_D4, …


@functools.cache
def sample() -> list[TaskConfig]:
    """`PER_CELL` instances of every cell of cocobench-full, then every cell's first shared
    config, spread over each cell's list rather than its first few."""
    full = load_tasks("cocobench-full")
    by_cell = {cell: list(group) for cell, group in
               itertools.groupby(sorted(full, key=lambda c: c.task_id), key=cell_of)}
    picked = [group[i * len(group) // PER_CELL] for group in by_cell.values()
              for i in range(PER_CELL)]
    shared = sorted(SHARED_TASKS.glob("*.json")) if SHARED_TASKS.is_dir() else []
    firsts = {cell_of(c): c for c in reversed([load_task(p) for p in shared])}
    return picked + list(firsts.values())


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(sample())),
                         ids=[c.task_id for c in sample()])
def test_random_steps_keep_every_invariant(index: int) -> None:
    played = play(sample()[index], seed=index, steps=STEPS)
    assert set(played.kinds) == {"menu", "skill", "native"}
    assert played.refused > 0  # refusals were tried, and changed nothing


def test_the_sample_covers_every_cell() -> None:
    cells = {cell_of(c) for c in load_tasks("cocobench-full")}
    assert {cell_of(c) for c in sample()} == cells
    assert len(sample()) >= PER_CELL * len(cells)


# -- the fuzz finds the bugs it is there for --------------------------------------------------

LOADED = "C_D2__EmbBedroom01__load_in_order_seed0"


def test_the_fuzz_finds_contents_left_behind(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(World, "descendants", lambda self, obj: [])
    config = next(c for c in load_tasks("cocobench-full") if c.task_id == LOADED)
    with pytest.raises(InvariantBroken, match=r"lies \d+\.\d+ m from .*, which contains it"):
        play(config, seed=0, steps=150)


def test_the_fuzz_finds_non_finite_numbers(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(actions, "_finite",
                        lambda kw, name, default: float(kw.get(name, default)))
    config = next(c for c in load_tasks("cocobench-full")
                  if c.task_id == "A_D1__EmbKitchen02__store_groceries_3agent_seed0")
    with pytest.raises(InvariantBroken, match=r"non-finite|raised"):
        play(config, seed=0, steps=20)


# -- the sweep counts an episode that fails any other way ---------------------------------

def test_the_sweep_counts_an_episode_that_raises_as_a_breach(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = importlib.util.spec_from_file_location("sim_sweep", REPO / "bench" / "sim_sweep.py")
    assert spec is not None and spec.loader is not None
    sweep = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sweep)

    def planted(config: TaskConfig, seed: int, steps: int) -> None:
        raise RuntimeError("planted fault")

    monkeypatch.setattr(sweep, "play", planted)
    monkeypatch.setattr(sys, "argv", ["sim_sweep.py", "--limit", "2", "--seeds", "1"])
    assert sweep.main() == 1  # it ended with its figures, not a traceback
    out = capsys.readouterr().out
    assert "breaches 2" in out
    assert "play raised RuntimeError('planted fault')" in out

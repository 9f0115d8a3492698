"""Real run folders for the viewer's tests, made once per session by `cocobench run`."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cocobench_agents.cli import main

#: One instance per coordination dimension, so every construct signal is drawn.
TASKS = ("A_D1__EmbKitchen05__store_groceries_seed0", "A_D2__EmbKitchen03__stock_cabinet_seed0",
         "K_D3__EmbKitchen01__prepare_food_3agent_seed0",
         "C_D4__EmbBathroom02__relay_items_3agent_seed0")


@pytest.fixture(scope="session")
def fixed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A greedy run (centralized C0 and decentralized D1, image and blind) over `TASKS`:
    8 episodes. Read-only: copy it (`run_copy`) to change it."""
    out = tmp_path_factory.mktemp("viewer") / "run"
    args = ["run", "--model", "greedy", "--conditions", "C0_image,D1_blind", "--out", str(out)]
    for task in TASKS:
        args += ["--task-id", task]
    assert main(args) == 0
    return out


@pytest.fixture
def run_copy(fixed_run: Path, tmp_path: Path) -> Path:
    """A private copy of the fixed run, free to change."""
    return Path(shutil.copytree(fixed_run, tmp_path / "run"))

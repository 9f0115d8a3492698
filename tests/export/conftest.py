"""Real run folders for the export's tests, made once per session by `cocobench run` with
built-in models on shared configs: greedy and random under C0, D0 and D1, image and blind
(they fail), and a scripted team that plays the oracle's calls (it succeeds)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import cocobench_agents as cb
from cocobench_agents.cli import main
from tests.human.desks import OracleDesk
from tests.paths import SHARED_TASKS

#: Two agents (D1) and a relay of two (D4): distributed seats and a centralized planner.
TASKS = ("A_D1__FloorPlan1__seed0", "C_D4__FloorPlan1__seed0")
CONDITIONS = "C0_image,C0_blind,D0_blind,D1_image,D1_blind"
SOLVED = "A_D1__FloorPlan1__seed0"


def config(task: str) -> str:
    return str(SHARED_TASKS / f"{task}.json")


@pytest.fixture(scope="session")
def played_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """greedy and random over `TASKS` × `CONDITIONS`: 20 episodes. Read-only: copy it
    (`run_copy`) to change it."""
    out = tmp_path_factory.mktemp("export") / "played"
    args = ["run", "--model", "greedy", "--model", "random:3", "--conditions", CONDITIONS,
            "--out", str(out), "--max-steps", "12"]
    for task in TASKS:
        args += ["--task", config(task)]
    assert main(args) == 0
    return out


@pytest.fixture(scope="session")
def solved_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A `scripted:` model replaying the oracle's calls on `SOLVED` under C0_blind: one
    successful episode (the script is what a person playing those calls would reply)."""
    base = tmp_path_factory.mktemp("solved")
    selection = {"sources": [config(SOLVED)]}
    oracle = cb.run(cb.RunRequest(out=base / "oracle", selection=selection,
                                  conditions=["OR_blind"]))[0]
    document = json.loads((base / "oracle" / oracle["trajectory"]).read_text())
    desk = OracleDesk([i["label"] for i in document["trajectory"] if "skill_result" in i])
    cb.run(cb.RunRequest(out=base / "human", models=["human"], selection=selection,
                         conditions=["C0_blind"]), desk=desk)
    script = base / "replies.json"
    script.write_text(json.dumps(desk.reply_texts()))
    out = base / "scripted"
    [result] = cb.run(cb.RunRequest(out=out, models=[f"scripted:{script}"],
                                    selection=selection, conditions=["C0_blind"]))
    assert result["task_success"] == 1
    return out


@pytest.fixture
def run_copy(played_run: Path, tmp_path: Path) -> Path:
    """A private copy of the played run, free to change."""
    return Path(shutil.copytree(played_run, tmp_path / "played"))

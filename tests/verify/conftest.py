"""Real run folders for the verifier's tests, made once per session by `cocobench run`, and
helpers that tamper with a copy of one."""

from __future__ import annotations

import gzip
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main

#: A centralized and a decentralized condition (rounds, messages), on the demo suite.
CONDITIONS = "C0_blind,D1_blind"


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """greedy over the demo suite (4 instances) × `CONDITIONS`, 10 steps at most: 8
    episodes. Read-only: tests tamper with a copy (`copy_run`)."""
    out = tmp_path_factory.mktemp("verify") / "demo"
    assert main(["run", "--suite", "demo", "--model", "greedy", "--conditions", CONDITIONS,
                 "--max-steps", "10", "--out", str(out)]) == 0
    return out


@pytest.fixture
def copy_run(demo_run: Path, tmp_path: Path) -> Callable[[], Path]:
    def copy() -> Path:
        target = tmp_path / f"run{len(list(tmp_path.iterdir()))}"
        shutil.copytree(demo_run, target)
        return target
    return copy


def lines(run: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (run / "results.jsonl").read_text().splitlines()]


def write_lines(run: Path, rows: list[dict[str, Any]]) -> None:
    (run / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def episode_line(run: Path, condition: str = "C0_blind",
                 task_prefix: str = "K_D3") -> dict[str, Any]:
    return next(r for r in lines(run) if r["condition"] == condition
                and r["task_id"].startswith(task_prefix))


def trajectory(run: Path, line: dict[str, Any]) -> dict[str, Any]:
    return json.loads((run / line["trajectory"]).read_text())


def write_trajectory(run: Path, line: dict[str, Any], document: dict[str, Any]) -> None:
    (run / line["trajectory"]).write_text(json.dumps(document, indent=2))


def prompts(run: Path, line: dict[str, Any]) -> dict[str, str]:
    path = (run / line["trajectory"]).parent / "prompts.json.gz"
    return json.loads(gzip.decompress(path.read_bytes()))


@pytest.fixture(scope="session")
def many_episodes_bundle(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A bundle of 128 episodes (greedy, the demo suite × `CONDITIONS` × 16 epochs): as many
    as `verify` replays in parallel processes."""
    home = tmp_path_factory.mktemp("many")
    assert main(["run", "--suite", "demo", "--model", "greedy", "--conditions", CONDITIONS,
                 "--epochs", "16", "--max-steps", "10", "--out", str(home / "run")]) == 0
    assert main(["submit", "pack", str(home / "run"), "--out",
                 str(home / "many.cocobench.tar.gz")]) == 0
    return home / "many.cocobench.tar.gz"

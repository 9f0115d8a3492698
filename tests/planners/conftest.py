"""Shared fixtures of the planner tests."""

from __future__ import annotations

import asyncio
import json
import shutil
from pathlib import Path

import pytest

from benchmark_adapter.tasks import TaskConfig, load_tasks
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs.plugins import forget_user_planners
from cocobench_agents.models import ModelPool, ModelSettings


@pytest.fixture(scope="session")
def demo() -> dict[str, TaskConfig]:
    """The built-in demo instances by cell."""
    return {c.cell: c for c in load_tasks("demo")}


@pytest.fixture
def script(tmp_path: Path):
    """Write a scripted model's replies; return its model spec."""
    def write(replies: dict[str, list[str]] | list[str]) -> str:
        path = tmp_path / f"script{len(list(tmp_path.iterdir()))}.json"
        path.write_text(json.dumps(replies), encoding="utf-8")
        return f"scripted:{path}"
    return write


def run(spec: EpisodeSpec, pool: ModelPool | None = None):
    """Run one episode synchronously; return (trajectory, result)."""
    return asyncio.run(run_episode(spec, pool or ModelPool(ModelSettings())))


@pytest.fixture
def fresh_planners():
    """Each CLI call of a real user is a new process: nothing loaded stays between tests."""
    forget_user_planners()
    yield
    forget_user_planners()


@pytest.fixture
def strategy(tmp_path: Path) -> Path:
    """The fixture planners (user_planner.py), copied where the researcher keeps them."""
    path = tmp_path / "lab" / "mine.py"
    path.parent.mkdir()
    shutil.copy(Path(__file__).with_name("user_planner.py"), path)
    return path

"""Fixtures for the generator tests: the shipped suites and small, fast generations."""

from __future__ import annotations

import json
from typing import Any

import pytest

from benchmark_adapter.generator import TASK_TYPES, package_data_root, run_strata
from benchmark_adapter.generator.composition import TEAM_SIZES, Stratum, full_strata
from tests.paths import SHARED_TASKS

SHIPPED = package_data_root()
# The released configs live beside the repository: /work/shared/cocobench-data next to /work/main.
REAL_TASKS = SHARED_TASKS


def read_suite(name: str) -> list[dict[str, Any]]:
    """Every task config shipped in a suite folder (subset files left out)."""
    folder = SHIPPED / name
    if not folder.is_dir():
        pytest.skip(f"suite {name} is not generated in {SHIPPED}")
    return [
        json.loads(p.read_text(encoding="utf-8"))
        for p in sorted(folder.glob("*_D*/*.json"))
    ]


def first_strata() -> list[Stratum]:
    """One instance per task type × team size: the first room of each (as in the full suite)."""
    seen, strata = set(), []
    for s in full_strata():
        if (s.task_type, s.agents) not in seen:
            seen.add((s.task_type, s.agents))
            strata.append(Stratum(s.task_type, s.agents, s.room, 1))
    assert len(strata) == len(TASK_TYPES) * len(TEAM_SIZES)
    return strata


@pytest.fixture(scope="session")
def sample_configs() -> dict[tuple[str, int], dict[str, Any]]:
    """The first kept config of every task type × team size, generated afresh."""
    results = run_strata(first_strata(), jobs=1)
    return {(r.stratum.task_type, r.stratum.agents): r.kept[0] for r in results}


@pytest.fixture(scope="session")
def shipped_full() -> list[dict[str, Any]]:
    return read_suite("cocobench-full")


@pytest.fixture(scope="session")
def shipped_240() -> list[dict[str, Any]]:
    return read_suite("cocobench-240")

"""The shipped suites: the paper's composition, the stratified subset, byte-identical
regeneration, and the `cocobench generate` command (on a small slice)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from benchmark_adapter.generator import TASK_TYPES, run_strata
from benchmark_adapter.generator.composition import (
    FULL_COMPOSITION,
    TEAM_SIZES,
    Stratum,
    full_strata,
    subset_quota,
)
from benchmark_adapter.generator.jsonfmt import dumps
from benchmark_adapter.generator.rooms import ROOMS
from benchmark_adapter.generator.suites import SUBSET_FILE, config_path
from benchmark_adapter.tasks import load_tasks, select_tasks
from cocobench_agents.cli import generate_cmd

from .conftest import SHIPPED, first_strata

Configs = list[dict[str, Any]]
PAPER_DIMS = {"D1": 218, "D2": 225, "D3": 230, "D4": 224}
PAPER_TEAMS = {2: 415, 3: 288, 4: 194}


def _template(config: dict[str, Any]) -> str:
    return config["provenance"]["template"]


def test_the_composition_table_is_the_papers() -> None:
    dims, teams = Counter(), Counter()
    for slug, counts in FULL_COMPOSITION.items():
        dims[TASK_TYPES[slug].dim] += sum(counts)
        for agents, count in zip(TEAM_SIZES, counts):
            teams[agents] += count
            assert count > 0
    assert dims == PAPER_DIMS and teams == PAPER_TEAMS
    assert sum(s.count for s in full_strata()) == 897
    assert subset_quota({"a": 13, "b": 67, "c": 46}) == {"a": 3, "b": 10, "c": 7}


def test_shipped_full_suite_has_the_papers_composition(shipped_full: Configs) -> None:
    assert len(shipped_full) == 897
    assert Counter(c["coordination_dim"] for c in shipped_full) == PAPER_DIMS
    assert Counter(c["agent_count"] for c in shipped_full) == PAPER_TEAMS
    by_type = Counter((_template(c), c["agent_count"]) for c in shipped_full)
    assert by_type == {
        (slug, n): count
        for slug, counts in FULL_COMPOSITION.items()
        for n, count in zip(TEAM_SIZES, counts)
    }
    assert {c["provenance"]["room"] for c in shipped_full} == set(ROOMS)
    assert len({c["task_id"] for c in shipped_full}) == 897


def test_shipped_subset_is_stratified(shipped_full: Configs, shipped_240: Configs) -> None:
    assert len(shipped_240) == 240
    strata = Counter((c["coordination_dim"], c["agent_count"]) for c in shipped_240)
    assert set(strata.values()) == {20} and len(strata) == 12
    pairs = {(_template(c), c["agent_count"]) for c in shipped_240}
    assert len(pairs) == len(TASK_TYPES) * len(TEAM_SIZES)
    full = {c["task_id"]: c for c in shipped_full}
    assert all(full[c["task_id"]] == c for c in shipped_240)
    subset = json.loads((SHIPPED / "cocobench-full" / SUBSET_FILE).read_text())
    assert subset["task_ids"] == [c["task_id"] for c in shipped_240]
    assert subset["stats"]["by_dim"] == {"D1": 60, "D2": 60, "D3": 60, "D4": 60}


def test_suites_load_by_name_and_subset_file() -> None:
    subset_file = SHIPPED / "cocobench-full" / SUBSET_FILE
    if not subset_file.is_file():
        pytest.skip("suites not generated")
    tasks = load_tasks("cocobench-240")
    assert len(tasks) == 240
    assert [t.task_id for t in load_tasks(subset_file)] == [t.task_id for t in tasks]
    chosen = select_tasks(tasks, "cocobench-240", index=subset_file)
    assert len(chosen) == 240


def test_a_slice_regenerates_byte_for_byte(sample_configs: dict) -> None:
    """The first instance of every task type × team size, generated afresh, is the shipped
    file, byte for byte (streams are deterministic, so a prefix of a stratum is too)."""
    for config in sample_configs.values():
        path = SHIPPED / "cocobench-full" / config_path(config)
        if not path.is_file():
            pytest.skip(f"{path} not generated")
        assert path.read_bytes() == dumps(config).encode("utf-8"), path.name


def test_worker_processes_give_the_same_instances() -> None:
    strata = [Stratum("fill_drawers_in_order", 4, "bathroom", 3)]
    serial, parallel = run_strata(strata, jobs=1), run_strata(strata, jobs=2)
    assert serial[0].kept == parallel[0].kept
    assert serial[0].verdicts == parallel[0].verdicts


def test_generate_command_writes_and_checks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    strata = first_strata()[:4]
    monkeypatch.setattr(generate_cmd, "generate",
                        lambda jobs, backend: run_strata(strata, jobs, backend))
    runner = CliRunner()
    written = runner.invoke(generate_cmd.generate_command, ["--out", str(tmp_path)])
    assert written.exit_code == 0, written.output
    assert "Store Groceries" in written.output and "placement" in written.output
    files = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.json"))
    assert f"cocobench-full/{SUBSET_FILE}" in files
    assert len([f for f in files if f.startswith("cocobench-full/A_D1/")]) == 3

    check = ["--out", str(tmp_path), "--check"]
    assert runner.invoke(generate_cmd.generate_command, check).exit_code == 0
    victim = tmp_path / files[0]
    victim.write_bytes(victim.read_bytes() + b" ")
    (tmp_path / "cocobench-240" / "stray.json").write_text("{}")
    failed = runner.invoke(generate_cmd.generate_command, check)
    assert failed.exit_code == 1
    assert f"{files[0]}: differs" in failed.output
    assert "cocobench-240/stray.json: not generated" in failed.output

"""One instance per task type × team size: it passes the gates and looks like a released config."""

from __future__ import annotations

import json
from typing import Any

import pytest

from benchmark_adapter.generator import TASK_TYPES, judge
from benchmark_adapter.generator.budgets import BUDGET_RATIO
from benchmark_adapter.generator.composition import TEAM_SIZES
from benchmark_adapter.generator.oracles import oracle_stats
from benchmark_adapter.tasks import TaskConfig

from .conftest import REAL_TASKS

Samples = dict[tuple[str, int], dict[str, Any]]
CASES = [(slug, n) for slug in TASK_TYPES for n in TEAM_SIZES]


def _real_configs() -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted(REAL_TASKS.glob("*.json"))]


@pytest.mark.parametrize(("slug", "agents"), CASES)
def test_every_task_type_and_team_size_passes_the_gates(
    sample_configs: Samples, slug: str, agents: int
) -> None:
    config = sample_configs[slug, agents]
    assert judge(config).passed
    task_type = TASK_TYPES[slug]
    assert config["agent_count"] == agents == len(config["agents"])
    assert (config["task_family"], config["coordination_dim"]) == (task_type.family, task_type.dim)
    assert config["scene_id"].startswith("Emb")
    provenance = config["provenance"]
    assert provenance["template"] == slug and provenance["scene"] == config["scene_id"]
    assert provenance["seed"] == config["seed"] and provenance["generator_version"]
    assert provenance["instruction"].endswith(".")


@pytest.mark.skipif(not REAL_TASKS.is_dir(), reason=f"released configs not found at {REAL_TASKS}")
def test_fields_and_budgets_match_the_released_configs(sample_configs: Samples) -> None:
    real = _real_configs()
    for (slug, _), config in sample_configs.items():
        cell = TASK_TYPES[slug].cell
        same_cell = [r for r in real if f"{r['task_family']}_{r['coordination_dim']}" == cell]
        fields = {frozenset(r) for r in same_cell if "provenance" in r}
        assert frozenset(config) in fields, f"{slug}: top-level fields differ from {cell}"
        steps, budget = config["difficulty"]["oracle_steps"], config["difficulty"]["step_budget"]
        ratios = [
            r["difficulty"]["step_budget"] / r["difficulty"]["oracle_steps"] for r in same_cell
        ]
        assert min(ratios) * steps - 1 <= budget <= max(ratios) * steps + 1
        assert budget >= steps and BUDGET_RATIO[cell] >= 1


def test_d1_makespan_is_the_oracle_busiest_agent(sample_configs: Samples) -> None:
    for (slug, agents), config in sample_configs.items():
        if TASK_TYPES[slug].dim != "D1":
            continue
        stats = oracle_stats(TaskConfig.model_validate(config))
        assert config["task_constraints"]["optimal_makespan"] == stats.makespan
        expected = {"store_groceries": 7, "sort_and_store": 4, "tidy_drawers": 6}[slug]
        assert stats.makespan == expected, (slug, agents)


def test_d3_assignment_and_top_level_makespan(sample_configs: Samples) -> None:
    for agents in TEAM_SIZES:
        config = sample_configs["prepare_food", agents]
        assignment = config["assignment"]
        assert sorted(set(assignment.values())) == [f"agent_{i}" for i in range(1, agents + 1)]
        per_agent = [list(assignment.values()).count(a) for a in set(assignment.values())]
        assert config["optimal_makespan"] == sum(7 + 2 * k for k in per_agent)
        assert config["step_budget"] == 2 * config["optimal_makespan"]
        knife = config["init_state"]["objects"]["knife"]
        assert config["task_constraints"]["resource_exclusion"][0]["resource_id"] == knife


def test_d4_roles_buffers_and_capacities(sample_configs: Samples) -> None:
    for slug in ("relay_items", "indirect_relay", "cross_zone_handoff"):
        for agents in TEAM_SIZES:
            config = sample_configs[slug, agents]
            constraints = config["task_constraints"]
            pc = constraints["producer_consumer"]
            ids = [a["id"] for a in config["agents"]]
            if agents == 2:
                assert (pc["producer"], pc["consumer"]) == ("agent_1", "agent_2")
            else:
                assert pc["producers"] == ids[: agents // 2]
                assert pc["consumers"] == ids[agents // 2 :]
            assert constraints["buffer_stations"] == [{"objectId": pc["buffer"], "capacity": 1}]
            assert len(config["goal_predicates"]) == max(3, agents)


def test_asymmetric_prepare_food_exists_in_the_shipped_suite(shipped_full: list) -> None:
    k = [c for c in shipped_full if c["provenance"]["template"] == "prepare_food"]
    asymmetric = [c for c in k if c["provenance"]["asymmetric"]]
    assert asymmetric and len(asymmetric) < len(k)
    for config in asymmetric[:5]:
        owners = list(config["assignment"].values())
        assert len(owners) == config["agent_count"] + 1

"""The oracle registration hook and the Store Groceries plan."""

from __future__ import annotations

from typing import Any

import pytest

from benchmark_adapter.generator.oracles import oracle_stats, plan_store_groceries
from benchmark_adapter.oracles import NoOraclePlan, oracle_plan, register_plan
from benchmark_adapter.oracles.plans import plan_a_d1
from benchmark_adapter.tasks import TaskConfig


def test_two_agent_store_groceries_is_the_released_a_d1_plan(sample_configs: Any) -> None:
    data = sample_configs["store_groceries", 2]
    objects = data["init_state"]["objects"]
    # The released plan reads `potato`/`lettuce`; alias the same objects under those names.
    aliased = {**objects, "potato": objects["food_1"], "lettuce": objects["food_2"]}
    config = TaskConfig.model_validate({**data, "init_state": {**data["init_state"],
                                                               "objects": aliased}})
    assert list(plan_store_groceries(config)) == list(plan_a_d1(config))


def test_store_groceries_scales_with_the_team(sample_configs: Any) -> None:
    config = TaskConfig.model_validate(sample_configs["store_groceries", 4])
    stats = oracle_stats(config)
    assert (stats.name, stats.calls, stats.makespan) == ("store_groceries", 7 + 6 + 4 + 4, 7)


def test_configs_name_their_plan_and_unknown_names_fail_clearly(sample_configs: Any) -> None:
    data = sample_configs["sort_and_store", 2]
    assert data["provenance"]["oracle"] == "G_D1"
    broken = TaskConfig.model_validate({**data, "provenance": {"oracle": "no_such_plan"}})
    with pytest.raises(NoOraclePlan, match="'no_such_plan'"):
        oracle_plan(broken)


def test_released_plans_cannot_be_replaced() -> None:
    with pytest.raises(ValueError, match="released cell plan"):
        register_plan("A_D1", plan_store_groceries)
    register_plan("store_groceries", plan_store_groceries)  # same function again: harmless
    with pytest.raises(ValueError, match="already registered"):
        register_plan("store_groceries", plan_a_d1)

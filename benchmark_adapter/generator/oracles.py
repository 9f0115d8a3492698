"""Oracle plans for task types the released cell plans do not cover, and oracle statistics.

The released A_D1 plan is written for exactly two agents and the aliases `potato`/`lettuce`.
Store Groceries instances of every team size use `plan_store_groceries`, registered under the
name `store_groceries` (configs name it in `provenance.oracle`). Every other task type runs its
cell's released plan unchanged.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from benchmark_adapter.oracles.plans import Plan, call, numbered
from benchmark_adapter.oracles.registry import plan_function, plan_name, register_plan
from benchmark_adapter.skills.calls import parse_call
from benchmark_adapter.tasks.config import TaskConfig


def plan_store_groceries(config: TaskConfig) -> Plan:
    """agent_1 opens the fridge, stores food_1 and steps back (7 steps); agent_2 switches the
    light off and stores food_2 (6); agent_k (k ≥ 3) stores food_k (4). For two agents this
    is the released A_D1 plan over `food_1`/`food_2`. The fridge is left open: a loaded fridge
    cannot be closed (reference §10.2)."""
    o = config.resolve
    agents, foods = config.agent_ids, numbered(config, "food")
    fridge = o("fridge")

    def store(agent: str, food: str) -> list[str]:
        return [
            call("Find", agent, o(food)),
            call("PickUp", agent, o(food)),
            call("Find", agent, fridge),
            call("Put", agent, fridge),
        ]

    calls = [
        call("Find", agents[0], fridge),
        call("Open", agents[0], fridge),
        *store(agents[0], foods[0]),
        call("Explore", agents[0], "back"),  # make room at the fridge for the next agent
        call("Find", agents[1], o("light")),
        call("ToggleOff", agents[1], o("light")),
    ]
    for agent, food in zip(agents[1:], foods[1:]):
        calls += store(agent, food)
    # One call at a time: the runner `send`s each result back, which a list iterator (and so
    # `yield from` a list) would refuse.
    for c in calls:  # noqa: UP028
        yield c


register_plan("store_groceries", plan_store_groceries)


@dataclass(frozen=True)
class OracleStats:
    """Length of a config's oracle plan: calls in all, and the busiest agent's calls."""

    name: str
    calls: int
    makespan: int


def oracle_stats(config: TaskConfig) -> OracleStats:
    """Count the calls of the config's oracle plan without running it (plans are open-loop)."""
    plan = plan_function(config)
    if plan is None:
        raise LookupError(f"{config.task_id}: no oracle plan named {plan_name(config)!r}")
    per_agent = Counter(parse_call(c).agent for c in plan(config))
    return OracleStats(plan_name(config), sum(per_agent.values()), max(per_agent.values()))

"""Privileged reference plans, run through the same `Episode` as any planner."""

from benchmark_adapter.oracles.plans import ORACLE_PLANS, Plan
from benchmark_adapter.oracles.registry import register_plan, registered_plans
from benchmark_adapter.oracles.runner import NoOraclePlan, oracle_plan, run_oracle

__all__ = [
    "ORACLE_PLANS",
    "NoOraclePlan",
    "Plan",
    "oracle_plan",
    "register_plan",
    "registered_plans",
    "run_oracle",
]

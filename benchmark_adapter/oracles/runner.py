"""Run an oracle plan through an `Episode`, exactly as a planner would."""

from __future__ import annotations

from typing import Any

from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles.plans import Plan
from benchmark_adapter.oracles.registry import plan_function, plan_name, registered_plans
from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.tasks.config import TaskConfig

VALIDATION_MAX_STEPS = 200  # the reference's validator budget


class NoOraclePlan(LookupError):
    """No oracle plan goes by the config's `provenance.oracle` name or its cell."""


def oracle_plan(config: TaskConfig) -> Plan:
    """The reference plan for the config: the one `provenance.oracle` names, else its cell's."""
    plan = plan_function(config)
    if plan is None:
        name = plan_name(config)
        what = f"cell {name}" if name == config.cell else f"{name!r} (provenance.oracle)"
        raise NoOraclePlan(
            f"{config.task_id}: no oracle plan for {what} "
            f"(known: {', '.join(sorted(registered_plans()))})"
        )
    return plan(config)


def run_oracle(
    config: TaskConfig,
    controller: Controller | None = None,
    max_steps: int = VALIDATION_MAX_STEPS,
    frames: bool = False,
) -> dict[str, Any]:
    """Run the config's oracle plan; return the trajectory document."""
    episode = Episode(config, controller, frames=frames)
    episode.reset()
    plan = oracle_plan(config)
    reason = "done"
    try:
        next_call = next(plan)
        while True:
            if episode.step_index >= max_steps:
                reason = "max_steps"
                break
            result = episode.step(next_call)
            next_call = plan.send(result)
    except StopIteration:
        pass
    episode.stop(
        {
            "policy": "oracle",
            "backend": episode.backend,
            "model": None,
            "step_index": episode.step_index,
            "status": reason,
            "terminal_reason": reason,
        }
    )
    return episode.finish()

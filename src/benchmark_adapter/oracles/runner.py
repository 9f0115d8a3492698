"""Run an oracle plan through an `Episode`, exactly as a planner would."""

from __future__ import annotations

from typing import Any

from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles.plans import ORACLE_PLANS, Plan
from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.tasks.config import TaskConfig

VALIDATION_MAX_STEPS = 200  # the reference's validator budget


class NoOraclePlan(LookupError):
    """The config's cell has no oracle plan."""


def oracle_plan(config: TaskConfig) -> Plan:
    """The reference plan for the config's cell."""
    plan = ORACLE_PLANS.get(config.cell)
    if plan is None:
        raise NoOraclePlan(
            f"{config.task_id}: no oracle plan for cell {config.cell} "
            f"(known: {', '.join(sorted(ORACLE_PLANS))})"
        )
    return plan(config)


def run_oracle(
    config: TaskConfig,
    controller: Controller | None = None,
    max_steps: int = VALIDATION_MAX_STEPS,
    frames: bool = False,
) -> dict[str, Any]:
    """Run the cell's oracle; return the trajectory document."""
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

"""What the planner's model calls cost: from the trajectory's `planner_decisions` list.

`planner_decisions` is written by this framework (every decision, including those of agents
that idled in a round, which the reference's step-attached decisions miss); trajectories
without it have no usage block. A reused reply (``cached`` or ``replayed``: no model call was
made) costs nothing; what its original call cost is counted as saved.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .failures import PROTOCOL_STATUSES


@dataclass(frozen=True)
class ModelUsage:
    """Totals over an episode's model calls."""

    model_calls: int
    prompt_tokens: int
    completion_tokens: int
    cost_usd: float
    model_latency_s: float
    retries: int
    parse_errors: int  # every protocol failure, idle agents' included
    backend_errors: int
    reused_calls: int = 0  # answered from the response cache or a recorded run
    saved_cost_usd: float = 0.0  # what those calls had cost when the model made them


def model_usage(traj: Mapping[str, Any]) -> ModelUsage | None:
    """Sum tokens, cost, latency and failures over `planner_decisions` (None if absent)."""
    decisions = traj.get("planner_decisions")
    if not isinstance(decisions, list):
        return None
    calls = [d for d in decisions if isinstance(d, Mapping) and "prompt_hash" in d]
    reused = [d for d in calls if _reused(d)]
    billed = [d for d in calls if not _reused(d)]
    return ModelUsage(
        model_calls=len(calls),
        prompt_tokens=sum(int(d.get("prompt_tokens") or 0) for d in billed),
        completion_tokens=sum(int(d.get("completion_tokens") or 0) for d in billed),
        cost_usd=round(sum(float(d.get("cost_usd") or 0.0) for d in billed), 6),
        model_latency_s=round(sum(float(d.get("latency_s") or 0.0) for d in billed), 4),
        retries=sum(int(d.get("retries") or 0) for d in billed),
        parse_errors=sum(d.get("status") in PROTOCOL_STATUSES for d in calls),
        backend_errors=sum(d.get("status") == "backend_error" for d in calls),
        reused_calls=len(reused),
        saved_cost_usd=round(sum(float(_saved(d).get("cost_usd") or 0.0) for d in reused), 6),
    )


def _reused(decision: Mapping[str, Any]) -> bool:
    return bool(decision.get("cached") or decision.get("replayed"))


def _saved(decision: Mapping[str, Any]) -> Mapping[str, Any]:
    # Records written before reused replies were billed 0 kept the original figures in place.
    saved = decision.get("saved")
    return saved if isinstance(saved, Mapping) else decision

"""The scorer: the episode's trajectory scored by the benchmark (`score_trajectory`, as
`cocobench score` does), reported as named scores with Inspect's mean and bootstrap standard
error. A value the episode has none of (the construct score of an unscored episode, the
legality of an episode that landed no step, progress of a task without one) is NaN, which
Inspect leaves out of that score's metrics: an unscored episode is not a zero, as in our
reports."""

from __future__ import annotations

import math
from typing import Any

from inspect_ai.scorer import Score, Target, bootstrap_stderr, mean, scorer
from inspect_ai.solver import TaskState

from benchmark_adapter.metrics import score_trajectory
from benchmark_adapter.vocabulary import DIMENSIONS

from .solver import RESULT, TRAJECTORY

#: The named scores: ours → the result line's field.
SCORES = {"success": "task_success", "construct_score": "construct_score",
          "legal_plan": "legal_plan", "progress": "task_progress", "steps": "num_steps"}
#: Each dimension's construct score, ``cs_D1`` … (NaN where the episode has none).
DIMENSION_SCORES = tuple(f"cs_{dim}" for dim in DIMENSIONS)
#: 1 where the planner's own code ended the episode (a node raised, returned a malformed
#: record, or never ended), else 0: its mean is the share of such episodes, counted apart
#: from the model's failures (in the scores) and the infrastructure's (Inspect's errors).
PLANNER_ERROR = "planner_error"
_METRICS = [mean(), bootstrap_stderr()]


@scorer(metrics={name: _METRICS for name in (*SCORES, *DIMENSION_SCORES, PLANNER_ERROR)})
def cocobench_scorer() -> Any:
    """Score the sample's trajectory."""

    async def score(state: TaskState, target: Target) -> Score:
        document = state.store.get(TRAJECTORY)
        if document is None:
            return Score.unscored(reason="no trajectory",
                                  explanation="the episode left no trajectory")
        line = state.store.get(RESULT) or {}
        if line.get("planner_error"):  # the strategy's code ended it: a failure, told apart
            return Score(value=score_values(line), answer=state.output.completion,
                         explanation=line["planner_error"],
                         metadata={"terminal_reason": PLANNER_ERROR,
                                   PLANNER_ERROR: line["planner_error"]})
        result = score_trajectory(document, **_identifiers(line)).model_dump(mode="json")
        return Score(value=score_values(result), answer=state.output.completion,
                     explanation=_explanation(result),
                     metadata={"terminal_reason": result["terminal_reason"],
                               "construct_status": result["construct_status"],
                               "checks": result["checks"]})

    return score


def findable_by_its_logged_name() -> None:
    """Register the scorer also under the name Inspect's log records for it.

    A log names a scorer without its package (``cocobench_scorer``), and ``inspect score
    LOG`` looks that name up as it stands, where a package's scorer is registered under
    ``cocobench_agents/cocobench_scorer``: without this, Inspect asks for ``--scorer``.
    ``inspect score`` loads the packages' entry points (this package among them) before it
    looks the name up."""
    from inspect_ai._util.registry import _registry, registry_key

    _registry.setdefault(registry_key("scorer", cocobench_scorer.__name__), cocobench_scorer)


def score_values(line: dict[str, Any]) -> dict[str, float]:
    """A result line's named scores (NaN for a value it has none of)."""
    values = {name: _number(line.get(field)) for name, field in SCORES.items()}
    blocks = line.get("cross_construct") or {}
    for name, dim in zip(DIMENSION_SCORES, DIMENSIONS, strict=True):
        values[name] = _number((blocks.get(dim) or {}).get("score"))
    values[PLANNER_ERROR] = float(bool(line.get(PLANNER_ERROR)))
    return values


def _identifiers(line: dict[str, Any]) -> dict[str, Any]:
    return {k: line[k] for k in ("backend", "models", "planner", "obs_mode", "prompt_suite")
            if line.get(k) is not None}


def _number(value: Any) -> float:
    return math.nan if value is None else float(value)


def _explanation(line: dict[str, Any]) -> str:
    return (f"{line.get('terminal_reason')}: checks {line.get('checks')}, construct "
            f"{line.get('construct_status')}")

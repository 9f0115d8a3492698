"""Instance quality gates: placement, oracle (success with a legal plan) and metric.

An instance passes when its init actions all succeed, its oracle reaches the goal with a legal
plan, and the oracle's construct score on the instance's own dimension is at least 0.95
(the paper's "near-ceiling" metric gate).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from typing import Any

from benchmark_adapter.metrics import score_trajectory
from benchmark_adapter.metrics.steps import NOOP_MARKERS, has_marker
from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.oracles.runner import VALIDATION_MAX_STEPS
from benchmark_adapter.sim.backends import make_controller
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import DEFAULT_BACKEND, EMBEDDED

METRIC_GATE = 0.95
# Construct statuses that may pass the metric gate without a score, and why. Empty: every
# released cell's oracle produces enough evidence to be scored.
NA_EXEMPTIONS: dict[str, str] = {}


@dataclass(frozen=True)
class ValidationRow:
    """One instance's verdict."""

    task_id: str
    cell: str
    agents: int
    steps: int
    success: bool
    legal_plan: bool | None
    construct_score: float | None
    construct_status: str
    passed: bool
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def validate_task(config: TaskConfig, max_steps: int = VALIDATION_MAX_STEPS,
                  backend: str = DEFAULT_BACKEND) -> ValidationRow:
    """Run the oracle of one instance on `backend` and apply the three gates."""
    try:
        controller = None if backend == EMBEDDED else make_controller(config, backend)
        trajectory = run_oracle(config, controller, max_steps=max_steps)
        result = score_trajectory(trajectory)
    except Exception as exc:  # noqa: BLE001 - a broken instance is a failed row, not a crash
        return ValidationRow(
            task_id=config.task_id,
            cell=config.cell,
            agents=config.agent_count,
            steps=0,
            success=False,
            legal_plan=None,
            construct_score=None,
            construct_status="error",
            passed=False,
            reason=f"error: {exc}",
        )
    reason = _failure_reason(trajectory, result)
    return ValidationRow(
        task_id=config.task_id,
        cell=config.cell,
        agents=config.agent_count,
        steps=result.num_steps,
        success=bool(result.task_success),
        legal_plan=None if result.legal_plan is None else bool(result.legal_plan),
        construct_score=result.construct_score,
        construct_status=result.construct_status,
        passed=not reason,
        reason=reason,
    )


def _failure_reason(trajectory: dict[str, Any], result: Any) -> str:
    # An init action that found its state already in place (a closed drawer closed again)
    # is a no-op, not a placement failure.
    failed_init = [
        t
        for t in trajectory["init_trace"]
        if not t["lastActionSuccess"] and not has_marker(t["errorMessage"], NOOP_MARKERS)
    ]
    if failed_init:
        first = failed_init[0]
        return f"placement: {first['action'].get('action')} failed ({first['errorMessage']})"
    if not result.task_success:
        return f"oracle: goal not reached ({result.checks} checks)"
    if not result.legal_plan:
        return "oracle: plan not legal"
    status, score = result.construct_status, result.construct_score
    if status != "scored":
        return "" if status in NA_EXEMPTIONS else f"metric: construct score NA ({status})"
    if score < METRIC_GATE:
        return f"metric: construct score {score:.2f} < {METRIC_GATE}"
    return ""


def validate_tasks(configs: Iterable[TaskConfig], jobs: int = 1, backend: str = DEFAULT_BACKEND
                   ) -> Iterator[ValidationRow]:
    """Validate instances, `jobs` processes at a time; rows come back in input order."""
    configs = list(configs)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(configs) or 1))
    check = functools.partial(validate_task, backend=backend)
    if jobs == 1:
        yield from map(check, configs)
        return
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        yield from pool.map(check, configs, chunksize=max(1, len(configs) // (jobs * 8)))

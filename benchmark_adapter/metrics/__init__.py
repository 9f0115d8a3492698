"""CoCoBench metrics as pure functions over a recorded trajectory dict.

The input is a ``trajectory.json`` in the reference format (``task_id``,
``task_config``, ``init_trace``, ``final_eval``, ``trajectory``); see
``docs/metrics.md`` for each formula and where the reference is followed.
"""

from .constructs import (
    DIMENSIONS,
    MIN_SAMPLE,
    STATUSES,
    ConstructEvidence,
    ConstructScore,
    construct_evidence,
    construct_score,
    cross_construct_scores,
)
from .errors import TrajectoryError
from .failures import (
    FAILURE_KINDS,
    PlannerStats,
    failure_kind,
    planner_stats,
    policy_decisions,
    terminal_reason,
)
from .general import (
    CommVolume,
    DistributedMetrics,
    GeneralMetrics,
    checks_summary,
    d2_legality_gate,
    distributed_metrics,
    final_eval,
    general_metrics,
    goal_success,
    legal_plan,
    subgoal_success_rate,
)
from .result import EpisodeResult, score_trajectory, unrun_result
from .steps import (
    INTERACTION_SKILLS,
    STEP_CATEGORIES,
    Step,
    allowed_skills_by_agent,
    classify_step,
    classify_steps,
    extract_steps,
    step_taxonomy,
)
from .usage import ModelUsage, model_usage

__all__ = [
    "DIMENSIONS",
    "FAILURE_KINDS",
    "INTERACTION_SKILLS",
    "MIN_SAMPLE",
    "STATUSES",
    "STEP_CATEGORIES",
    "CommVolume",
    "ConstructEvidence",
    "ConstructScore",
    "DistributedMetrics",
    "EpisodeResult",
    "GeneralMetrics",
    "ModelUsage",
    "PlannerStats",
    "Step",
    "TrajectoryError",
    "allowed_skills_by_agent",
    "checks_summary",
    "classify_step",
    "classify_steps",
    "construct_evidence",
    "construct_score",
    "cross_construct_scores",
    "d2_legality_gate",
    "distributed_metrics",
    "extract_steps",
    "failure_kind",
    "final_eval",
    "general_metrics",
    "goal_success",
    "legal_plan",
    "model_usage",
    "planner_stats",
    "policy_decisions",
    "score_trajectory",
    "step_taxonomy",
    "subgoal_success_rate",
    "terminal_reason",
    "unrun_result",
]

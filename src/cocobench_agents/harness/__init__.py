"""Batch runs: suite × conditions × models × epochs into a resumable run folder."""

from cocobench_agents.harness.execute import execute, infra_error_record, run_one
from cocobench_agents.harness.plan import (
    Condition,
    EpisodeKey,
    PlanError,
    PlannedEpisode,
    RunOptions,
    parse_conditions,
    plan_episodes,
)
from cocobench_agents.harness.progress import Progress, episode_line
from cocobench_agents.harness.record import pending_episodes, run_record
from cocobench_agents.harness.store import RunFolder, RunFolderError

__all__ = [
    "Condition", "EpisodeKey", "PlanError", "PlannedEpisode", "Progress", "RunFolder",
    "RunFolderError", "RunOptions", "episode_line", "execute", "infra_error_record",
    "parse_conditions", "pending_episodes", "plan_episodes", "run_one", "run_record",
]

"""Every shared config runs under C0, D0 and D1, in both views, with the greedy and random
built-ins: no crash and a valid, scorable trajectory each."""

from __future__ import annotations

import json

import pytest

from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.trajectory import dumps
from cocobench_agents.episode_runner import EpisodeSpec
from tests.paths import SHARED_TASKS

from .conftest import run

CONFIGS = load_tasks(SHARED_TASKS) if SHARED_TASKS.exists() else []
PLANNERS = ("centralized", "decentralized", "decentralized-broadcast")
pytestmark = pytest.mark.slow  # 36 configs × 12 episodes: about 2 s a config


@pytest.mark.skipif(not CONFIGS, reason=f"shared configs not found at {SHARED_TASKS}")
@pytest.mark.parametrize("config", CONFIGS, ids=lambda c: c.task_id)
def test_every_condition_gives_a_valid_trajectory(config):
    for planner in PLANNERS:
        for obs_mode in ("image", "blind"):
            for model in ("greedy", "random"):
                spec = EpisodeSpec(config, planner=planner, obs_mode=obs_mode,
                                   models={"*": model})
                document, result = run(spec)
                landed = [i for i in document["trajectory"] if "skill_result" in i]
                assert len(landed) <= config.budget
                assert result.terminal_reason in ("max_steps", "done", "all_idle",
                                                  "no_actions", "parse_error")
                assert document["trajectory"][-1]["label"] == "policy_stop"
                assert json.loads(dumps(document))["task_id"] == config.task_id

"""An environment over many instances keeps a bounded number of them built: each holds its
world (about 0.8 MB), so keeping every instance it had played grew a cocobench-full
environment past 1 GB (`python bench/env.py --episodes 10000` prints the resident memory)."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.needs_env


def test_an_environment_keeps_its_most_recent_instances_only():
    from cocobench_agents.envs import parallel_env
    from cocobench_agents.envs.parallel import KEPT_EPISODES

    environment = parallel_env("cocobench-240", condition="C0_blind", text=False)
    ids = [config.task_id for config in environment.configs][:KEPT_EPISODES + 8]
    for task_id in ids:
        environment.reset(options={"task_id": task_id})
    assert list(environment._episodes) == ids[-KEPT_EPISODES:]
    again = environment._episodes[ids[-1]]
    environment.reset(options={"task_id": ids[-1]})  # a kept one is played again, not rebuilt
    assert environment.episode is again
    environment.reset(options={"task_id": ids[0]})  # a dropped one is built afresh
    assert list(environment._episodes)[-1] == ids[0] and len(environment._episodes) == \
        KEPT_EPISODES
    environment.close()

"""The environment is the benchmark: an episode played through it scores exactly as the same
replies score under `--model scripted:FILE` (every result field, times aside)."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.trajectory import PROMPTS_FIELD
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs import PLANNERS as BUILT_IN
from cocobench_agents.models import ModelPool
from tests.envs.play import done_after, illegal_first, oracle_policy, play, random_policy
from tests.paths import SHARED_TASKS

pytestmark = pytest.mark.needs_env

#: Every built-in planner that calls a model, and claim-board (an installed plugin).
PLANNERS = (*(name for name, spec in BUILT_IN.items() if spec.uses_models), "claim-board")
#: Times differ between any two runs; everything else must not.
TIMES = {"elapsed_s"}


def instances() -> list:
    """A dozen instances: real configs of the shared data and of the built-in suites."""
    shared = load_tasks(SHARED_TASKS)
    picked = [shared[i] for i in range(0, len(shared), max(1, len(shared) // 8))][:8]
    suite = load_tasks("cocobench-240")
    return [*picked, suite[0], suite[60], suite[120], load_tasks("demo")[0]]


POLICIES = {"oracle": lambda i: oracle_policy(), "random": random_policy,
            "illegal": illegal_first, "done_early": lambda i: done_after(2, i)}


def scored_both_ways(config, planner: str, policy_name: str, tmp_path, index: int):
    from cocobench_agents.envs import SeatedEpisode

    script = tmp_path / f"{config.task_id}-{Path(planner).name}-{policy_name}.json"
    spec = EpisodeSpec(config, planner=planner, models={"*": f"scripted:{script}"},
                       obs_mode="blind", max_steps=24)
    episode = SeatedEpisode(spec)
    replies = play(episode, POLICIES[policy_name](index))
    script.write_text(json.dumps(replies))
    document, result = asyncio.run(run_episode(spec, ModelPool()))
    # The prompts too: every decision's text, as the run kept it, is what the seat observed.
    assert episode.document[PROMPTS_FIELD] == document[PROMPTS_FIELD]
    assert _strip(episode.document["planner_decisions"]) == _strip(document["planner_decisions"])
    # The condition, as the harness names it in the result line (harness.batch).
    return episode.result, result.model_copy(update={"condition": episode.condition})


def differences(env_result, run_result) -> dict:
    a = env_result.model_dump(mode="json")
    b = run_result.model_dump(mode="json")
    return {k: (a.get(k), b.get(k)) for k in a.keys() | b.keys()
            if k not in TIMES and _strip(a.get(k)) != _strip(b.get(k))}


def _strip(value):
    """Latencies are times too: measured around each model call."""
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if "latency" not in k}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


@pytest.mark.slow
@pytest.mark.parametrize("planner", PLANNERS)
@pytest.mark.parametrize("policy_name", list(POLICIES))
def test_an_episode_scores_as_the_scripted_run_scores_it(planner, policy_name, tmp_path):
    results = []
    for index, config in enumerate(instances()):
        env_result, run_result = scored_both_ways(config, planner, policy_name, tmp_path, index)
        assert differences(env_result, run_result) == {}, config.task_id
        results.append(env_result)
    # The policies did what they are named for (else the equality would prove little).
    if policy_name == "oracle":
        assert sum(r.task_success for r in results) >= len(results) // 2
    if policy_name == "illegal":
        assert any(r.failed_steps for r in results)
    if policy_name == "done_early":
        assert all(r.num_steps < 2 + (r.agent_count or 4) for r in results)


def test_a_random_d1_episode_scores_as_its_scripted_run(tmp_path):
    config = load_tasks(SHARED_TASKS)[0]
    env_result, run_result = scored_both_ways(config, "decentralized-broadcast", "random",
                                              tmp_path, 0)
    assert differences(env_result, run_result) == {}
    assert env_result.planner == "decentralized-broadcast"


@pytest.mark.slow
@pytest.mark.parametrize("condition", ["C0_blind", "LW_blind"])
def test_the_result_line_of_cocobench_run_is_the_environments_last_info(condition, tmp_path):
    """Through the command itself: `cocobench run --model scripted:FILE` writes the result
    line the environment's last `info` holds (times and the run folder's own keys aside)."""
    import subprocess
    import sys

    from cocobench_agents.envs import parallel_env

    config = load_tasks(SHARED_TASKS)[3]
    script = tmp_path / "script.json"
    environment = parallel_env(str(SHARED_TASKS), condition=condition, task_id=config.task_id,
                               max_steps=12, model=f"scripted:{script}")
    environment.reset()
    replies = play(environment.episode, random_policy(7))
    info = environment.state_result.model_dump(mode="json")  # what the last info holds
    script.write_text(json.dumps(replies))
    out = tmp_path / "run"
    subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "run", "--task",
                    str(SHARED_TASKS / f"{config.task_id}.json"), "--model",
                    f"scripted:{script}", "--conditions", condition, "--max-steps", "12",
                    "--out", str(out)], check=True, capture_output=True)
    line = json.loads((out / "results.jsonl").read_text().splitlines()[0])
    own = {"elapsed_s", "trajectory", "epoch"}
    assert {k: _strip(v) for k, v in info.items() if k not in own} == \
        {k: _strip(line[k]) for k in info if k not in own}

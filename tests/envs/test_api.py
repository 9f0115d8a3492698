"""The environments pass PettingZoo's and Gymnasium's own checks, for every condition, on
real configs and on the built-in suites; they are deterministic; bad input is told clearly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.needs_env, pytest.mark.usefixtures("quiet")]

TASKS = str(SHARED_TASKS)
REAL = "A_D1__FloorPlan1__seed0"  # agents agent_1, agent_2
CONDITIONS = ("C0_blind", "D0_blind", "D1_blind", "LW_blind")
#: (source, task_id): one real config, and a built-in suite (the instance drawn per reset).
SOURCES = ((TASKS, REAL), ("demo", None))


@pytest.mark.parametrize("condition", CONDITIONS)
@pytest.mark.parametrize(("source", "task_id"), SOURCES)
def test_pettingzoo_parallel_and_aec_api_tests_pass(source, task_id, condition):
    from pettingzoo.test import api_test, parallel_api_test

    from cocobench_agents.envs import env, parallel_env

    parallel_api_test(parallel_env(source, condition=condition, task_id=task_id, seed=0),
                      num_cycles=200)
    api_test(env(source, condition=condition, task_id=task_id, seed=1), num_cycles=200)


@pytest.mark.parametrize("condition", ("C0_image", "D1_image"))
def test_image_conditions_pass_the_api_test_and_carry_frames(condition):
    from pettingzoo.test import parallel_api_test

    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition=condition, task_id=REAL)
    observations, _ = environment.reset(seed=0)
    image = next(iter(observations.values()))["frame"]
    assert image.dtype == np.uint8 and image.max() > 0
    parallel_api_test(environment, num_cycles=20)


SEATS = {"C0_blind": "team", "D0_blind": "agent_1", "D1_blind": "agent_2",
         "LW_blind": "agent_1"}


@pytest.mark.parametrize("condition", CONDITIONS)
@pytest.mark.parametrize(("source", "task_id"), SOURCES)
def test_gymnasium_check_env_passes_on_seat_env(source, task_id, condition):
    from gymnasium.utils.env_checker import check_env

    from cocobench_agents.envs import SeatEnv

    check_env(SeatEnv(source, condition=condition, seat=SEATS[condition], partner="random",
                      task_id=task_id), skip_render_check=True)


def test_the_leader_seat_learns_with_robot_partners():
    from gymnasium.utils.env_checker import check_env

    from cocobench_agents.envs import SeatEnv

    environment = SeatEnv(TASKS, condition="LW_blind", seat="leader", partner="greedy",
                          task_id=REAL)
    check_env(environment, skip_render_check=True)
    observation, _ = environment.reset(seed=0)
    assert "agent_1" in observation["prompt"]


def rollout(environment, seed: int, steps: int = 40) -> list:
    """Observations and rewards of `steps` steps of seeded random legal actions."""
    observations, _ = environment.reset(seed=seed)
    rng = np.random.default_rng(seed)
    seen = [observations]
    for _ in range(steps):
        if not environment.agents:
            break
        actions = {}
        for seat in environment.agents:
            observation = observations[seat]
            ids = np.flatnonzero(observation["action_mask"]) - 1
            choice = int(rng.choice(ids[ids >= 0])) if (ids >= 0).any() else -1
            if "sends_message" not in observation:  # a seat that never broadcasts
                actions[seat] = choice
                continue
            sends = observation["sends_message"] == 1
            actions[seat] = {"action": choice, "message": f"agent_1: m{choice}" if sends else ""}
        observations, rewards, *_ = environment.step(actions)
        seen.append((observations, rewards))
    return seen


@pytest.mark.parametrize("condition", CONDITIONS)
def test_same_seed_same_actions_same_observations(condition):
    from cocobench_agents.envs import parallel_env

    def run(seed):
        return rollout(parallel_env("demo", condition=condition), seed)

    first, again, other = run(3), run(3), run(4)
    assert _same(first, again)
    assert not _same(first, other)


def _same(a, b) -> bool:
    import pickle

    return pickle.dumps(a) == pickle.dumps(b)


def test_the_observation_is_the_prompt_the_harness_sends():
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.engine.first_prompts import first_round_requests
    from cocobench_agents.envs import parallel_env
    from cocobench_agents.episode_runner import EpisodeSpec

    config = load_tasks("demo")[1]
    for planner, condition in (("centralized", "C0_blind"), ("decentralized", "D0_blind"),
                               ("decentralized-broadcast", "D1_blind"),
                               ("leader-worker", "LW_blind")):
        observations, _ = parallel_env("demo", condition=condition,
                                       task_id=config.task_id).reset()
        requests = first_round_requests(EpisodeSpec(config, planner=planner,
                                                    obs_mode="blind"))
        sent = {r.agent or r.role: r.messages[-1]["content"] for r in requests}
        if planner == "leader-worker":  # the robots wait for the leader's word first
            sent = {"leader": sent["leader"]}
        prompts = {seat: obs["prompt"] for seat, obs in observations.items() if obs["prompt"]}
        assert sent == prompts


def test_rewards_are_the_benchmarks_own_and_the_last_info_is_the_result_line():
    from benchmark_adapter.oracles import oracle_plan
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL,
                               reward={"legality": 0.5, "construct": 1.0})
    environment.reset()
    plan, total = oracle_plan(environment.episode.spec.config), 0.0
    failing = environment.episode.view("team").menu
    for call in plan:
        entry = next(o for o in environment.episode.view("team").menu if o.call == call)
        rewards = environment.step({"team": entry.action_id})[1]
        total += rewards["team"]
    _, rewards, terminations, truncations, infos = environment.step({"team": -1})
    total += rewards["team"]
    result = environment.state_result
    assert terminations == {"team": True} and truncations == {"team": False}
    assert result.task_success == 1
    # progress sums to the final progress; success and construct come at the end.
    assert total == pytest.approx(result.task_progress + 1 + result.construct_score)
    assert infos["team"] == result.model_dump(mode="json")
    assert infos["team"]["condition"] == "C0_blind"
    assert failing  # the menu was there to choose from


def test_a_failed_call_costs_its_seat_the_legality_weight():
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="D0_blind", task_id=REAL,
                               reward={"legality": 2.0, "progress": 0.0})
    environment.reset()
    put = next(o for o in environment.episode.view("agent_1").menu if o.call.startswith("Put"))
    _, rewards, *_ = environment.step({"agent_1": put.action_id, "agent_2": -1})
    assert rewards == {"agent_1": -2.0, "agent_2": 0.0}


def test_an_invalid_id_costs_what_a_failed_call_does_and_is_never_better_than_done():
    from cocobench_agents.envs import DEFAULT_WEIGHTS, parallel_env

    team = parallel_env(TASKS, condition="C0_blind", task_id=REAL)
    team.reset()
    invalid = team.step({"team": 999})[1]["team"]
    team.reset()
    done = team.step({"team": -1})[1]["team"]
    assert invalid == -DEFAULT_WEIGHTS["legality"] < done == 0.0  # both end a C0 episode
    robots = parallel_env(TASKS, condition="D0_blind", task_id=REAL)
    robots.reset()
    rewards = robots.step({"agent_1": 999, "agent_2": -1})[1]
    assert rewards == {"agent_1": -DEFAULT_WEIGHTS["legality"], "agent_2": 0.0}


def test_a_failed_call_costs_less_than_a_passing_check_is_worth():
    from benchmark_adapter.episode import Episode
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.envs import DEFAULT_WEIGHTS

    for config in load_tasks(TASKS):
        episode = Episode(config)
        episode.reset()
        checks = len(episode.items[-1]["eval"]["checks"])
        assert 0 < DEFAULT_WEIGHTS["legality"] < DEFAULT_WEIGHTS["progress"] / checks


def test_the_construct_score_is_paid_only_for_a_successful_episode():
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL,
                               reward={"construct": 1.0, "progress": 0.0, "legality": 0.0,
                                       "success": 0.0})
    observations, _ = environment.reset()
    rng, paid = np.random.default_rng(0), 0.0
    while environment.agents:  # random moves to the budget: a construct score, no success
        ids = np.flatnonzero(observations["team"]["action_mask"])[1:] - 1
        observations, rewards, *_ = environment.step({"team": int(rng.choice(ids))})
        paid += rewards["team"]
    result = environment.state_result
    assert result.task_success == 0 and result.construct_score > 0.4 and paid == 0.0


def test_the_budget_truncates():
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL, max_steps=2)
    environment.reset()
    explore = [o for o in environment.episode.view("team").menu if "Explore" in o.call]
    environment.step({"team": explore[0].action_id})
    _, _, terminations, truncations, infos = environment.step({"team": explore[1].action_id})
    assert truncations == {"team": True} and terminations == {"team": False}
    assert infos["team"]["terminal_reason"] == "max_steps"


@pytest.mark.parametrize("mode", ("sync", "async"))
def test_seat_env_runs_under_gymnasium_vector(mode):
    import gymnasium

    from cocobench_agents.envs import SeatEnv

    def make():
        return SeatEnv("demo", condition="D0_blind", seat="agent_1", partner="greedy")

    kind = gymnasium.vector.SyncVectorEnv if mode == "sync" else gymnasium.vector.AsyncVectorEnv
    vector = kind([make, make])  # (async: in shared memory, prompts' newlines and all)
    try:
        observations, _ = vector.reset(seed=[1, 2])
        masks = observations["action_mask"]
        actions = np.array([int(np.flatnonzero(m)[-1]) - 1 for m in masks])
        observations, rewards, *_ = vector.step(actions)
        assert rewards.shape == (2,) and len(observations["prompt"]) == 2
        assert all("agent_1" in p for p in observations["prompt"])
        assert all("\n" in p for p in observations["prompt"])
    finally:
        vector.close()


# -- bad input -------------------------------------------------------------------------------


def test_an_action_off_the_mask_is_scored_as_an_invalid_id_by_default():
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL)
    environment.reset()
    _, _, terminations, _, infos = environment.step({"team": 999})
    assert terminations == {"team": True}  # as the reference ends C0 on an invalid id
    decision = environment.episode.document["planner_decisions"][-1]
    assert decision["status"] == "invalid_action_id" and decision["parsed_action_id"] == "999"
    assert infos["team"]["task_success"] == 0


def test_an_action_off_the_mask_is_refused_when_asked():
    from cocobench_agents.envs import EnvError, parallel_env

    environment = parallel_env(TASKS, condition="D0_blind", task_id=REAL, off_menu="error")
    environment.reset()
    with pytest.raises(EnvError, match=r"action 999 of seat 'agent_1' is not on its menu"):
        environment.step({"agent_1": 999, "agent_2": -1})
    with pytest.raises(EnvError, match="must be a menu id"):
        environment.step({"agent_1": "3", "agent_2": -1})


def test_the_action_space_holds_every_menu_id_and_a_smaller_one_is_refused():
    from cocobench_agents.envs import EnvError, parallel_env

    # The full suite's menus can reach ids above 255 once objects are sliced.
    environment = parallel_env("cocobench-full", condition="C0_blind", text=False)
    assert environment.action_space("team").n > 256 + 1
    with pytest.raises(EnvError, match=r"max_menu=255 is too small: \d+ of the source's "
                                       r"instances can show larger menu ids \(up to \d+, in "):
        parallel_env("cocobench-full", condition="C0_blind", max_menu=255)
    assert parallel_env(TASKS, condition="D0_blind", task_id=REAL, max_menu=400
                        ).action_space("agent_1").n == 402


def test_a_message_from_a_seat_that_sends_none_is_refused_when_asked():
    from cocobench_agents.envs import EnvError, parallel_env

    environment = parallel_env(TASKS, condition="D0_blind", task_id=REAL)
    environment.reset()
    with pytest.raises(EnvError, match="seat 'agent_1' sends no messages"):
        environment.step({"agent_1": {"action": 0, "message": "hi"}, "agent_2": -1})
    led = parallel_env(TASKS, condition="LW_blind", task_id=REAL, off_menu="error")
    led.reset()
    with pytest.raises(EnvError, match="seat 'agent_1' waits this phase"):
        led.step({"leader": {"action": -1, "message": "agent_1: go"},
                  "agent_1": {"action": -1, "message": "me too"},
                  "agent_2": {"action": -1, "message": ""}})


def test_stepping_a_finished_episode_is_refused():
    from cocobench_agents.envs import EnvError, parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL)
    environment.reset()
    environment.step({"team": -1})  # DONE ends a C0 episode
    assert environment.agents == []
    with pytest.raises(EnvError, match=r"the episode has ended: call reset\(\)"):
        environment.step({})
    with pytest.raises(EnvError, match="no live seat 'team'"):
        environment.step({"team": 0})


def test_unknown_names_are_told():
    from cocobench_agents.envs import EnvError, SeatEnv, parallel_env
    from cocobench_agents.harness import PlanError
    from cocobench_agents.models import ModelConfigError

    with pytest.raises(PlanError, match="unknown condition 'Z9_blind'"):
        parallel_env(TASKS, condition="Z9_blind", task_id=REAL)
    with pytest.raises(EnvError, match="one, such as D1_blind"):
        parallel_env(TASKS, condition="blind", task_id=REAL)
    with pytest.raises(EnvError, match=r"'oracle' \(OR\) calls no model: it has no seat to play"):
        parallel_env(TASKS, condition="OR_blind", task_id=REAL)
    with pytest.raises(EnvError, match="unknown reward 'speed': the rewards are progress"):
        parallel_env(TASKS, condition="C0_blind", task_id=REAL, reward={"speed": 1})
    with pytest.raises(EnvError, match="no seat 'agent_0' in A_D1__FloorPlan1__seed0"):
        SeatEnv(TASKS, condition="D0_blind", seat="agent_0", partner="greedy", task_id=REAL)
    with pytest.raises(ModelConfigError, match="cannot read the script"):
        SeatEnv(TASKS, condition="D0_blind", seat="agent_1", partner="scripted:/no/such.json",
                task_id=REAL)
    with pytest.raises(Exception, match="unknown task 'nope'"):
        parallel_env(TASKS, condition="C0_blind", task_id="nope")
    with pytest.raises(EnvError, match="off_menu must be 'score' or 'error', not 'skip'"):
        parallel_env(TASKS, condition="C0_blind", task_id=REAL, off_menu="skip")
    with pytest.raises(EnvError, match="unknown task_id 'nope' in options"):
        parallel_env(TASKS, condition="C0_blind").reset(options={"task_id": "nope"})


@pytest.mark.parametrize("condition", ("D0_blind", "D1_blind", "LW_blind"))
def test_an_oracle_partner_plays_its_part_of_the_reference_plan(condition):
    from cocobench_agents.envs import SeatEnv
    from cocobench_agents.envs.oracle_partner import OraclePlan

    seat_env = SeatEnv(TASKS, condition=condition, seat="agent_2", partner="oracle",
                       task_id=REAL)
    seat_env.reset(seed=0)
    episode = seat_env.team.episode
    plan = OraclePlan(episode.episode)  # the learner follows the same plan for its calls
    terminated = truncated = False
    while not (terminated or truncated):
        call = plan.next_call()
        entry = next((o for o in episode.view("agent_2").menu if o.call == call), None)
        choice = entry.action_id if entry else -1
        action = choice if condition == "D0_blind" else {"action": choice, "message": ""}
        _, _, terminated, truncated, info = seat_env.step(action)
    assert info["task_success"] == 1
    decisions = episode.document["planner_decisions"]
    assert {d["model"] for d in decisions if d["agent"] == "agent_1"} == {"oracle"}


def test_closing_the_env_closes_its_one_loop_and_the_partners_clients():
    import asyncio

    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.envs import parallel_env

    environment = parallel_env("demo", condition="D0_blind", partners={"agent_1": "greedy"},
                               max_steps=3)
    closed = []

    class Remote:  # a remote partner's client, as the pool keeps it
        async def aclose(self):
            closed.append(asyncio.get_running_loop())

    environment.pool._remote["remote/model"] = Remote()
    for config in load_tasks("demo")[:2]:
        environment.reset(options={"task_id": config.task_id})
        while environment.agents:
            environment.step(dict.fromkeys(environment.agents, -1))
        assert environment.state_result is not None
    episodes = list(environment._episodes.values())
    loop = environment.loop
    assert len(episodes) == 2 and all(e._loop is loop for e in episodes)
    environment.close()
    assert loop.is_closed() and closed == [loop]


def test_a_waiting_seats_message_is_not_read_by_default():
    from cocobench_agents.envs import parallel_env

    led = parallel_env(TASKS, condition="LW_blind", task_id=REAL)
    observations, _ = led.reset()
    assert observations["agent_1"]["sends_message"] == 0  # the leader speaks first
    led.step({"leader": {"action": 5, "message": "agent_1: find the apple"},
              "agent_1": {"action": 3, "message": "me too"},
              "agent_2": {"action": -1, "message": ""}})
    lead = next(d for d in led.episode.tools.decisions if d["policy"] == "leader")
    assert lead["directives"]["agent_1"] == "find the apple"
    assert "me too" not in str(led.episode.episode.items)


@pytest.mark.parametrize(("call", "error"), [
    (lambda e: e.reset(options="x"), r"reset options must be a dict such as \{'task_id': …\}, "
                                     r"not 'x'"),
    (lambda e: e.reset(seed=-1), "seed must be a non-negative integer or None, not -1"),
    (lambda e: e.reset(seed=1.5), "seed must be a non-negative integer or None, not 1.5"),
    (lambda e: e.reset(seed="7"), "seed must be a non-negative integer or None, not '7'"),
])
def test_bad_reset_arguments_are_told(call, error):
    from cocobench_agents.envs import EnvError, SeatEnv, parallel_env

    with pytest.raises(EnvError, match=error):
        call(parallel_env(TASKS, condition="C0_blind", task_id=REAL))
    with pytest.raises(EnvError, match=error):
        call(SeatEnv(TASKS, condition="C0_blind", seat="team", partner="greedy",
                     task_id=REAL))


def test_an_unknown_reset_option_is_warned_about_not_dropped_silently():
    from cocobench_agents.envs import EnvWarning, parallel_env

    environment = parallel_env(TASKS, condition="C0_blind", task_id=REAL)
    with pytest.warns(EnvWarning, match="unknown reset option 'taskid' is not read: the "
                                        "options are task_id"):
        environment.reset(options={"taskid": REAL})


@pytest.mark.parametrize(("options", "error"), [
    ({"max_steps": 0}, "max_steps must be a positive integer .* not 0"),
    ({"max_steps": -3}, "max_steps must be a positive integer .* not -3"),
    ({"max_steps": 2.5}, "max_steps must be a positive integer .* not 2.5"),
    ({"seed": -2}, "seed must be a non-negative integer or None, not -2"),
    ({"partners": {"agent_9": "greedy"}}, "partners name no seat 'agent_9': the seats under "
                                          "D0_blind are agent_1, agent_2"),
    ({"render_mode": "human"}, "render_mode must be 'ansi' or 'rgb_array' .*not 'human'"),
    ({"text": "no"}, "text must be True or False, not 'no'"),
    ({"max_menu": "300"}, r"max_menu must be an integer \(or None: .*\), not '300'"),
    ({"reward": {"progress": "1"}}, "the weight of reward 'progress' must be a number, not '1'"),
    ({"observation": "pixels"}, "observation must be 'text' or 'numeric', not 'pixels'"),
])
def test_bad_options_are_told(options, error):
    from cocobench_agents.envs import EnvError, parallel_env

    with pytest.raises(EnvError, match=error):
        parallel_env(TASKS, condition="D0_blind", task_id=REAL, **options)


def test_a_message_over_its_limit_is_refused_not_cut():
    from cocobench_agents.envs import EnvError, parallel_env

    environment = parallel_env(TASKS, condition="D1_blind", task_id=REAL)
    environment.reset()
    space = environment.action_space("agent_1")["message"]
    assert space.contains("x" * 200) and not space.contains("x" * 201)
    with pytest.raises(EnvError, match="the message of seat 'agent_1' is 201 characters: the "
                                       "limit is 200"):
        environment.step({"agent_1": {"action": -1, "message": "x" * 201}, "agent_2": -1})
    with pytest.raises(EnvError, match="must be one line"):
        environment.step({"agent_1": {"action": -1, "message": "a\nACTION: 3"},
                          "agent_2": -1})
    environment.step({"agent_1": {"action": -1, "message": "y" * 200}, "agent_2": -1})
    sent = [d for d in environment.episode.tools.decisions if d.get("message")]
    assert sent[-1]["message"] == "y" * 200
    led = parallel_env(TASKS, condition="LW_blind", task_id=REAL)
    led.reset()
    with pytest.raises(EnvError, match="the message of seat 'leader' is 4001 characters: the "
                                       "limit is 4000"):
        led.step({"leader": {"action": -1, "message": "x" * 4001}, "agent_1": -1,
                  "agent_2": -1})


def test_render_modes():
    import gymnasium

    from cocobench_agents.envs import SEAT_ENV_ID, SeatEnv, parallel_env

    text = gymnasium.make(SEAT_ENV_ID, source=TASKS, condition="D1_blind", seat="agent_1",
                          partner="greedy", task_id=REAL, render_mode="ansi", text=False)
    observation, _ = text.reset(seed=0)
    view = text.render()
    assert observation["prompt"] == "" and "You are agent_1" in view  # rendered on demand
    frames = SeatEnv(TASKS, condition="C0_blind", seat="team", partner="greedy",
                     task_id=REAL, render_mode="rgb_array")
    frames.reset(seed=0)
    picture = frames.render()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3
    assert SeatEnv(TASKS, condition="C0_blind", seat="team", partner="greedy",
                   task_id=REAL).render() is None
    team = parallel_env(TASKS, condition="LW_blind", task_id=REAL, render_mode="ansi")
    team.reset()
    assert "== leader ==" in team.render() and "(waits this phase)" in team.render()


@pytest.mark.needs_trl
def test_a_script_that_imports_torch_exits_cleanly(tmp_path):
    import subprocess
    import sys

    script = tmp_path / "train.py"
    script.write_text(
        "import torch  # noqa: F401  (its teardown order made the loop's close fail)\n"
        "from cocobench_agents.envs import parallel_env\n"
        "environment = parallel_env('demo', condition='D0_blind',\n"
        "                           partners={'agent_1': 'greedy'})\n"
        "environment.reset(seed=0)\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=300, cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 0 and done.stderr == ""


@pytest.mark.parametrize("condition", CONDITIONS)
def test_the_state_for_centralized_critics_passes_pettingzoos_state_test(condition):
    from pettingzoo.test import state_test

    from cocobench_agents.envs import env, parallel_env

    state_test(env(TASKS, condition=condition, task_id=REAL),
               parallel_env(TASKS, condition=condition, task_id=REAL), num_cycles=5)


def test_the_state_holds_the_budget_the_goal_checks_and_every_seats_menu():
    from benchmark_adapter.oracles import oracle_plan
    from cocobench_agents.envs import parallel_env

    environment = parallel_env(TASKS, condition="D0_blind", task_id=REAL,
                               partners={"agent_2": "greedy"})
    environment.reset()
    size = environment.action_space("agent_1").n
    state = environment.state()
    assert state.shape == environment.state_space.shape == (2 + 3 + 2 * size,)
    masks = state[5:].reshape(2, size)
    assert masks[0, 0] == masks[1, 0] == 1  # both robots act: DONE is on each mask
    menu = environment.episode.tools.menu_options("agent_2")  # the partner's menu is in it too
    assert set(np.flatnonzero(masks[1])[1:] - 1) == {o.action_id for o in menu}
    call = next(iter(oracle_plan(environment.episode.spec.config)))
    entry = next(o for o in environment.episode.view("agent_1").menu if o.call == call)
    environment.step({"agent_1": entry.action_id})
    after = environment.state()
    assert 0 < after[0] <= 1 and environment.state_space.contains(after)

"""The numeric observation (``observation="numeric"``): fixed-size tables of the objects, the
menu entries and the goal, which Gymnasium's `FlattenObservation` turns into a vector a policy
network takes; deterministic; the goal in it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.needs_env, pytest.mark.usefixtures("quiet")]

TASKS = str(SHARED_TASKS)
REAL = "A_D1__FloorPlan1__seed0"  # agents agent_1, agent_2
#: The flattened width's ceiling: the text observation flattened to 2.8 million entries.
NARROW = 5_000


def numeric_seat(condition: str, seat: str, source: str = TASKS, **options):
    import gymnasium

    from cocobench_agents.envs import SEAT_ENV_ID

    return gymnasium.make(SEAT_ENV_ID, source=source, condition=condition, seat=seat,
                          partner="random", observation="numeric", **options)


@pytest.mark.parametrize(("condition", "seat"), [("C0_blind", "team"), ("D1_blind", "agent_1"),
                                                 ("LW_blind", "leader")])
def test_flattened_it_is_a_narrow_vector_every_step(condition, seat):
    from gymnasium.spaces import flatdim
    from gymnasium.wrappers import FlattenObservation

    environment = FlattenObservation(numeric_seat(condition, seat))
    width = environment.observation_space.shape[0]
    assert width == flatdim(environment.unwrapped.observation_space) < NARROW
    environment.action_space.seed(0)
    observation, _ = environment.reset(seed=0)
    for _ in range(12):
        assert observation.shape == (width,) and np.isfinite(observation).all()
        assert environment.observation_space.contains(observation)
        observation, _, terminated, truncated, _ = environment.step(
            environment.action_space.sample())
        if terminated or truncated:
            observation, _ = environment.reset()
    environment.close()


def test_the_tables_name_the_scene_the_menu_and_the_goal():
    from cocobench_agents.envs import parallel_env
    from cocobench_agents.envs.features import (
        ENTRY_COLUMNS,
        GOAL_COLUMNS,
        OBJECT_COLUMNS,
        OBJECT_TYPES,
        PREDICATES,
        SKILL_NAMES,
    )

    environment = parallel_env(TASKS, condition="D0_blind", task_id=REAL,
                               observation="numeric")
    observations, _ = environment.reset(seed=0)
    seen = observations["agent_1"]
    objects = {OBJECT_TYPES[int(row[1]) - 1]: row for row in seen["objects"] if row[0]}
    column = {name: i for i, name in enumerate(OBJECT_COLUMNS)}
    assert {"Potato", "Lettuce", "Fridge", "LightSwitch"} <= set(objects)
    assert objects["Fridge"][column["receptacle"]] == 1 and objects["Fridge"][column["in_goal"]]
    # The goal: potato and lettuce in the fridge, the light off; none met at the start.
    slot_type = {i + 1: OBJECT_TYPES[int(row[1]) - 1]
                 for i, row in enumerate(seen["objects"]) if row[0]}
    goal = [dict(zip(GOAL_COLUMNS, row)) for row in seen["goal"] if row[0]]
    assert [(PREDICATES[int(g["predicate"]) - 1], slot_type[int(g["object"])],
             slot_type.get(int(g["receptacle"])), g["passed"]) for g in goal] == [
        ("on", "Potato", "Fridge", 0), ("on", "Lettuce", "Fridge", 0),
        ("toggled", "LightSwitch", None, 0)]
    # Each menu entry's row sits at its id + 1, as in the action mask, and names its call.
    entries = seen["entries"]
    assert np.array_equal(entries[:, 0].astype(bool), seen["action_mask"].astype(bool))
    for option in environment.episode.view("agent_1").menu:
        row = dict(zip(ENTRY_COLUMNS, entries[option.action_id + 1]))
        assert option.call.startswith(f"{SKILL_NAMES[int(row['skill']) - 1]}(agent_1")
        assert row["robot"] == 1
        if option.call.startswith("Find("):
            assert option.call.split(", ")[1].startswith(slot_type[int(row["object"])])


def test_same_seed_and_actions_give_the_same_features():
    def trajectory() -> list[dict]:
        environment = numeric_seat("D1_blind", "agent_1")
        environment.action_space.seed(3)
        seen = [environment.reset(seed=5)[0]]
        for _ in range(10):
            observation, _, terminated, truncated, _ = environment.step(
                environment.action_space.sample())
            seen.append(observation)
            if terminated or truncated:
                break
        environment.close()
        return seen

    first, second = trajectory(), trajectory()
    assert len(first) == len(second) > 1
    for a, b in zip(first, second):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    assert any(not np.array_equal(first[0]["objects"], o["objects"]) for o in first[1:]) or \
        any(not np.array_equal(first[0]["context"], o["context"]) for o in first[1:])


def test_two_instances_that_differ_only_in_their_goal_differ_in_the_goal_table(tmp_path):
    from cocobench_agents.envs import parallel_env

    config = json.loads((SHARED_TASKS / f"{REAL}.json").read_text())
    lights_on = {**config, "task_id": f"{REAL}_lights_on",
                 "goal_predicates": [p if p["predicate"] != "toggled" else {**p, "value": True}
                                     for p in config["goal_predicates"]]}
    seen = []
    for variant in (config, lights_on):
        path = tmp_path / f"{variant['task_id']}.json"
        path.write_text(json.dumps(variant))
        environment = parallel_env(str(path), condition="C0_blind", observation="numeric")
        seen.append(environment.reset(seed=0)[0]["team"])
    same, other = seen
    assert np.array_equal(same["objects"], other["objects"])
    assert np.array_equal(same["entries"], other["entries"])
    assert not np.array_equal(same["goal"], other["goal"])


def test_the_object_table_holds_the_most_objects_an_instance_can_list():
    """Slicing adds pieces: the table's rows count them, so every object keeps a row."""
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.envs import parallel_env
    from cocobench_agents.envs.features import object_bound

    configs = load_tasks(TASKS)
    environment = parallel_env(TASKS, condition="C0_blind", observation="numeric")
    rows = environment.observation_space("team")["objects"].shape[0]
    assert rows == max(map(object_bound, configs))
    sliced = next(c for c in configs if any(p.predicate == "sliced_by"
                                            for p in c.goal_predicates))
    assert object_bound(sliced) > len(sliced.init_state.objects)


def test_a_bad_observation_option_is_told():
    from cocobench_agents.envs import EnvError, parallel_env

    with pytest.raises(EnvError, match="observation must be 'text' or 'numeric', not 'pixels'"):
        parallel_env(TASKS, condition="C0_blind", task_id=REAL, observation="pixels")

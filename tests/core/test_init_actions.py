"""Init actions applied at reset (reference §2.3): every kind, traced, never raised."""

from __future__ import annotations

import copy

from benchmark_adapter.episode import Episode
from benchmark_adapter.scene_setup import apply_init_actions

from .worlds import (
    DRAWER_A,
    FRIDGE,
    GHOST,
    KNIFE,
    LIGHT,
    MUG,
    TOMATO,
    Sim,
    make_config,
    touch,
)

TRACE_KEYS = {"action", "lastActionSuccess", "errorMessage"}
# A CounterTop that only the K-style init action names (not an important object).
SPARE_COUNTER = "CounterTop|+02.50|+00.95|-02.00"


def apply(sim: Sim, *actions: dict) -> list[dict]:
    trace = apply_init_actions(sim.ctl, [dict(a) for a in actions])
    assert len(trace) == len(actions)
    for entry in trace:
        assert set(entry) == TRACE_KEYS
        assert isinstance(entry["lastActionSuccess"], bool)
        assert isinstance(entry["errorMessage"], str)
    return trace


def test_assert_present(kitchen: Sim) -> None:
    action = {"action": "assert_present", "objectId": TOMATO}
    assert apply(kitchen, action) == [
        {"action": action, "lastActionSuccess": True, "errorMessage": ""}]


def test_assert_present_missing(kitchen: Sim) -> None:
    [entry] = apply(kitchen, {"action": "assert_present", "objectId": GHOST})
    assert entry["lastActionSuccess"] is False
    assert GHOST in entry["errorMessage"] and "not present" in entry["errorMessage"]
    assert entry["action"] == {"action": "assert_present", "objectId": GHOST}


def test_ensure_toggle_state_toggles_then_is_already_satisfied(kitchen: Sim) -> None:
    kitchen.place(0, -2.5, -2.5, 180.0)  # agent 0 cannot see the switch: the toggle is forced
    assert kitchen.obj(LIGHT)["isToggled"] is False
    action = {"action": "ensure_toggle_state", "objectId": LIGHT, "isToggled": True,
              "note": "light starts on"}
    [first] = apply(kitchen, action)
    assert first["lastActionSuccess"] is True and first["errorMessage"] == ""
    assert first["action"]["objectId"] == LIGHT
    assert kitchen.obj(LIGHT)["isToggled"] is True
    [second] = apply(kitchen, action)
    assert second == {"action": action, "lastActionSuccess": True,
                      "errorMessage": "already satisfied"}
    assert kitchen.obj(LIGHT)["isToggled"] is True


def test_ensure_toggle_state_off(kitchen: Sim) -> None:
    kitchen.world.objects[LIGHT].is_toggled = True
    touch(kitchen.world)
    [entry] = apply(kitchen, {"action": "ensure_toggle_state", "objectId": LIGHT,
                              "isToggled": False})
    assert entry["lastActionSuccess"] is True
    assert kitchen.obj(LIGHT)["isToggled"] is False


def test_ensure_empty(kitchen: Sim) -> None:
    assert kitchen.run(f"Find(agent_1, {MUG})").success
    mug = kitchen.world.objects[MUG]
    mug.is_filled, mug.fill_liquid = True, "water"
    touch(kitchen.world)
    [entry] = apply(kitchen, {"action": "ensure_empty", "objectId": MUG})
    assert entry["lastActionSuccess"] is True and entry["errorMessage"] == ""
    assert kitchen.obj(MUG)["isFilledWithLiquid"] is False
    [again] = apply(kitchen, {"action": "ensure_empty", "objectId": MUG})
    assert again["lastActionSuccess"] is True
    assert again["errorMessage"].startswith("already")


def test_open_then_close_object_without_agent_id(kitchen: Sim) -> None:
    opened = {"action": "OpenObject", "objectId": FRIDGE, "forceAction": True,
              "note": "pre-open the fridge"}
    closed = {"action": "CloseObject", "objectId": DRAWER_A, "forceAction": True}
    trace = apply(kitchen, opened, {"action": "OpenObject", "objectId": DRAWER_A,
                                    "forceAction": True}, closed)
    assert [t["lastActionSuccess"] for t in trace] == [True, True, True]
    assert trace[0]["action"]["note"] == "pre-open the fridge"  # extra keys pass through
    assert kitchen.obj(FRIDGE)["isOpen"] is True
    assert kitchen.obj(DRAWER_A)["isOpen"] is False


def test_close_an_already_closed_object_is_a_traced_failure(kitchen: Sim) -> None:
    [entry] = apply(kitchen, {"action": "CloseObject", "objectId": DRAWER_A,
                              "forceAction": True})
    assert entry["lastActionSuccess"] is False
    assert "already closed" in entry["errorMessage"]


K_INIT = [
    {"action": "assert_present", "objectId": KNIFE},
    {"action": "PickupObject", "objectId": KNIFE, "agentId": 0, "forceAction": True},
    {"action": "PutObject", "objectId": SPARE_COUNTER, "agentId": 0, "forceAction": True,
     "placeStationary": True},
]


def test_k_style_pickup_and_put_onto_a_counter_only_the_init_action_names() -> None:
    config = make_config({"knife": KNIFE, "tomato": TOMATO}, init_actions=K_INIT)
    ep = Episode(config)
    obs = ep.reset()
    assert [t["lastActionSuccess"] for t in ep.init_trace] == [True, True, True]
    assert [t["errorMessage"] for t in ep.init_trace] == ["", "", ""]
    world = ep.controller.world
    assert SPARE_COUNTER in world.objects  # created because the init action names it
    knife = next(o for o in ep.objects() if o["objectId"] == KNIFE)
    assert knife["parentReceptacles"] == [SPARE_COUNTER]
    assert obs.inventories == {"agent_1": [], "agent_2": []}
    assert all(SPARE_COUNTER not in e.args for e in obs.action_menu)  # not important


def test_initial_random_spawn_is_recorded_as_success(kitchen: Sim) -> None:
    before = {oid: (o.x, o.y, o.z) for oid, o in kitchen.world.objects.items()}
    action = {"action": "InitialRandomSpawn", "randomSeed": 2, "forceVisible": False,
              "numPlacementAttempts": 5, "placeStationary": True}
    assert apply(kitchen, action) == [
        {"action": action, "lastActionSuccess": True, "errorMessage": ""}]
    assert {oid: (o.x, o.y, o.z) for oid, o in kitchen.world.objects.items()} == before


def test_unknown_action_is_recorded_as_failed_and_the_rest_still_runs(kitchen: Sim) -> None:
    trace = apply(kitchen,
                  {"action": "Levitate", "objectId": TOMATO},
                  {"action": "OpenObject", "objectId": FRIDGE, "forceAction": True})
    assert trace[0]["lastActionSuccess"] is False
    assert "Levitate" in trace[0]["errorMessage"]
    assert trace[0]["action"] == {"action": "Levitate", "objectId": TOMATO}
    assert trace[1]["lastActionSuccess"] is True
    assert kitchen.obj(FRIDGE)["isOpen"] is True


def test_init_action_without_a_name_is_a_traced_failure(kitchen: Sim) -> None:
    [entry] = apply(kitchen, {"objectId": TOMATO})
    assert entry["lastActionSuccess"] is False and entry["errorMessage"]


def test_an_init_action_that_raises_is_recorded_not_raised(kitchen: Sim) -> None:
    trace = apply_init_actions(kitchen.ctl, [
        {"action": "PickupObject", "objectId": KNIFE, "agentId": 5, "forceAction": True},
        {"action": "assert_present", "objectId": KNIFE},
    ])
    assert [t["lastActionSuccess"] for t in trace] == [False, True]
    assert trace[0]["errorMessage"]


def test_raw_state_actions_are_forced_by_default(kitchen: Sim) -> None:
    kitchen.place(0, -2.5, -2.5, 180.0)
    assert kitchen.obj(MUG)["visible"] is False
    [entry] = apply(kitchen, {"action": "DirtyObject", "objectId": MUG})
    assert entry["lastActionSuccess"] is True, entry["errorMessage"]
    assert kitchen.obj(MUG)["isDirty"] is True
    # the same raw action not in the forced set needs the object in view
    [toggle] = apply(kitchen, {"action": "ToggleObjectOn", "objectId": LIGHT})
    assert toggle["lastActionSuccess"] is False


def test_episode_records_the_init_trace_and_leaves_the_config_alone() -> None:
    actions = [{"action": "assert_present", "objectId": TOMATO},
               {"action": "ensure_toggle_state", "objectId": LIGHT, "isToggled": True},
               {"action": "DirtyObject", "objectId": MUG},
               {"action": "Levitate"}]
    config = make_config(init_actions=actions)
    snapshot = copy.deepcopy(config.init_state.init_actions)
    ep = Episode(config)
    ep.reset()
    assert [t["lastActionSuccess"] for t in ep.init_trace] == [True, True, True, False]
    assert config.init_state.init_actions == snapshot  # nothing added (e.g. forceAction)
    document = ep.finish()
    assert document["init_trace"] == ep.init_trace
    init = document["trajectory"][0]
    assert (init["label"], init["step_index"]) == ("init", 0)
    assert init["native_trace"] == ep.init_trace
    assert "skill_result" not in init


def test_reset_reapplies_init_actions_on_a_fresh_world() -> None:
    config = make_config(init_actions=[{"action": "OpenObject", "objectId": FRIDGE,
                                        "forceAction": True}])
    ep = Episode(config)
    ep.reset()
    assert ep.step(f"Close(agent_1, {FRIDGE})").success
    ep.reset()
    assert [t["lastActionSuccess"] for t in ep.init_trace] == [True]
    fridge = next(o for o in ep.objects() if o["objectId"] == FRIDGE)
    assert fridge["isOpen"] is True
    assert len(ep.items) == 1


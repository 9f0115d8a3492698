"""The skill layer (reference §4.1–4.2): every skill in a valid situation, every refusal text,
the visibility rules (non-forced ToggleOn/Slice need a Find; forced PickUp/Put/Open do not)."""

from __future__ import annotations

import math

import pytest

from benchmark_adapter.skills import SKILLS
from benchmark_adapter.vocabulary import SKILL_NAMES

from .worlds import (
    COUNTER,
    DRAWER_A,
    FRIDGE,
    GHOST,
    KNIFE,
    LIGHT,
    MUG,
    PLATE,
    TOMATO,
    Sim,
    touch,
)

# A corner of the kitchen floor from which an agent facing -z sees none of the objects.
BLIND_SPOT = (-2.5, -2.5, 180.0)


def blind(sim: Sim, agent: int = 0) -> None:
    """Move `agent` where it sees nothing, and check that it indeed sees nothing."""
    sim.place(agent, *BLIND_SPOT)
    assert not any(o["visible"] for o in sim.md(agent)["objects"] if not o["isPickedUp"])


def ok(sim: Sim, call: str):
    result = sim.run(call)
    assert result.success, f"{call}: {result.errorMessage}"
    assert result.errorMessage == ""
    return result


def refused(sim: Sim, call: str, message: str, *, native: bool = False):
    """The call fails with exactly `message`; `native` says whether a native action ran."""
    result = sim.run(call)
    assert result.success is False
    assert result.errorMessage == message
    assert bool(result.native_trace) is native
    return result


# -- every skill succeeds in a valid situation ------------------------------------------------

def test_find_makes_the_object_visible(kitchen: Sim) -> None:
    blind(kitchen, 0)
    result = ok(kitchen, f"Find(agent_1, {TOMATO})")
    assert kitchen.obj(TOMATO, 0)["visible"] is True
    assert [t["action"]["action"] for t in result.native_trace][:1] == ["GetInteractablePoses"]
    assert result.native_trace[-1]["action"]["action"] == "TeleportFull"


@pytest.mark.parametrize(("direction", "expected"), [
    # from (0.0, -2.0) facing +z (yaw 0) with a level camera: (x, z, yaw, horizon) afterwards
    ("forward", (0.0, -1.75, 0.0, 0.0)),
    ("back", (0.0, -2.25, 0.0, 0.0)),
    ("left", (-0.25, -2.0, 0.0, 0.0)),
    ("right", (0.25, -2.0, 0.0, 0.0)),
    ("turn_left", (0.0, -2.0, 270.0, 0.0)),
    ("turn_right", (0.0, -2.0, 90.0, 0.0)),
    ("look_up", (0.0, -2.0, 0.0, -30.0)),
    ("look_down", (0.0, -2.0, 0.0, 30.0)),
])
def test_explore_each_direction(kitchen: Sim, direction: str, expected: tuple) -> None:
    kitchen.place(0, *BLIND_SPOT)
    kitchen.place(1, 0.0, -2.0, 0.0, 0.0)
    result = ok(kitchen, f"Explore(agent_2, {direction})")
    assert result.args == {"direction": direction}
    assert len(result.native_trace) == 1
    x, z, yaw, horizon = kitchen.pose(1)
    assert (x, z, yaw, horizon) == pytest.approx(expected)
    agent = kitchen.md(1)["agent"]
    assert (agent["position"]["x"], agent["position"]["z"]) == pytest.approx(expected[:2])


def test_explore_moves_by_a_quarter_metre(kitchen: Sim) -> None:
    kitchen.place(1, 0.0, -2.0, 0.0, 0.0)
    result = ok(kitchen, "Explore(agent_2, forward)")
    assert result.native_trace[0]["action"] == {"action": "MoveAhead", "agentId": 1,
                                                "moveMagnitude": 0.25}


def test_wait_is_one_pass(kitchen: Sim) -> None:
    before = kitchen.pose(0)
    result = ok(kitchen, "Wait(agent_1)")
    assert [t["action"] for t in result.native_trace] == [{"action": "Pass", "agentId": 0}]
    assert kitchen.pose(0) == before


def test_pickup_put_drop(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    assert [o["objectId"] for o in kitchen.md(0)["inventoryObjects"]] == [TOMATO]
    assert kitchen.obj(TOMATO)["isPickedUp"] is True
    put = ok(kitchen, f"Put(agent_1, {PLATE})")
    assert put.args == {"objectId": TOMATO, "receptacleId": PLATE}
    assert put.native_trace[0]["action"] == {
        "action": "PutObject", "agentId": 0, "objectId": PLATE, "forceAction": True,
        "placeStationary": True}
    assert kitchen.md(0)["inventoryObjects"] == []
    assert kitchen.obj(TOMATO)["parentReceptacles"] == [PLATE]
    assert kitchen.obj(PLATE)["receptacleObjectIds"] == [TOMATO]
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    assert kitchen.obj(PLATE)["receptacleObjectIds"] == []
    drop = ok(kitchen, "Drop(agent_1)")
    assert drop.native_trace[0]["action"] == {"action": "DropHandObject", "agentId": 0,
                                              "forceAction": True}
    assert kitchen.md(0)["inventoryObjects"] == []
    assert kitchen.obj(TOMATO)["isPickedUp"] is False
    assert kitchen.obj(TOMATO)["parentReceptacles"] is None


def test_open_and_close(kitchen: Sim) -> None:
    assert kitchen.obj(DRAWER_A)["isOpen"] is False
    ok(kitchen, f"Open(agent_1, {DRAWER_A})")
    assert kitchen.obj(DRAWER_A)["isOpen"] is True
    ok(kitchen, f"Close(agent_1, {DRAWER_A})")
    assert kitchen.obj(DRAWER_A)["isOpen"] is False


def test_toggle_on_and_off_after_find(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_2, {LIGHT})")
    on = ok(kitchen, f"ToggleOn(agent_2, {LIGHT})")
    assert on.native_trace[0]["action"] == {"action": "ToggleObjectOn", "agentId": 1,
                                            "objectId": LIGHT}  # not forced
    assert kitchen.obj(LIGHT)["isToggled"] is True
    ok(kitchen, f"ToggleOff(agent_2, {LIGHT})")
    assert kitchen.obj(LIGHT)["isToggled"] is False


def test_slice_creates_tomato_pieces(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {KNIFE})")
    ok(kitchen, f"Find(agent_1, {TOMATO})")
    result = ok(kitchen, f"Slice(agent_1, {TOMATO})")
    assert result.native_trace[0]["action"] == {"action": "SliceObject", "agentId": 0,
                                                "objectId": TOMATO}
    ids = [o["objectId"] for o in kitchen.md(0)["objects"]]
    pieces = sorted(i for i in ids if "Sliced" in i)
    assert pieces == [
        "Tomato|+00.50|+00.95|+00.20|TomatoSliced_0",
        "Tomato|+00.50|+00.95|+00.20|TomatoSliced_1",
        "Tomato|+00.50|+00.95|+00.20|TomatoSliced_2",
    ]
    assert {kitchen.obj(p)["objectType"] for p in pieces} == {"TomatoSliced"}
    assert kitchen.obj(TOMATO)["isSliced"] is True  # the source stays in the metadata


def test_clean_object(kitchen: Sim) -> None:
    kitchen.world.objects[MUG].is_dirty = True
    touch(kitchen.world)
    assert kitchen.obj(MUG)["isDirty"] is True
    ok(kitchen, f"Find(agent_1, {MUG})")
    ok(kitchen, f"CleanObject(agent_1, {MUG})")
    assert kitchen.obj(MUG)["isDirty"] is False


def test_fill_and_empty_liquid(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_1, {MUG})")
    fill = ok(kitchen, f"FillObjectWithLiquid(agent_1, {MUG}, coffee)")
    assert fill.args["objectId"] == MUG
    assert fill.native_trace[0]["action"]["fillLiquid"] == "coffee"
    assert (kitchen.obj(MUG)["isFilledWithLiquid"], kitchen.obj(MUG)["fillLiquid"]) == (
        True, "coffee")
    ok(kitchen, f"EmptyLiquidFromObject(agent_1, {MUG})")
    assert (kitchen.obj(MUG)["isFilledWithLiquid"], kitchen.obj(MUG)["fillLiquid"]) == (
        False, None)


def test_fill_defaults_to_water(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_1, {PLATE})")
    ok(kitchen, f"FillObjectWithLiquid(agent_1, {PLATE})")
    assert kitchen.obj(PLATE)["fillLiquid"] == "water"


def _xz(sim: Sim, object_id: str) -> tuple[float, float]:
    p = sim.obj(object_id)["position"]
    return p["x"], p["z"]


def _heading(sim: Sim, agent: int) -> tuple[float, float]:
    yaw = math.radians(sim.pose(agent)[2])
    return math.sin(yaw), math.cos(yaw)


def test_push_and_pull_move_the_object_along_the_agent_heading(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_1, {MUG})")
    heading = _heading(kitchen, 0)
    x0, z0 = _xz(kitchen, MUG)
    push = ok(kitchen, f"PushObject(agent_1, {MUG})")
    assert push.native_trace[0]["action"]["moveMagnitude"] == 150.0
    x1, z1 = _xz(kitchen, MUG)
    # default magnitude 150 moves it 0.1 m away from the agent
    assert (x1 - x0, z1 - z0) == pytest.approx((0.1 * heading[0], 0.1 * heading[1]), abs=1e-9)
    ok(kitchen, f"Find(agent_1, {MUG})")  # the push may have moved it out of view
    heading = _heading(kitchen, 0)
    pull = ok(kitchen, f"PullObject(agent_1, {MUG}, 300)")
    assert pull.native_trace[0]["action"]["moveMagnitude"] == 300.0
    x2, z2 = _xz(kitchen, MUG)
    assert (x2 - x1, z2 - z1) == pytest.approx((-0.2 * heading[0], -0.2 * heading[1]),
                                               abs=1e-9)


def test_break_object(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_1, {PLATE})")
    ok(kitchen, f"BreakObject(agent_1, {PLATE})")
    assert kitchen.obj(PLATE)["isBroken"] is True


# -- refusals (executor side: no native action is issued) -----------------------------------

def test_pickup_of_an_object_held_by_another_agent(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {KNIFE})")
    refused(kitchen, f"PickUp(agent_2, {KNIFE})",
            "Knife|+00.50|+00.95|-00.50 is already held by another agent")
    assert [o["objectId"] for o in kitchen.md(0)["inventoryObjects"]] == [KNIFE]


def test_put_with_empty_hands(kitchen: Sim) -> None:
    result = refused(kitchen, f"Put(agent_1, {PLATE})", "Agent is not holding any object")
    assert result.args == {"receptacleId": PLATE}  # the reference records no held object


def test_put_into_a_closed_receptacle(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    refused(kitchen, f"Put(agent_1, {DRAWER_A})",
            "Drawer|-01.00|+00.60|-01.00 is closed; Open it first")
    refused(kitchen, f"Put(agent_1, {FRIDGE})",
            "Fridge|-01.50|+00.00|+01.00 is closed; Open it first")
    assert [o["objectId"] for o in kitchen.md(0)["inventoryObjects"]] == [TOMATO]
    ok(kitchen, f"Open(agent_1, {DRAWER_A})")
    ok(kitchen, f"Put(agent_1, {DRAWER_A})")
    assert kitchen.obj(TOMATO)["parentReceptacles"] == [DRAWER_A]


def test_slice_without_a_knife(kitchen: Sim) -> None:
    ok(kitchen, f"Find(agent_1, {TOMATO})")
    refused(kitchen, f"Slice(agent_1, {TOMATO})",
            "Agent must hold a Knife or ButterKnife to slice")


@pytest.mark.parametrize(("held", "message"), [
    # the reference names the held object by its id (which starts with its type)
    (TOMATO, "Agent is holding Tomato|+00.50|+00.95|+00.20, not a Knife/ButterKnife"),
    (MUG, "Agent is holding Mug|-00.50|+00.95|-00.50, not a Knife/ButterKnife"),
])
def test_slice_holding_something_else(kitchen: Sim, held: str, message: str) -> None:
    ok(kitchen, f"PickUp(agent_1, {held})")
    refused(kitchen, f"Slice(agent_1, {TOMATO})", message)


def test_the_executor_implements_exactly_the_skills_task_checks_accept() -> None:
    assert tuple(SKILLS) == SKILL_NAMES


def test_unsupported_skill(kitchen: Sim) -> None:
    result = refused(kitchen, f"Fly(agent_1, {TOMATO})", "Unsupported skill: Fly")
    assert result.skill == "Fly" and result.agent == "agent_1"


def test_unknown_explore_direction(kitchen: Sim) -> None:
    result = refused(kitchen, "Explore(agent_1, upwards)", "Unsupported direction: upwards")
    assert result.args == {"direction": "upwards"}


@pytest.mark.parametrize(("call", "message"), [
    (f"PickUp(agent_1, {COUNTER})",
     "Object CounterTop|+01.00|+00.90|+00.00 does not satisfy affordance: pickupable"),
    (f"Open(agent_1, {COUNTER})",
     "Object CounterTop|+01.00|+00.90|+00.00 does not satisfy affordance: openable"),
    (f"Close(agent_1, {PLATE})",
     "Object Plate|+00.00|+00.95|+01.00 does not satisfy affordance: openable"),
    (f"ToggleOn(agent_1, {COUNTER})",
     "Object CounterTop|+01.00|+00.90|+00.00 does not satisfy affordance: toggleable"),
    (f"ToggleOff(agent_1, {FRIDGE})",
     "Object Fridge|-01.50|+00.00|+01.00 does not satisfy affordance: toggleable"),
    (f"CleanObject(agent_1, {LIGHT})",
     "Object LightSwitch|+02.00|+01.30|+01.50 does not satisfy affordance: dirtyable"),
    (f"BreakObject(agent_1, {COUNTER})",
     "Object CounterTop|+01.00|+00.90|+00.00 does not satisfy affordance: breakable"),
])
def test_affordance_refusals(kitchen: Sim, call: str, message: str) -> None:
    refused(kitchen, call, message)


def test_put_on_a_non_receptacle(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    refused(kitchen, f"Put(agent_1, {LIGHT})",
            "Object LightSwitch|+02.00|+01.30|+01.50 does not satisfy affordance: receptacle")


def test_slice_a_non_sliceable_object(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {KNIFE})")
    refused(kitchen, f"Slice(agent_1, {PLATE})",
            "Object Plate|+00.00|+00.95|+01.00 does not satisfy affordance: sliceable")


MISSING = "Object not found in metadata: Apple|+09.00|+00.90|+09.00"


@pytest.mark.parametrize("skill", [
    "Find", "PickUp", "Open", "Close", "ToggleOn", "ToggleOff", "CleanObject",
    "FillObjectWithLiquid", "EmptyLiquidFromObject", "PushObject", "PullObject", "BreakObject",
])
def test_missing_object(kitchen: Sim, skill: str) -> None:
    refused(kitchen, f"{skill}(agent_1, {GHOST})", MISSING)


def test_put_on_a_missing_receptacle(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    refused(kitchen, f"Put(agent_1, {GHOST})", MISSING)


def test_slice_a_missing_object(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {KNIFE})")
    refused(kitchen, f"Slice(agent_1, {GHOST})", MISSING)


def test_unknown_agent_and_malformed_calls(kitchen: Sim) -> None:
    refused(kitchen, "Wait(agent_3)", "Unknown agent agent_3")
    assert kitchen.run("PickUp(agent_1)").errorMessage == "PickUp needs an object id"
    bad = kitchen.run("this is not a call")
    assert bad.success is False and "not a skill call" in bad.errorMessage


# -- visibility: non-forced skills need a Find, forced ones do not (reference QUIRK §4.2) ----

@pytest.mark.parametrize(("prepare", "skill", "target", "flag"), [
    ([], "ToggleOn", LIGHT, "isToggled"),
    ([f"PickUp(agent_1, {KNIFE})"], "Slice", TOMATO, "isSliced"),
])
def test_non_forced_skill_needs_the_object_in_view(
    kitchen: Sim, prepare: list[str], skill: str, target: str, flag: str
) -> None:
    for call in prepare:
        ok(kitchen, call)
    blind(kitchen, 0)
    result = kitchen.run(f"{skill}(agent_1, {target})")
    assert result.success is False
    assert result.errorMessage.startswith(f"{target} is not interactable")
    assert kitchen.obj(target)[flag] is False
    ok(kitchen, f"Find(agent_1, {target})")
    ok(kitchen, f"{skill}(agent_1, {target})")
    assert kitchen.obj(target)[flag] is True


def test_forced_skills_succeed_without_find(kitchen: Sim) -> None:
    blind(kitchen, 0)
    start = kitchen.pose(0)
    pick = ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    assert pick.native_trace[0]["action"] == {"action": "PickupObject", "agentId": 0,
                                              "objectId": TOMATO, "forceAction": True}
    ok(kitchen, f"Put(agent_1, {PLATE})")
    assert kitchen.obj(TOMATO)["parentReceptacles"] == [PLATE]
    ok(kitchen, f"Open(agent_1, {FRIDGE})")
    assert kitchen.obj(FRIDGE)["isOpen"] is True
    ok(kitchen, f"Close(agent_1, {FRIDGE})")
    assert kitchen.pose(0) == start  # nothing moved the agent


# -- engine refusals surface verbatim ---------------------------------------------------------

def test_full_receptacle_has_no_valid_positions(kitchen: Sim) -> None:
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    ok(kitchen, f"Put(agent_1, {MUG})")  # a Mug holds one object
    ok(kitchen, f"PickUp(agent_1, {KNIFE})")
    result = kitchen.run(f"Put(agent_1, {MUG})")
    assert result.success is False
    assert "No valid positions" in result.errorMessage
    assert [o["objectId"] for o in kitchen.md(0)["inventoryObjects"]] == [KNIFE]


def test_loaded_fridge_cannot_be_closed(kitchen: Sim) -> None:
    ok(kitchen, f"Open(agent_1, {FRIDGE})")
    ok(kitchen, f"PickUp(agent_1, {TOMATO})")
    ok(kitchen, f"Put(agent_1, {FRIDGE})")
    result = refused(kitchen, f"Close(agent_2, {FRIDGE})",
                     "Object failed to open/close successfully", native=True)
    assert result.native_trace[0]["action"]["forceAction"] is True
    assert kitchen.obj(FRIDGE)["isOpen"] is True


def test_native_trace_entries_carry_the_agent_id(kitchen: Sim) -> None:
    calls = [f"Find(agent_2, {MUG})", f"PickUp(agent_2, {MUG})", "Explore(agent_2, back)",
             "Drop(agent_2)", f"Find(agent_2, {KNIFE})"]
    for call in calls:
        result = kitchen.run(call)
        assert result.native_trace, call
        for entry in result.native_trace:
            assert set(entry) == {"action", "lastActionSuccess", "errorMessage"}
            assert entry["action"]["agentId"] == 1
            assert isinstance(entry["lastActionSuccess"], bool)
            assert isinstance(entry["errorMessage"], str)


def test_result_record(kitchen: Sim) -> None:
    record = ok(kitchen, f"PickUp(agent_1, {TOMATO})").to_dict()
    assert record == {
        "skill": "PickUp", "agent": "agent_1", "args": {"objectId": TOMATO}, "success": True,
        "errorMessage": "",
        "native_trace": [{"action": {"action": "PickupObject", "agentId": 0,
                                     "objectId": TOMATO, "forceAction": True},
                          "lastActionSuccess": True, "errorMessage": ""}],
    }

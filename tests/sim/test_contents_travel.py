"""Contents travel with their receptacle (issue 41), as in AI2-THOR: picked up, carried, put,
dropped and pushed together, positions following and parent links kept, seen where they are.
The three menu-only reproductions of the issue first, then one test per kind of move."""

from __future__ import annotations

import math

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.sim.embedded.world import World, within_bounds
from benchmark_adapter.tasks import TaskConfig, load_task, load_tasks
from tests.paths import SHARED_TASKS

BEDROOM = "C_D2__EmbBedroom21__load_in_order_3agent_seed0"  # init actions load the Box
KITCHEN = "C_D4__FloorPlan1__seed0"  # Tomato onto the Plate buffer
LIVING_ROOM = "C_D2__FloorPlan201__livingroom_seed2"  # KeyChain into the Box

needs_shared = pytest.mark.skipif(not SHARED_TASKS.is_dir(),
                                  reason=f"shared CoCoBench data not found at {SHARED_TASKS}")


def full_config(task_id: str) -> TaskConfig:
    return next(c for c in load_tasks("cocobench-full") if c.task_id == task_id)


def shared_config(task_id: str) -> TaskConfig:
    return load_task(SHARED_TASKS / f"{task_id}.json")


def episode(config: TaskConfig) -> Episode:
    ep = Episode(config)
    ep.reset()
    return ep


def world(ep: Episode) -> World:
    return ep.controller.world


def id_of(ep: Episode, object_type: str) -> str:
    return next(o.id for o in world(ep).objects.values() if o.type == object_type)


def play(ep: Episode, *calls: str) -> None:
    """Menu calls that must each be on the acting agent's menu and succeed."""
    for call in calls:
        assert call in {e.call for e in ep.observe().action_menu}, f"{call} is not on the menu"
        result = ep.step(call)
        assert result.success, f"{call}: {result.errorMessage}"


def record(ep: Episode, agent: int, object_id: str) -> dict:
    md = ep.controller.last_metadata()[agent]
    return next(o for o in md["objects"] if o["objectId"] == object_id)


def gap(ep: Episode, content: str, receptacle: str) -> float:
    a, b = world(ep).objects[content], world(ep).objects[receptacle]
    return math.hypot(a.x - b.x, a.z - b.z)


def assert_lies_in(ep: Episode, content: str, receptacle: str) -> None:
    w = world(ep)
    assert w.objects[content].parent == receptacle
    assert within_bounds(w.objects[content], w.objects[receptacle]), gap(ep, content, receptacle)
    w.check_containment()


# -- the menu-only reproductions --------------------------------------------------

def test_picking_up_the_preloaded_box_carries_its_alarm_clock() -> None:
    ep = episode(full_config(BEDROOM))
    box, clock = id_of(ep, "Box"), id_of(ep, "AlarmClock")
    assert world(ep).objects[clock].parent == box  # loaded by the init actions
    play(ep, f"PickUp(agent_2, {box})")
    assert_lies_in(ep, clock, box)  # was 2.66 m away
    assert gap(ep, clock, box) < 0.2
    holder = world(ep).agents[1]
    assert math.hypot(world(ep).objects[clock].x - holder.x,
                      world(ep).objects[clock].z - holder.z) < 0.2
    assert record(ep, 1, clock)["parentReceptacles"] == [box]
    assert not any(record(ep, i, clock)["visible"] for i in range(3))  # the Box is closed
    play(ep, f"Open(agent_2, {box})")
    assert record(ep, 1, clock)["visible"] is True  # in agent_2's hand
    assert record(ep, 0, clock)["visible"] is False  # in a teammate's hand


@needs_shared
def test_the_tomato_put_on_the_plate_buffer_goes_where_the_plate_goes() -> None:
    ep = episode(shared_config(KITCHEN))
    tomato, plate = id_of(ep, "Tomato"), id_of(ep, "Plate")
    play(ep, f"PickUp(agent_1, {tomato})", f"Put(agent_1, {plate})",
         f"PickUp(agent_1, {plate})")
    assert_lies_in(ep, tomato, plate)  # was 1.28 m away
    assert record(ep, 0, tomato)["parentReceptacles"] == [plate]
    # In the producer's hand it is seen by the producer only, and the consumer's Find does
    # not find it at the spot where it lay.
    assert record(ep, 0, tomato)["visible"] is True
    assert record(ep, 1, tomato)["visible"] is False
    assert ep.step(f"Find(agent_2, {tomato})").success is False


@needs_shared
def test_the_keychain_put_in_the_box_goes_where_the_box_goes() -> None:
    ep = episode(shared_config(LIVING_ROOM))
    box, keychain = id_of(ep, "Box"), id_of(ep, "KeyChain")
    play(ep, f"Open(agent_1, {box})", f"PickUp(agent_1, {keychain})", f"Put(agent_1, {box})",
         f"PickUp(agent_2, {box})")
    assert_lies_in(ep, keychain, box)  # was 1.96 m away
    assert record(ep, 1, keychain)["visible"] is True
    assert record(ep, 0, keychain)["visible"] is False


# -- each kind of move -----------------------------------------------------------------------

def native(ep: Episode, action: str, agent: int, **kwargs) -> dict:
    md = ep.controller.step(action, agentId=agent, **kwargs)[agent]
    assert md["lastActionSuccess"], md["errorMessage"]
    return md


def loaded_box() -> tuple[Episode, str, str]:
    """The bedroom's Box, loaded with its AlarmClock, in agent_2's hand."""
    ep = episode(full_config(BEDROOM))
    box, clock = id_of(ep, "Box"), id_of(ep, "AlarmClock")
    play(ep, f"PickUp(agent_2, {box})")
    return ep, box, clock


def test_carrying_the_box_carries_its_content() -> None:
    ep, box, clock = loaded_box()
    for x, z in ((-2.0, 0.5), (1.0, 1.0)):
        positions = native(ep, "GetReachablePositions", 1)["actionReturn"]
        pose = min(positions, key=lambda p: math.hypot(p["x"] - x, p["z"] - z))
        native(ep, "TeleportFull", 1, **pose, rotation=0, horizon=0, standing=True)
        assert_lies_in(ep, clock, box)
    ep.step("Explore(agent_2, forward)")
    assert_lies_in(ep, clock, box)


def test_dropping_the_box_drops_its_content_with_it() -> None:
    ep, box, clock = loaded_box()
    native(ep, "DropHandObject", 1, forceAction=True)
    assert world(ep).objects[box].y == 0.0
    assert_lies_in(ep, clock, box)
    assert record(ep, 0, clock)["parentReceptacles"] == [box]


@needs_shared
def test_putting_the_plate_away_puts_its_tomato_with_it() -> None:
    ep = episode(shared_config(KITCHEN))
    tomato, plate, fridge = id_of(ep, "Tomato"), id_of(ep, "Plate"), id_of(ep, "Fridge")
    play(ep, f"PickUp(agent_1, {tomato})", f"Put(agent_1, {plate})",
         f"PickUp(agent_1, {plate})")
    if not world(ep).objects[fridge].is_open:
        native(ep, "OpenObject", 0, objectId=fridge, forceAction=True)
    native(ep, "PutObject", 0, objectId=fridge, forceAction=True)
    assert world(ep).objects[plate].parent == fridge
    assert_lies_in(ep, tomato, plate)
    assert record(ep, 1, tomato)["parentReceptacles"] == [plate, fridge]


def test_pushing_the_box_pushes_its_content_with_it() -> None:
    ep, box, clock = loaded_box()
    native(ep, "DropHandObject", 1, forceAction=True)
    before = world(ep).objects[box].x, world(ep).objects[box].z
    native(ep, "PushObject", 1, objectId=box, moveMagnitude=300.0, forceAction=True)
    native(ep, "PullObject", 1, objectId=box, moveMagnitude=100.0, forceAction=True)
    assert (world(ep).objects[box].x, world(ep).objects[box].z) != before
    assert_lies_in(ep, clock, box)


def test_closing_the_carried_box_hides_its_content_even_from_its_holder() -> None:
    ep, box, clock = loaded_box()
    native(ep, "OpenObject", 1, objectId=box, forceAction=True)
    assert record(ep, 1, clock)["visible"] is True
    native(ep, "CloseObject", 1, objectId=box, forceAction=True)
    assert record(ep, 1, clock)["visible"] is False
    native(ep, "DropHandObject", 1, forceAction=True)
    native(ep, "OpenObject", 1, objectId=box, forceAction=True)
    # Opened where it was dropped, in front of agent_2: the content is there with it.
    assert_lies_in(ep, clock, box)

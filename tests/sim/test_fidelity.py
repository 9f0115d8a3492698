"""The embedded world's fidelity rules of issue 41 beyond carried contents: numbers are finite
and bounded where they enter (a refused action, never an exception, never stored); pushes
re-parent what they push off and carry what lies in what they push; a sliced source is
disabled; slicing what one holds is refused; capacity counts pieces."""

from __future__ import annotations

import copy
import math
import re

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.invariants import state
from benchmark_adapter.sim.embedded import EmbeddedController, ThorCompatController
from benchmark_adapter.tasks import TaskConfig, load_task
from benchmark_adapter.trajectory import dumps
from tests.paths import SHARED_TASKS
from tests.sim.test_containment import KNIFE, MUG, PLATE, TOMATO, act, controller, put_into

COUNTER = "CounterTop|+00.00|+00.00|+01.00"
POTATO = "Potato|+00.40|+00.95|+00.90"


# -- numbers ----------------------------------------------------------------------------------

BAD_NUMBERS = [
    ("MoveAhead", {"moveMagnitude": 1e308}, "is not a reachable position"),
    ("MoveAhead", {"moveMagnitude": math.inf}, "moveMagnitude must be a finite number"),
    ("MoveBack", {"moveMagnitude": math.nan}, "moveMagnitude must be a finite number"),
    ("MoveLeft", {"moveMagnitude": -0.25}, "moveMagnitude must be > 0"),
    ("TeleportFull", {"x": math.inf, "y": 0.9, "z": 0.0, "standing": True},
     "x must be a finite number"),
    ("TeleportFull", {"x": 1e308, "y": 0.9, "z": 1e308, "standing": True},
     "is not a reachable position"),
    ("TeleportFull", {"x": 0.0, "y": 0.9, "z": 0.0, "rotation": {"y": math.nan},
                      "standing": True}, "rotation must be a finite number"),
    ("TeleportFull", {"x": 0.0, "y": 0.9, "z": 0.0, "horizon": math.inf, "standing": True},
     "horizon must be a finite number"),
    ("PushObject", {"objectId": MUG, "moveMagnitude": math.nan, "forceAction": True},
     "moveMagnitude must be a finite number"),
    ("PullObject", {"objectId": MUG, "moveMagnitude": -1e6, "forceAction": True},
     "moveMagnitude must be > 0"),
    ("RotateRight", {"degrees": math.inf}, "degrees must be a finite number"),
    ("LookDown", {"degrees": math.nan}, "degrees must be a finite number"),
]


@pytest.mark.parametrize(("action", "kwargs", "message"), BAD_NUMBERS,
                         ids=[f"{a}-{next(iter(k.values()))}" for a, k, _ in BAD_NUMBERS])
def test_a_bad_number_is_a_refused_action_that_changes_nothing(action, kwargs, message) -> None:
    ctl = controller()
    before = state(ctl.world)
    md = ctl.step(action, agentId=0, **kwargs)[0]
    assert md["lastActionSuccess"] is False
    assert message in md["errorMessage"]
    assert state(ctl.world) == before
    ctl.world.check_containment()  # positions finite too


@pytest.mark.parametrize(("action", "kwargs", "message"), BAD_NUMBERS[:4] + BAD_NUMBERS[8:])
def test_thor_compat_reports_a_bad_number_as_a_failed_event(action, kwargs, message) -> None:
    config = controller().config
    with ThorCompatController(config) as thor:
        event = thor.step(dict(action=action, agentId=0, **kwargs))
        assert event.events[0].metadata["lastActionSuccess"] is False
        assert message in event.events[0].metadata["errorMessage"]
        assert event.events[0].frame.shape == (300, 300, 3)  # renders: no NaN yaw


def test_a_non_finite_push_never_reaches_the_trajectory() -> None:
    ctl = controller()
    ep = Episode(ctl.config, ctl)
    ep.reset()
    result = ep.step(f"PushObject(agent_1, {MUG}, nan)")
    assert result.success is False and "finite" in result.errorMessage
    text = dumps(ep.finish())
    assert "NaN" not in text and "Infinity" not in text
    assert all(e["action"].get("moveMagnitude") is None for e in result.native_trace)


# -- pushing --------------------------------------------------------------------------------

def loaded_counter() -> EmbeddedController:
    """The Plate on a CounterTop, the Mug on the Plate."""
    ctl = controller()
    counter = copy.deepcopy(ctl.config.model_dump())
    counter["init_state"]["objects"]["counter"] = COUNTER
    ctl = EmbeddedController(TaskConfig.model_validate(counter))
    ctl.reset()
    put_into(ctl, PLATE, COUNTER)
    put_into(ctl, MUG, PLATE)
    return ctl


def test_a_pushed_receptacle_carries_its_contents() -> None:
    ctl = loaded_counter()
    mug, plate = ctl.world.objects[MUG], ctl.world.objects[PLATE]
    offset = (mug.x - plate.x, mug.z - plate.z)
    assert act(ctl, "PushObject", objectId=PLATE, moveMagnitude=150.0)["lastActionSuccess"]
    assert (mug.x - plate.x, mug.z - plate.z) == pytest.approx(offset)
    assert mug.parent == PLATE
    ctl.world.check_containment()


def test_an_object_pushed_off_its_receptacle_leaves_it() -> None:
    ctl = loaded_counter()
    mug, plate, counter = (ctl.world.objects[i] for i in (MUG, PLATE, COUNTER))
    parents, heights = [], []
    for _ in range(4):  # 0.25 m a push (the most one moves): off the Plate, then the counter
        assert act(ctl, "PushObject", objectId=MUG, moveMagnitude=1e6)["lastActionSuccess"]
        parents.append(mug.parent)
        heights.append(mug.y)
        ctl.world.check_containment()
    assert parents == [PLATE, COUNTER, None, None]
    assert heights[1] == counter.y + counter.aff.height and heights[2] == 0.0
    assert MUG not in plate.contents and MUG not in counter.contents


def test_what_lies_in_a_hand_cannot_be_pushed() -> None:
    ctl = loaded_counter()
    assert act(ctl, "PickupObject", objectId=PLATE)["lastActionSuccess"]
    md = act(ctl, "PushObject", 1, objectId=MUG, moveMagnitude=150.0)
    assert md["lastActionSuccess"] is False and "is held" in md["errorMessage"]


# -- slicing --------------------------------------------------------------------------------

def sliced_on_the_plate() -> EmbeddedController:
    ctl = controller()
    put_into(ctl, TOMATO, PLATE)
    assert act(ctl, "SliceObject", objectId=TOMATO)["lastActionSuccess"]
    return ctl


def test_a_sliced_source_is_disabled() -> None:
    ctl = sliced_on_the_plate()
    md = ctl.last_metadata()
    for agent in range(2):
        record = next(o for o in md[agent]["objects"] if o["objectId"] == TOMATO)
        assert record["visible"] is False and record["isSliced"] is True
    plate = next(o for o in md[0]["objects"] if o["objectId"] == PLATE)
    assert TOMATO not in plate["receptacleObjectIds"]
    assert len(plate["receptacleObjectIds"]) == 3  # its three pieces
    refused = act(ctl, "PickupObject", 1, objectId=TOMATO)
    assert refused["lastActionSuccess"] is False
    assert "it was sliced into pieces" in refused["errorMessage"]
    assert ctl.step("GetInteractablePoses", agentId=0, objectId=TOMATO)[0]["actionReturn"] == []
    ctl.world.check_containment()


def test_capacity_counts_pieces() -> None:
    ctl = sliced_on_the_plate()  # a Plate holds 3: its three pieces fill it
    assert act(ctl, "PickupObject", objectId=MUG)["lastActionSuccess"]
    md = act(ctl, "PutObject", objectId=PLATE)
    assert md["errorMessage"] == "No valid positions to place object found"
    piece = ctl.world.objects[PLATE].contents[0]
    assert act(ctl, "PickupObject", 1, objectId=piece)["lastActionSuccess"]
    assert act(ctl, "PutObject", objectId=PLATE)["lastActionSuccess"]


def test_slicing_what_one_holds_is_refused() -> None:
    ctl = controller()
    assert act(ctl, "PickupObject", objectId=TOMATO)["lastActionSuccess"]
    before = state(ctl.world)
    md = act(ctl, "SliceObject", objectId=TOMATO)
    assert md["lastActionSuccess"] is False
    assert md["errorMessage"] == f"{TOMATO} is held by agent_1: put it down before slicing it"
    assert state(ctl.world) == before


def test_a_piece_sliced_in_a_carried_plate_travels_with_it() -> None:
    ctl = controller()
    put_into(ctl, TOMATO, PLATE)
    assert act(ctl, "PickupObject", objectId=PLATE)["lastActionSuccess"]
    assert act(ctl, "SliceObject", 1, objectId=TOMATO)["lastActionSuccess"]
    assert act(ctl, "DropHandObject")["lastActionSuccess"]
    ctl.world.check_containment()
    assert all(ctl.world.objects[p].parent == PLATE for p in ctl.world.objects[PLATE].contents)
    assert KNIFE in ctl.world.objects  # untouched


@pytest.mark.skipif(not SHARED_TASKS.is_dir(), reason="shared CoCoBench data not found")
def test_the_issue_s_plate_holds_at_most_its_capacity_after_slicing() -> None:
    config = load_task(SHARED_TASKS / "C_D4__FloorPlan1__seed0.json")
    ctl = EmbeddedController(config)
    ctl.reset()
    tomato = next(o.id for o in ctl.world.objects.values() if o.type == "Tomato")
    plate = next(o.id for o in ctl.world.objects.values() if o.type == "Plate")
    put_into(ctl, tomato, plate)
    assert act(ctl, "SliceObject", objectId=tomato)["lastActionSuccess"]
    assert len(ctl.world.objects[plate].contents) == 3  # was 4: the source and its pieces


# -- positions from a task config's ids -------------------------------------------------------

@pytest.mark.parametrize("position", ["+3000.00|+00.90|+00.00", "+00.00|+00.90|-300.00",
                                      "nan|+00.90|+00.00", "+00.00|inf|+00.00"])
def test_an_object_id_placed_beyond_any_scene_is_refused_at_reset(position: str) -> None:
    """The floor grid spans every object: one id 3 km out took minutes and gigabytes to
    ground (300 m: 14 s, 290 MB), a NaN or infinite one raised from inside the grid."""
    config = copy.deepcopy(controller().config.model_dump())
    config["init_state"]["objects"]["far"] = far = f"Apple|{position}"
    ctl = EmbeddedController(TaskConfig.model_validate(config))
    with pytest.raises(ValueError, match=rf"^{re.escape(far)} lies at .*: not within 50 m "
                                         "of the scene's origin$"):
        ctl.reset()

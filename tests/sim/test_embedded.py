"""Native rules of the embedded simulator: collisions, visibility distance, one holder per
object, closed receptacles, immutable metadata snapshots, determinism."""

from __future__ import annotations

import pytest

from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.tasks import TaskConfig

LIGHT = "LightSwitch|+02.00|+01.30|+01.50"
DRAWER = "Drawer|-01.00|+00.60|-01.00"
TOMATO = "Tomato|+00.50|+00.95|+00.20"
MUG = "Mug|-00.50|+00.95|-00.50"
PLATE = "Plate|+00.00|+00.95|+01.00"


def config(visibility: float = 1.5, agents: int = 2) -> TaskConfig:
    objects = {"light": LIGHT, "drawer": DRAWER, "tomato": TOMATO, "mug": MUG, "plate": PLATE}
    return TaskConfig.model_validate({
        "task_id": "X_D1__EmbeddedRules__seed0", "coordination_dim": "D1", "task_family": "X",
        "task_name": "embedded_rules", "scene_id": "EmbeddedRules", "agent_count": agents,
        "agents": [{"id": f"agent_{i + 1}"} for i in range(agents)],
        "init_state": {"controller_init": {"scene": "EmbeddedRules", "agentCount": agents,
                                           "visibilityDistance": visibility},
                       "objects": objects},
    })


def controller(visibility: float = 1.5, agents: int = 2) -> EmbeddedController:
    ctl = EmbeddedController(config(visibility, agents))
    ctl.reset()
    return ctl


def teleport(ctl: EmbeddedController, agent: int, x: float, z: float, yaw: float = 0.0,
             horizon: float = 0.0, *, expect: bool | None = True):
    """TeleportFull; by default the teleport must succeed (None: either way)."""
    md = ctl.step("TeleportFull", agentId=agent, x=x, y=0.9, z=z, rotation={"y": yaw},
                  horizon=horizon, standing=True)
    if expect is not None:
        assert md[agent]["lastActionSuccess"] is expect, md[agent]["errorMessage"]
    return md


def obj(md, object_id: str) -> dict:
    return next(o for o in md["objects"] if o["objectId"] == object_id)


# -- teleport and collisions ------------------------------------------------------------------

def test_teleport_moves_the_agent() -> None:
    ctl = controller()
    teleport(ctl, 1, -2.0, -2.0)
    md = teleport(ctl, 0, 0.0, -2.0, 90.0, 30.0)
    assert md[0]["lastActionSuccess"] is True and md[0]["errorMessage"] == ""
    agent = md[0]["agent"]
    assert (agent["position"]["x"], agent["position"]["z"]) == (0.0, -2.0)
    assert (agent["rotation"]["y"], agent["cameraHorizon"]) == (90.0, 30.0)


@pytest.mark.parametrize(("dx", "dz"), [(0.0, 0.0), (0.25, 0.0), (0.25, 0.25)])
def test_teleport_onto_an_occupied_spot_fails(dx: float, dz: float) -> None:
    ctl = controller()
    teleport(ctl, 1, 0.0, -2.0)
    teleport(ctl, 0, 2.0, -2.0)
    md = teleport(ctl, 0, 0.0 + dx, -2.0 + dz, expect=False)
    assert md[0]["lastActionSuccess"] is False
    assert "agent_2" in md[0]["errorMessage"]
    assert md[0]["agent"]["position"]["x"] == 2.0  # did not move


def test_teleport_half_a_metre_from_a_teammate_is_fine() -> None:
    ctl = controller()
    teleport(ctl, 1, 0.0, -2.0)
    assert teleport(ctl, 0, 0.5, -2.0)[0]["lastActionSuccess"] is True


def test_moving_into_a_teammate_fails() -> None:
    ctl = controller()
    teleport(ctl, 1, 0.0, -1.25)
    teleport(ctl, 0, 0.0, -2.0, 0.0)
    assert ctl.step("MoveAhead", agentId=0, moveMagnitude=0.25)[0]["lastActionSuccess"] is True
    md = ctl.step("MoveAhead", agentId=0, moveMagnitude=0.25)
    assert md[0]["lastActionSuccess"] is False
    assert "agent_2" in md[0]["errorMessage"]
    assert md[0]["agent"]["position"]["z"] == -1.75


def test_teleport_off_the_floor_or_off_grid_fails() -> None:
    ctl = controller()
    teleport(ctl, 0, 100.0, 100.0, expect=False)
    teleport(ctl, 0, 0.1, -2.0, expect=False)


def test_teleport_needs_standing() -> None:
    ctl = controller()
    md = ctl.step("TeleportFull", agentId=0, x=0.0, y=0.9, z=-2.0, rotation=0, horizon=0)
    assert md[0]["lastActionSuccess"] is False
    assert "standing" in md[0]["errorMessage"]


# -- visibility ---------------------------------------------------------------------------------

def test_non_forced_actions_need_the_object_within_visibility_distance() -> None:
    ctl = controller(visibility=1.5)
    teleport(ctl, 1, -2.0, -2.0)
    # the switch is at (2.0, 1.5): 1.75 m straight ahead of (2.0, -0.25)
    md = teleport(ctl, 0, 2.0, -0.25, 0.0)
    assert obj(md[0], LIGHT)["visible"] is False
    md = ctl.step("ToggleObjectOn", agentId=0, objectId=LIGHT)
    assert md[0]["lastActionSuccess"] is False
    assert md[0]["errorMessage"].startswith(f"{LIGHT} is not interactable")
    assert obj(md[0], LIGHT)["isToggled"] is False
    # forced, it works from anywhere
    md = ctl.step("ToggleObjectOn", agentId=0, objectId=LIGHT, forceAction=True)
    assert md[0]["lastActionSuccess"] is True
    # 1.25 m away it is in reach
    md = teleport(ctl, 0, 2.0, 0.25, 0.0)
    assert obj(md[0], LIGHT)["visible"] is True
    assert ctl.step("ToggleObjectOff", agentId=0, objectId=LIGHT)[0]["lastActionSuccess"]


def test_visibility_distance_comes_from_the_config() -> None:
    ctl = controller(visibility=2.0)
    teleport(ctl, 1, -2.0, -2.0)
    md = teleport(ctl, 0, 2.0, -0.25, 0.0)
    assert obj(md[0], LIGHT)["visible"] is True
    assert ctl.step("ToggleObjectOn", agentId=0, objectId=LIGHT)[0]["lastActionSuccess"]


def test_facing_away_hides_the_object() -> None:
    ctl = controller()
    teleport(ctl, 1, -2.0, -2.0)
    md = teleport(ctl, 0, 2.0, 0.25, 180.0)
    assert obj(md[0], LIGHT)["visible"] is False


def test_visibility_is_per_agent() -> None:
    ctl = controller()
    teleport(ctl, 1, -2.0, -2.0, 180.0)
    md = teleport(ctl, 0, 2.0, 0.25, 0.0)
    assert obj(md[0], LIGHT)["visible"] is True
    assert obj(md[1], LIGHT)["visible"] is False


# -- holding ----------------------------------------------------------------------------------

def test_one_holder_per_object() -> None:
    ctl = controller()
    md = ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    assert md[0]["lastActionSuccess"] is True
    assert md[0]["inventoryObjects"] == [{"objectId": TOMATO, "objectType": "Tomato"}]
    md = ctl.step("PickupObject", agentId=1, objectId=TOMATO, forceAction=True)
    assert md[1]["lastActionSuccess"] is False
    assert "agent_1" in md[1]["errorMessage"]
    assert md[1]["inventoryObjects"] == []
    assert md[0]["inventoryObjects"] == [{"objectId": TOMATO, "objectType": "Tomato"}]
    assert obj(md[1], TOMATO)["isPickedUp"] is True
    assert obj(md[0], TOMATO)["visible"] is True  # the holder sees what it holds …
    assert obj(md[1], TOMATO)["visible"] is False  # … nobody else does


def test_one_object_per_hand() -> None:
    ctl = controller()
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    md = ctl.step("PickupObject", agentId=0, objectId=MUG, forceAction=True)
    assert md[0]["lastActionSuccess"] is False
    assert [o["objectId"] for o in md[0]["inventoryObjects"]] == [TOMATO]


def test_drop_releases_the_object() -> None:
    ctl = controller()
    ctl.step("PickupObject", agentId=1, objectId=MUG, forceAction=True)
    md = ctl.step("DropHandObject", agentId=1, forceAction=True)
    assert md[1]["lastActionSuccess"] is True and md[1]["inventoryObjects"] == []
    assert ctl.step("PickupObject", agentId=0, objectId=MUG,
                    forceAction=True)[0]["lastActionSuccess"] is True


# -- receptacles --------------------------------------------------------------------------------

def test_closed_openable_refuses_placement_even_forced() -> None:
    ctl = controller()
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    md = ctl.step("PutObject", agentId=0, objectId=DRAWER, forceAction=True,
                  placeStationary=True)
    assert md[0]["lastActionSuccess"] is False
    assert DRAWER in md[0]["errorMessage"] and "closed" in md[0]["errorMessage"]
    assert [o["objectId"] for o in md[0]["inventoryObjects"]] == [TOMATO]
    ctl.step("OpenObject", agentId=0, objectId=DRAWER, forceAction=True)
    md = ctl.step("PutObject", agentId=0, objectId=DRAWER, forceAction=True,
                  placeStationary=True)
    assert md[0]["lastActionSuccess"] is True
    assert obj(md[0], TOMATO)["parentReceptacles"] == [DRAWER]
    assert obj(md[0], DRAWER)["receptacleObjectIds"] == [TOMATO]


def test_objects_in_a_closed_container_are_hidden_and_cannot_be_taken() -> None:
    ctl = controller()
    ctl.step("OpenObject", agentId=0, objectId=DRAWER, forceAction=True)
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    ctl.step("PutObject", agentId=0, objectId=DRAWER, forceAction=True)
    ctl.step("CloseObject", agentId=0, objectId=DRAWER, forceAction=True)
    md = ctl.step("PickupObject", agentId=1, objectId=TOMATO, forceAction=True)
    assert md[1]["lastActionSuccess"] is False
    assert all(not obj(m, TOMATO)["visible"] for m in md)


def test_put_on_a_non_receptacle_fails() -> None:
    ctl = controller()
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    md = ctl.step("PutObject", agentId=0, objectId=LIGHT, forceAction=True)
    assert md[0]["lastActionSuccess"] is False


# -- metadata snapshots -------------------------------------------------------------------------

def test_metadata_snapshot_is_not_changed_by_later_steps() -> None:
    ctl = controller()
    before = ctl.step("Pass", agentId=0)  # objects not read yet (built lazily)
    read_early = ctl.last_metadata()
    early_objects = read_early[0]["objects"]
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    teleport(ctl, 1, -2.0, -2.0, 180.0)
    ctl.step("OpenObject", agentId=1, objectId=DRAWER, forceAction=True)
    assert before[0]["inventoryObjects"] == []
    assert before[0]["lastAction"] == "Pass"
    assert obj(before[0], TOMATO)["isPickedUp"] is False
    assert obj(before[1], DRAWER)["isOpen"] is False
    assert obj(read_early[0], TOMATO)["isPickedUp"] is False
    assert obj({"objects": early_objects}, DRAWER)["isOpen"] is False
    now = ctl.last_metadata()
    assert obj(now[0], TOMATO)["isPickedUp"] is True
    assert obj(now[1], DRAWER)["isOpen"] is True
    assert now[1]["agent"]["position"] == {"x": -2.0, "y": 0.9, "z": -2.0}
    assert before[1]["agent"]["position"] != now[1]["agent"]["position"]


def test_metadata_has_the_ai2thor_keys() -> None:
    md = controller().step("Pass", agentId=1)
    assert len(md) == 2
    for key in ("agent", "objects", "inventoryObjects", "lastActionSuccess", "errorMessage",
                "actionReturn"):
        assert key in md[1]
    assert md[1]["agent"]["name"] == "agent_2"
    assert md[0]["agent"]["name"] == "agent_1"


def test_unknown_action_fails() -> None:
    md = controller().step("Levitate", agentId=0)
    assert md[0]["lastActionSuccess"] is False
    assert "Levitate" in md[0]["errorMessage"]


def test_agent_id_out_of_range_and_step_before_reset() -> None:
    ctl = controller()
    with pytest.raises(ValueError):
        ctl.step("Pass", agentId=2)
    with pytest.raises(RuntimeError):
        EmbeddedController(config()).step("Pass", agentId=0)


def test_same_calls_same_metadata() -> None:
    def trace() -> list:
        ctl = controller(agents=3)
        out = [dict(m) for m in ctl.last_metadata()]
        for action, kw in [("PickupObject", {"objectId": MUG, "forceAction": True}),
                           ("MoveAhead", {}), ("RotateLeft", {}),
                           ("DropHandObject", {"forceAction": True})]:
            out += [dict(m) for m in ctl.step(action, agentId=0, **kw)]
        return out
    assert trace() == trace()


def test_reset_restores_the_initial_world() -> None:
    ctl = controller()
    first = [dict(m) for m in ctl.last_metadata()]
    ctl.step("PickupObject", agentId=0, objectId=TOMATO, forceAction=True)
    teleport(ctl, 1, -2.0, -2.0)
    second = [dict(m) for m in ctl.reset()]
    assert second == first


def test_frame_is_a_png_of_at_least_300_pixels() -> None:
    png = controller().frame(1)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert width >= 300 and height >= 300

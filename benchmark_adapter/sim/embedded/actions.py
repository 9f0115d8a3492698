"""Native actions of the embedded simulator, with AI2-THOR's rules and error wording.

Each handler either returns the action's `actionReturn` or raises `ActionFailed` with the
error message AI2-THOR would give; the controller turns that into per-agent metadata.
`forceAction` skips the visibility requirement, as in AI2-THOR (reference §4.2).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

from benchmark_adapter.sim.embedded.affordances import affordances_of, slice_pieces
from benchmark_adapter.sim.embedded.vision import enclosed, interactable_poses, visible
from benchmark_adapter.sim.embedded.world import (
    AGENT_Y,
    GRID,
    SLOT_SPACING,
    SimAgent,
    SimObject,
    World,
    within_bounds,
)

MIN_HORIZON, MAX_HORIZON = -30.0, 60.0


class ActionFailed(Exception):
    """A native action the simulator refuses; the message is AI2-THOR's `errorMessage`."""


Handler = Callable[[World, SimAgent, dict[str, Any]], Any]


def _target(world: World, kw: dict[str, Any]) -> SimObject:
    oid = kw.get("objectId")
    if not isinstance(oid, str) or oid not in world.objects:
        raise ActionFailed(f"Object ID appears to be invalid: {oid!r}")
    return world.objects[oid]


def _reachable_target(world: World, agent: SimAgent, kw: dict[str, Any]) -> SimObject:
    """The target object, which a non-forced action must see from where the agent stands."""
    obj = _target(world, kw)
    if not kw.get("forceAction") and not visible(world, agent, obj):
        raise ActionFailed(
            f"{obj.id} is not interactable and (perhaps it is occluded by "
            "something or too far away)."
        )
    return obj


def _require(flag: bool, message: str) -> None:
    if not flag:
        raise ActionFailed(message)


def _finite(kw: dict[str, Any], name: str, default: float) -> float:
    """The number argument `name` (or `default`), refused unless finite: a NaN or infinite
    magnitude, degree or coordinate must fail the action, never reach the world's state."""
    value = float(kw.get(name, default))  # a TypeError or ValueError: invalid arguments
    if not math.isfinite(value):
        raise ActionFailed(f"{name} must be a finite number, got {value}")
    return value


def _positive(kw: dict[str, Any], name: str, default: float) -> float:
    """A finite `name` > 0, with AI2-THOR's wording for one that is not."""
    value = _finite(kw, name, default)
    _require(value > 0, f"{name} must be > 0")
    return value


def _not_disabled(obj: SimObject) -> None:
    """Refuse a sliced source: AI2-THOR keeps it in the metadata but disables it (no
    colliders, not visible), its pieces taking its place."""
    _require(not obj.is_sliced, f"{obj.id} is not interactable: it was sliced into pieces")


def _detach(world: World, obj: SimObject) -> None:
    if obj.parent is not None:
        world.objects[obj.parent].contents.remove(obj.id)
        obj.parent = None


def move_with_contents(world: World, obj: SimObject, x: float, y: float, z: float) -> None:
    """Put `obj` at (x, y, z), everything that lies in it moving along: as in AI2-THOR,
    contents travel with their receptacle, keeping their place in it."""
    dx, dy, dz = x - obj.x, y - obj.y, z - obj.z
    obj.x, obj.y, obj.z = x, y, z
    if dx or dy or dz:
        for content in world.descendants(obj):
            content.x, content.y, content.z = content.x + dx, content.y + dy, content.z + dz


def _attach(world: World, obj: SimObject, receptacle: SimObject) -> None:
    slot = len(receptacle.contents)
    receptacle.contents.append(obj.id)
    obj.parent = receptacle.id
    move_with_contents(
        world,
        obj,
        receptacle.x + SLOT_SPACING * (slot % 3 - 1),
        receptacle.y + receptacle.aff.height,
        receptacle.z + SLOT_SPACING * (slot // 3),
    )


def _room_left(receptacle: SimObject) -> int:
    """Free places of `receptacle`: its capacity less what lies in it (a sliced source has
    left it, `slice_object`; its pieces each occupy one)."""
    return receptacle.aff.capacity - len(receptacle.contents)


def sync_held(world: World, agent: SimAgent) -> None:
    """Carry the held object, and whatever lies in it, along with the agent."""
    if agent.held is not None:
        move_with_contents(world, world.objects[agent.held], agent.x, 1.0, agent.z)


# -- object interaction -------------------------------------------------------------------


def pickup(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(
        agent.held is None, "Agent hand has something in it already! Can't pick up anything else"
    )
    _require(obj.aff.pickupable, f"{obj.id} is not pickupable")
    _not_disabled(obj)
    if obj.held_by is not None:
        raise ActionFailed(f"{obj.id} is already picked up by agent_{obj.held_by + 1}")
    _require(not enclosed(world, obj), f"{obj.id} is inside a closed receptacle")
    _detach(world, obj)
    obj.held_by, agent.held = agent.index, obj.id
    sync_held(world, agent)


def put(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    _require(agent.held is not None, "Agent is not holding any object")
    receptacle = _reachable_target(world, agent, kw)
    held = world.objects[agent.held]
    _require(receptacle.aff.receptacle, f"{receptacle.id} is not a receptacle")
    _require(receptacle.id != held.id, f"Cannot place {held.id} in itself")
    _require(
        not (receptacle.aff.openable and not receptacle.is_open),
        f"Target receptacle {receptacle.id} is closed",
    )
    # In AI2-THOR a held receptacle's contents travel in the hand with it, so nothing ends
    # up inside itself; here the put must refuse it or containment would loop (issue 24: a
    # held Box put into the Mug inside it).
    _require(
        not world.lies_within(receptacle, held),
        f"{held.id} cannot be placed in {receptacle.id}, which lies inside {held.id}",
    )
    if _room_left(receptacle) <= 0:
        raise ActionFailed("No valid positions to place object found")
    held.held_by, agent.held = None, None
    _attach(world, held, receptacle)


def drop(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    _require(agent.held is not None, "Agent is not holding any object")
    obj = world.objects[agent.held]
    obj.held_by, agent.held = None, None
    yaw = math.radians(agent.yaw)
    move_with_contents(
        world, obj, agent.x + 0.3 * math.sin(yaw), 0.0, agent.z + 0.3 * math.cos(yaw)
    )


def _set_open(is_open: bool) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        obj = _reachable_target(world, agent, kw)
        _require(obj.aff.openable, f"{obj.id} is not openable")
        word = "open" if is_open else "closed"
        _require(obj.is_open != is_open, f"{obj.id} is already {word}")
        # AI2-THOR 5.0 cannot swing a loaded fridge door (reference §10.2).
        if obj.type == "Fridge" and obj.contents and not is_open:
            raise ActionFailed("Object failed to open/close successfully")
        obj.is_open = is_open

    return handler


def _set_toggle(on: bool) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        obj = _reachable_target(world, agent, kw)
        _require(obj.aff.toggleable, f"{obj.id} is not toggleable")
        word = "on" if on else "off"
        _require(obj.is_toggled != on, f"can't toggle object {word} if it's already {word}!")
        obj.is_toggled = on

    return handler


def slice_object(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.sliceable, f"{obj.id} is not sliceable")
    _require(not obj.is_sliced, f"{obj.id} is already sliced")
    # Refused rather than leaving the pieces floating in no one's hand (AI2-THOR slices
    # what lies in the world; the executor slices only with a knife in hand).
    _require(
        obj.held_by is None,
        f"{obj.id} is held by agent_{(obj.held_by or 0) + 1}: put it down before slicing it",
    )
    obj.is_sliced = True
    piece_type, count = slice_pieces(obj.type)
    for i in range(count):
        piece = SimObject(
            id=f"{obj.id}|{piece_type}_{i}",
            type=piece_type,
            x=obj.x,
            y=obj.y,
            z=obj.z,
            aff=affordances_of(piece_type),
            parent=obj.parent,
        )
        world.objects[piece.id] = piece
        if obj.parent is not None:
            world.objects[obj.parent].contents.append(piece.id)
    # The disabled source leaves its receptacle's listing (its colliders are off); the
    # pieces lie where it lay.
    _detach(world, obj)


def clean(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.dirtyable, f"{obj.id} is not dirtyable")
    _require(obj.is_dirty, f"{obj.id} is already clean")
    obj.is_dirty = False


def dirty(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.dirtyable, f"{obj.id} is not dirtyable")
    _require(not obj.is_dirty, f"{obj.id} is already dirty")
    obj.is_dirty = True


def fill(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.canFillWithLiquid, f"{obj.id} cannot be filled with liquid")
    _require(not obj.is_filled, f"{obj.id} is already filled")
    obj.is_filled, obj.fill_liquid = True, str(kw.get("fillLiquid") or "water")


def empty(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.canFillWithLiquid, f"{obj.id} cannot be filled with liquid")
    _require(obj.is_filled, f"{obj.id} is already empty")
    obj.is_filled, obj.fill_liquid = False, None


PUSH_FORCE_PER_METRE = 1500.0  # newtons of moveMagnitude per metre pushed
MAX_PUSH = 0.25  # metres: no push moves an object further


def _push(sign: float) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        obj = _reachable_target(world, agent, kw)
        force = _positive(kw, "moveMagnitude", 150.0)
        _require(obj.aff.moveable or obj.aff.pickupable, f"{obj.id} is not moveable")
        _not_disabled(obj)
        _require(world.carrier(obj) is None, f"{obj.id} is held and cannot be pushed")
        _require(not enclosed(world, obj), f"{obj.id} is inside a closed receptacle")
        yaw = math.radians(agent.yaw)
        step = sign * min(force / PUSH_FORCE_PER_METRE, MAX_PUSH)
        x, z = obj.x + step * math.sin(yaw), obj.z + step * math.cos(yaw)
        move_with_contents(world, obj, x, obj.y, z)
        _settle(world, obj)

    return handler


def _settle(world: World, obj: SimObject) -> None:
    """After a push: an object still over its receptacle stays in it; one pushed off lands
    in the nearest receptacle further out that lies under it and has room (a Tomato pushed
    off a Plate, onto the CounterTop the Plate stands on), else on the floor."""
    if obj.parent is None:
        return
    parent = world.objects[obj.parent]
    if within_bounds(obj, parent):
        return
    outer = world.ancestors(obj)[1:]
    _detach(world, obj)
    for receptacle in outer:
        lands = receptacle.y + receptacle.aff.height
        probe = SimObject(obj.id, obj.type, obj.x, lands, obj.z, obj.aff)
        if within_bounds(probe, receptacle) and _room_left(receptacle) > 0:
            receptacle.contents.append(obj.id)
            obj.parent = receptacle.id
            move_with_contents(world, obj, obj.x, lands, obj.z)
            return
    move_with_contents(world, obj, obj.x, 0.0, obj.z)


def break_object(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    obj = _reachable_target(world, agent, kw)
    _require(obj.aff.breakable, f"{obj.id} is not breakable")
    _require(not obj.is_broken, f"{obj.id} is already broken")
    obj.is_broken = True


# -- navigation ---------------------------------------------------------------------------


def _stand(world: World, agent: SimAgent, x: float, z: float) -> None:
    x, z = round(x, 4), round(z, 4)
    if not world.walkable(x, z):
        raise ActionFailed(f"({x:.2f}, {z:.2f}) is not a reachable position")
    other = world.blocking_agent(x, z, agent.index)
    if other is not None:
        raise ActionFailed(f"Agent collided with {other.name} at ({x:.2f}, {z:.2f})")
    agent.x, agent.z = x, z
    sync_held(world, agent)


def teleport(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    _require("standing" in kw, "TeleportFull requires 'standing' (AI2-THOR 5.0)")
    horizon = _finite(kw, "horizon", agent.horizon)
    _require(MIN_HORIZON <= horizon <= MAX_HORIZON, f"Invalid horizon {horizon}")
    rotation = kw.get("rotation", agent.yaw)
    yaw = _finite({"rotation": rotation["y"] if isinstance(rotation, dict) else rotation},
                  "rotation", 0.0)
    x, z = _finite(kw, "x", kw["x"]), _finite(kw, "z", kw["z"])  # both required
    _stand(world, agent, x, z)
    agent.yaw, agent.horizon, agent.standing = yaw % 360.0, horizon, bool(kw["standing"])


def _move(offset: float) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        magnitude = _positive(kw, "moveMagnitude", GRID)
        yaw = math.radians(agent.yaw + offset)
        _stand(
            world,
            agent,
            agent.x + magnitude * round(math.sin(yaw)),
            agent.z + magnitude * round(math.cos(yaw)),
        )

    return handler


def _rotate(sign: float) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        agent.yaw = (agent.yaw + sign * _finite(kw, "degrees", 90.0)) % 360.0

    return handler


def _look(sign: float) -> Handler:
    def handler(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
        horizon = agent.horizon + sign * _finite(kw, "degrees", 30.0)
        _require(
            MIN_HORIZON <= horizon <= MAX_HORIZON,
            f"can't look {'down' if sign > 0 else 'up'} beyond {horizon - sign * 30:g} degrees",
        )
        agent.horizon = horizon

    return handler


def reachable_positions(world: World, agent: SimAgent, kw: dict[str, Any]) -> list[dict]:
    # Shared, read-only (as `interactable_poses`): callers must not mutate them.
    return _floor_points(world.floor)


@functools.lru_cache(maxsize=256)
def _floor_points(floor: frozenset[tuple[int, int]]) -> list[dict]:
    """The floor's cells as positions, in grid order: the floor is static, so a Find's
    fallback need not sort and build them again on every call."""
    return [{"x": cx * GRID, "y": AGENT_Y, "z": cz * GRID} for cx, cz in sorted(floor)]


def poses(world: World, agent: SimAgent, kw: dict[str, Any]) -> list[dict]:
    return interactable_poses(world, _target(world, kw))


def no_op(world: World, agent: SimAgent, kw: dict[str, Any]) -> None:
    """Actions with no effect on this world (`Pass`; `InitialRandomSpawn`, whose effect the
    config's post-spawn ids already carry)."""


HANDLERS: dict[str, Handler] = {
    "PickupObject": pickup,
    "PutObject": put,
    "DropHandObject": drop,
    "OpenObject": _set_open(True),
    "CloseObject": _set_open(False),
    "ToggleObjectOn": _set_toggle(True),
    "ToggleObjectOff": _set_toggle(False),
    "SliceObject": slice_object,
    "CleanObject": clean,
    "DirtyObject": dirty,
    "FillObjectWithLiquid": fill,
    "EmptyLiquidFromObject": empty,
    "PushObject": _push(1.0),
    "PullObject": _push(-1.0),
    "BreakObject": break_object,
    "TeleportFull": teleport,
    "MoveAhead": _move(0.0),
    "MoveBack": _move(180.0),
    "MoveRight": _move(90.0),
    "MoveLeft": _move(-90.0),
    "RotateRight": _rotate(1.0),
    "RotateLeft": _rotate(-1.0),
    "LookDown": _look(1.0),
    "LookUp": _look(-1.0),
    "GetReachablePositions": reachable_positions,
    "GetInteractablePoses": poses,
    "Pass": no_op,
    "Done": no_op,
    "InitialRandomSpawn": no_op,
    "AdvancePhysicsStep": no_op,
}

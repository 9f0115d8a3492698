"""What an agent can see, and the poses from which an object can be seen.

An object is visible when it lies within the visibility distance (horizontally), inside the
camera's 90° horizontal field of view, inside its vertical field of view given the camera
horizon, and is not shut inside a closed container or held by another agent.
"""

from __future__ import annotations

import functools
import math

from benchmark_adapter.sim.embedded.world import (
    AGENT_Y,
    CAMERA_HEIGHT,
    GRID,
    SimAgent,
    SimObject,
    World,
)

FIELD_OF_VIEW = 90.0
HORIZONS = (-30.0, 0.0, 30.0, 60.0)
YAWS = (0.0, 90.0, 180.0, 270.0)


def bearing(from_x: float, from_z: float, to_x: float, to_z: float) -> float:
    """Yaw (degrees, 0 = +z, 90 = +x) that faces the target from a floor point."""
    return math.degrees(math.atan2(to_x - from_x, to_z - from_z)) % 360.0


def angle_between(a: float, b: float) -> float:
    """Smallest absolute difference between two yaws."""
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


def in_view(
    x: float, z: float, yaw: float, horizon: float, obj: SimObject, max_distance: float
) -> bool:
    """Geometric visibility of an object from a camera pose."""
    dist = math.hypot(obj.x - x, obj.z - z)
    if dist > max_distance:
        return False
    if dist > 0.05 and angle_between(bearing(x, z, obj.x, obj.z), yaw) > FIELD_OF_VIEW / 2:
        return False
    # Pitch (positive = down) to the object's bottom and top; visible if the span meets the view.
    flat = max(dist, 0.05)
    low = math.degrees(math.atan2(CAMERA_HEIGHT - obj.y, flat))
    high = math.degrees(math.atan2(CAMERA_HEIGHT - (obj.y + obj.aff.height), flat))
    return high - FIELD_OF_VIEW / 2 <= horizon <= low + FIELD_OF_VIEW / 2


def enclosed(world: World, obj: SimObject) -> bool:
    """Whether the object is shut inside a closed container (at any depth)."""
    if obj.parent is None:  # most objects, on every visibility test: keep it cheap
        return False
    return any(p.aff.openable and not p.is_open for p in world.ancestors(obj))


def visible(world: World, agent: SimAgent, obj: SimObject) -> bool:
    """AI2-THOR's `visible` flag for one agent. What is in a hand (held, or lying in the
    held receptacle) is visible to that hand's agent only; a sliced source, disabled, to
    no one."""
    if obj.held_by is not None:
        return obj.held_by == agent.index
    if obj.is_sliced:
        return False
    if obj.parent is None:  # most objects, on every visibility test: keep it cheap
        return in_view(agent.x, agent.z, agent.yaw, agent.horizon, obj,
                       world.visibility_distance)
    if enclosed(world, obj):
        return False
    carrier = world.carrier(obj)
    if carrier is not None:
        return carrier == agent.index
    return in_view(agent.x, agent.z, agent.yaw, agent.horizon, obj, world.visibility_distance)


def interactable_poses(world: World, obj: SimObject) -> list[dict]:
    """Standing poses on walkable cells from which the object is visible (ignores agents)."""
    if enclosed(world, obj) or obj.is_sliced or world.carrier(obj) is not None:
        return []
    # The poses are shared, read-only: callers must not mutate them.
    return _compute_poses(
        world.floor, obj.x, obj.y, obj.z, obj.aff.height, world.visibility_distance
    )


@functools.lru_cache(maxsize=4096)
def _compute_poses(
    floor: frozenset, x: float, y: float, z: float, height: float, reach: float
) -> list[dict]:
    """Poses depend only on the (static) floor and the object's geometry, so they are cached
    across steps and episodes."""
    cx0, cz0 = round(x / GRID), round(z / GRID)
    span = math.ceil(reach / GRID)
    poses = []
    for cx in range(cx0 - span, cx0 + span + 1):
        for cz in range(cz0 - span, cz0 + span + 1):
            if (cx, cz) in floor:
                poses.extend(_poses_at(cx * GRID, cz * GRID, x, y, z, height, reach))
    return poses


def _poses_at(
    x: float, z: float, ox: float, oy: float, oz: float, height: float, reach: float
) -> list[dict]:
    dist = math.hypot(ox - x, oz - z)
    if dist > reach:
        return []
    facing = bearing(x, z, ox, oz)
    yaws = [y for y in YAWS if dist <= 0.05 or angle_between(facing, y) <= FIELD_OF_VIEW / 2]
    flat = max(dist, 0.05)
    low = math.degrees(math.atan2(CAMERA_HEIGHT - oy, flat))
    high = math.degrees(math.atan2(CAMERA_HEIGHT - (oy + height), flat))
    fits = [h for h in HORIZONS if high - FIELD_OF_VIEW / 2 <= h <= low + FIELD_OF_VIEW / 2]
    if not fits:
        return []
    # One pose per position and yaw: the horizon nearest the object's middle.
    middle = (low + high) / 2
    horizon = min(fits, key=lambda h: abs(h - middle))
    return [
        {"x": x, "y": AGENT_Y, "z": z, "rotation": yaw, "horizon": horizon, "standing": True}
        for yaw in yaws
    ]

"""Furniture layout of one embedded scene: a rectangular room, furniture along its walls and in
its middle, attached pieces (drawers, cabinets, appliances) on their hosts, a light switch.

Everything is drawn from the `random.Random` passed in, in a fixed order, so one seed always
gives one layout. Furniture keeps apart by its floor footprint plus a walking gap.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterator

from benchmark_adapter.generator.ids import unique_object_id
from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.rooms import Furniture, RoomSpec
from benchmark_adapter.sim.embedded.affordances import affordances_of

WALL_INSET = 0.5  # furniture centres stand this far from the walls
CENTER_INSET = 1.25  # middle furniture keeps this far from the walls
SLOT_STEP = 0.25
WALK_GAP = 0.3  # free floor kept between two pieces of furniture
MIN_RADIUS = 0.2  # furniture without a footprint still takes this much floor
ATTACH_SHIFT = 0.4  # how far along its host an attached piece may sit


Room = tuple[float, float, float, float]  # x0, z0, x1, z1


def place_furniture(spec: RoomSpec, rng: random.Random) -> list[SceneObject]:
    """The furniture of one scene of a room category."""
    room = _room_box(spec, rng)
    placed: list[SceneObject] = []
    taken: set[str] = set()
    for item in spec.furniture:
        if item.where in ("wall", "center"):
            for _ in range(rng.randint(*item.count)):
                spot = _free_spot(item, room, placed, rng)
                if spot is not None:
                    placed.append(_make(item.type, spot[0], item.levels[0], spot[1], taken))
        elif item.where == "switch":
            x, z = _wall_point(room, rng)
            placed.append(_make(item.type, x, item.levels[0], z, taken))
        else:
            placed.extend(_attach(item, placed, rng, taken))
    return placed


def _room_box(spec: RoomSpec, rng: random.Random) -> Room:
    width = _snap(rng.uniform(*spec.width))
    depth = _snap(rng.uniform(*spec.depth))
    # AI2-THOR rooms are not centred on the origin; neither are ours.
    x0 = _snap(rng.uniform(-width + 0.5, -0.5))
    z0 = _snap(rng.uniform(-depth + 0.5, -0.5))
    return (x0, z0, x0 + width, z0 + depth)


def _snap(value: float) -> float:
    return round(value / SLOT_STEP) * SLOT_STEP


def _radius(object_type: str) -> float:
    return max(affordances_of(object_type).footprint, MIN_RADIUS)


def _free_spot(
    item: Furniture, room: Room, placed: list[SceneObject], rng: random.Random
) -> tuple[float, float] | None:
    """A wall or middle spot far enough from the furniture already placed, or None."""
    spots = list(_wall_spots(room) if item.where == "wall" else _center_spots(room))
    rng.shuffle(spots)
    radius = _radius(item.type)
    for x, z in spots:
        if all(
            math.hypot(x - o.x, z - o.z) >= radius + _radius(o.type) + WALK_GAP
            for o in placed
            if o.furniture and o.y < 1.5
        ):
            return x, z
    return None


def _wall_spots(room: Room) -> Iterator[tuple[float, float]]:
    x0, z0, x1, z1 = room
    xs = _steps(x0 + WALL_INSET, x1 - WALL_INSET)
    zs = _steps(z0 + WALL_INSET, z1 - WALL_INSET)
    for x in xs:
        yield x, z0 + WALL_INSET
        yield x, z1 - WALL_INSET
    for z in zs[1:-1]:
        yield x0 + WALL_INSET, z
        yield x1 - WALL_INSET, z


def _center_spots(room: Room) -> Iterator[tuple[float, float]]:
    x0, z0, x1, z1 = room
    for x in _steps(x0 + CENTER_INSET, x1 - CENTER_INSET):
        for z in _steps(z0 + CENTER_INSET, z1 - CENTER_INSET):
            yield x, z


def _steps(start: float, stop: float) -> list[float]:
    count = max(0, math.floor((stop - start) / SLOT_STEP + 1e-9)) + 1
    return [start + i * SLOT_STEP for i in range(count)]


def _wall_point(room: Room, rng: random.Random) -> tuple[float, float]:
    """A point on one of the walls (light switches have no footprint)."""
    x0, z0, x1, z1 = room
    side = rng.randrange(4)
    along = rng.uniform(0.3, 0.7)
    if side < 2:
        return x0 + along * (x1 - x0), (z0, z1)[side]
    return (x0, x1)[side - 2], z0 + along * (z1 - z0)


def _attach(
    item: Furniture, placed: list[SceneObject], rng: random.Random, taken: set[str]
) -> list[SceneObject]:
    """Pieces attached to host furniture: stacked at `levels`, then side by side."""
    hosts = item.where.removeprefix("in:").split(",")
    pieces: list[SceneObject] = []
    for host in [o for o in placed if o.type in hosts]:
        # Each kind of piece has its own place along the host (burners apart from drawers).
        base = round(rng.uniform(-ATTACH_SHIFT, ATTACH_SHIFT), 1)
        for j in range(rng.randint(*item.count)):
            if len(pieces) >= item.limit:
                return pieces
            level = item.levels[j % len(item.levels)]
            # Pieces beyond the stack sit beside it, alternately left and right.
            column = j // len(item.levels)
            dx = base + 0.3 * ((column + 1) // 2) * (1 if column % 2 else -1)
            pieces.append(_make(item.type, host.x + dx, level, host.z + 0.1, taken))
    return pieces


def _make(object_type: str, x: float, y: float, z: float, taken: set[str]) -> SceneObject:
    """A furniture object with an id no other object of the scene has."""
    oid, x = unique_object_id(object_type, x, y, z, taken)
    return SceneObject(oid, object_type, round(x, 2), round(y, 2), round(z, 2), furniture=True)

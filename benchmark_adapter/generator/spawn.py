"""Small objects of one embedded scene: which ones the scene has and where each lies.

Each `ItemKind` of the room is present with its `chance`; a present item goes on or into one of
its host receptacles that still has room (receptacle capacity from the affordance table).
Items on surfaces lie within the surface's spread at its top height; items inside openable
receptacles (fridge, cabinet, drawer, box) lie at the receptacle's own position.
"""

from __future__ import annotations

import random

from benchmark_adapter.generator.ids import unique_object_id
from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.rooms import SPREAD, SURFACE_TOP, RoomSpec
from benchmark_adapter.sim.embedded.affordances import affordances_of

DEFAULT_SPREAD = 0.1
INSIDE_SPREAD = 0.05
ON_TOP = 0.05  # height of an item above a host with no known surface height


def spawn_items(
    spec: RoomSpec, furniture: list[SceneObject], rng: random.Random
) -> list[SceneObject]:
    """The small objects of one scene, in the room spec's order."""
    hosts = list(furniture)
    load: dict[str, int] = {}
    taken = {o.id for o in furniture}
    items: list[SceneObject] = []
    for kind in spec.items:
        if rng.random() >= kind.chance:
            continue
        free = [h for h in hosts if h.type in kind.hosts and _has_room(h, load)]
        if not free:
            continue
        host = rng.choice(free)
        item = _place(kind.type, host, rng, taken)
        load[host.id] = load.get(host.id, 0) + 1
        items.append(item)
        if affordances_of(kind.type).receptacle:
            hosts.append(item)  # a box can hold later items
    return items


def _has_room(host: SceneObject, load: dict[str, int]) -> bool:
    return load.get(host.id, 0) < affordances_of(host.type).capacity


def _place(
    object_type: str, host: SceneObject, rng: random.Random, taken: set[str]
) -> SceneObject:
    inside = affordances_of(host.type).openable
    spread = INSIDE_SPREAD if inside else SPREAD.get(host.type, DEFAULT_SPREAD)
    x = host.x + rng.uniform(-spread, spread)
    z = host.z + rng.uniform(-spread, spread)
    y = host.y + ON_TOP if inside else SURFACE_TOP.get(host.type, host.y + ON_TOP)
    oid, x = unique_object_id(object_type, x, y, z, taken)
    return SceneObject(oid, object_type, round(x, 2), round(y, 2), round(z, 2), parent=host.id)

"""Where a D4 relay happens: the transfer point, the final target and, for cross-zone
handoffs, a source zone of items far from the target.

Transfer points and targets are open, non-openable surfaces (D4 consumers of living rooms,
bedrooms and bathrooms have no Open skill).
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import Ungroundable

TRANSFER_TYPES = {
    "living_room": ("SideTable", "Ottoman", "ArmChair", "Shelf", "CoffeeTable", "DiningTable"),
    "bedroom": ("SideTable", "Chair", "Shelf", "Dresser", "ArmChair", "Desk"),
    "bathroom": ("CounterTop", "Shelf", "SideTable", "Dresser", "Toilet"),
}
TARGET_TYPES = {
    "living_room": ("CoffeeTable", "Sofa", "DiningTable", "TVStand", "Dresser", "Shelf"),
    "bedroom": ("Desk", "Bed", "Dresser", "Shelf"),
    "bathroom": ("Shelf", "CounterTop", "SideTable", "Dresser", "Bathtub"),
}
ZONE_SPLIT = 2.5  # metres between every source item and the target of a cross-zone handoff
SOURCE_RADIUS = 1.75  # source items lie this close to one another
ZONE_MARGIN = 0.75  # the transfer point keeps this far from both zones


def _surfaces(
    scene: Scene, types: Sequence[str], items: Sequence[SceneObject]
) -> list[SceneObject]:
    """Furniture of the given types that none of the items lies on."""
    holders = {i.parent for i in items}
    return [o for o in scene.of_type(*types) if o.furniture and o.id not in holders]


def relay_places(
    scene: Scene, items: Sequence[SceneObject], rng: random.Random
) -> tuple[SceneObject, SceneObject]:
    """(transfer point, target) for a relay of `items`: a random target, and a random
    transfer surface of another type (trying the next target when there is none)."""
    targets = _surfaces(scene, TARGET_TYPES[scene.room], items)
    if not targets:
        raise Ungroundable("no target surface free of the relayed items")
    rng.shuffle(targets)
    surfaces = _surfaces(scene, TRANSFER_TYPES[scene.room], items)
    for target in targets:
        transfers = [o for o in surfaces if o.type != target.type]
        if transfers:
            return rng.choice(transfers), target
    raise Ungroundable(f"no transfer surface of another type than the {targets[0].type}")


def _distance(a: SceneObject | tuple[float, float], b: SceneObject) -> float:
    ax, az = (a.x, a.z) if isinstance(a, SceneObject) else a
    return math.hypot(ax - b.x, az - b.z)


def cross_zone_places(
    scene: Scene, count: int, rng: random.Random
) -> tuple[list[SceneObject], SceneObject, SceneObject]:
    """(items, transfer point, target): `count` items at least `ZONE_SPLIT` from the target,
    and the transfer point that makes the smallest detour between the two zones."""
    targets = [o for o in scene.of_type(*TARGET_TYPES[scene.room]) if o.furniture]
    rng.shuffle(targets)
    for target in targets:
        far = [item for item in scene.loose() if _distance(item, target) >= ZONE_SPLIT]
        items = _source_zone(far, count, rng)
        transfer = _midway(scene, items, target) if items else None
        if items and transfer is not None:
            return items, transfer, target
    raise Ungroundable(
        f"no target with {count} items within {SOURCE_RADIUS} m of each other and at least "
        f"{ZONE_SPLIT} m away"
    )


def _source_zone(
    far: list[SceneObject], count: int, rng: random.Random
) -> list[SceneObject] | None:
    """`count` items of distinct types lying together (within `SOURCE_RADIUS` of one of
    them), or None."""
    anchors = list(far)
    rng.shuffle(anchors)
    for anchor in anchors:
        zone: dict[str, SceneObject] = {}
        for item in far:
            if _distance(item, anchor) <= SOURCE_RADIUS:
                zone.setdefault(item.type, item)
        if len(zone) >= count:
            return [zone[t] for t in rng.sample(sorted(zone), count)]
    return None


def _midway(
    scene: Scene, items: Sequence[SceneObject], target: SceneObject
) -> SceneObject | None:
    cx = sum(i.x for i in items) / len(items)
    cz = sum(i.z for i in items) / len(items)
    direct = _distance((cx, cz), target)
    options = [
        o
        for o in _surfaces(scene, TRANSFER_TYPES[scene.room], items)
        if o.id != target.id
        and _distance((cx, cz), o) >= ZONE_MARGIN
        and _distance(target, o) >= ZONE_MARGIN
    ]
    if not options:
        return None
    # Smallest detour over the straight source -> target line; ids break ties.
    def detour(o: SceneObject) -> tuple[float, str]:
        return _distance((cx, cz), o) + _distance(target, o) - direct, o.id

    return min(options, key=detour)

"""Scene catalogue entries: a room's objects with positions, receptacle contents and free poses.

A `Scene` is what templates ground against, whichever way it was made: generated here from a
room category and seeds (`embedded_scene`), or read from AI2-THOR FloorPlan metadata
(`thor.scene_from_thor_metadata`). The embedded catalogue has `SCENES_PER_ROOM` layouts per
room category; a layout's furniture depends only on its index, its small objects also on the
spawn seed (as AI2-THOR's `InitialRandomSpawn` reshuffles a FloorPlan's small objects).
"""

from __future__ import annotations

import functools
import random
import zlib
from collections.abc import Iterable
from dataclasses import dataclass

from benchmark_adapter.generator.ids import scene_id
from benchmark_adapter.generator.layout import place_furniture
from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.rooms import ROOM_SPECS
from benchmark_adapter.generator.spawn import spawn_items
from benchmark_adapter.sim.embedded.affordances import affordances_of
from benchmark_adapter.sim.embedded.world import GRID, build_floor, make_object
from benchmark_adapter.vocabulary import EMBEDDED

SCENES_PER_ROOM = 30

__all__ = ["SCENES_PER_ROOM", "Scene", "SceneObject", "catalogue", "embedded_scene"]


@dataclass(frozen=True)
class Scene:
    """A household scene: objects in a fixed order, the room category and the spawn seed."""

    scene_id: str
    room: str
    seed: int
    objects: tuple[SceneObject, ...]
    source: str = EMBEDDED  # or "thor" for FloorPlan metadata

    def get(self, object_id: str) -> SceneObject:
        """The object with this id."""
        return self._by_id[object_id]

    def of_type(self, *types: str) -> list[SceneObject]:
        """Objects of the given types, in scene order."""
        return [o for o in self.objects if o.type in types]

    def contents(self, receptacle_id: str) -> list[SceneObject]:
        """Objects lying on or in a receptacle (its receptacle contents)."""
        return [o for o in self.objects if o.parent == receptacle_id]

    def enclosed(self, obj: SceneObject) -> bool:
        """Whether an object lies inside an openable receptacle (hidden until opened)."""
        parent = self._by_id.get(obj.parent) if obj.parent else None
        return parent is not None and affordances_of(parent.type).openable

    def loose(self, *types: str) -> list[SceneObject]:
        """Pickupable small objects in plain sight (not shut in a container), optionally
        restricted to some types."""
        return [
            o
            for o in self.objects
            if not o.furniture
            and affordances_of(o.type).pickupable
            and not self.enclosed(o)
            and (not types or o.type in types)
        ]

    def distractors(self, used: Iterable[str]) -> list[SceneObject]:
        """Small objects a task does not use."""
        taken = set(used)
        return [o for o in self.objects if not o.furniture and o.id not in taken]

    @functools.cached_property
    def free_poses(self) -> tuple[tuple[float, float], ...]:
        """Floor points (x, z) an agent can stand on: the embedded world's walkable grid."""
        floor = build_floor([make_object(o.id) for o in self.objects])
        return tuple((cx * GRID, cz * GRID) for cx, cz in sorted(floor))

    @functools.cached_property
    def _by_id(self) -> dict[str, SceneObject]:
        return {o.id: o for o in self.objects}


def seeded_rng(*parts: object) -> random.Random:
    """A generator seeded from the parts' text, the same in every interpreter run."""
    # crc32 of the text, not hash(): str hashes change between interpreter runs.
    return random.Random(zlib.crc32(":".join(map(str, parts)).encode()))


@functools.lru_cache(maxsize=1024)
def embedded_scene(room: str, index: int, seed: int = 0) -> Scene:
    """Embedded scene `index` (1-based) of a room category with its small objects spawned by
    `seed`; the same arguments always give the same scene."""
    spec = ROOM_SPECS[room]
    furniture = place_furniture(spec, seeded_rng("layout", room, index))
    items = spawn_items(spec, furniture, seeded_rng("spawn", room, index, seed))
    return Scene(scene_id(room, index), room, seed, (*furniture, *items))


def catalogue(room: str, seed: int = 0) -> list[Scene]:
    """Every embedded scene of a room category at one spawn seed."""
    return [embedded_scene(room, i, seed) for i in range(1, SCENES_PER_ROOM + 1)]

"""The embedded scene catalogue: deterministic, AI2-THOR-shaped, physically consistent."""

from __future__ import annotations

import re

import pytest

from benchmark_adapter.generator import catalogue, embedded_scene
from benchmark_adapter.generator.ids import coordinate, object_id, task_id
from benchmark_adapter.generator.rooms import ROOMS, room_of_floorplan
from benchmark_adapter.sim.embedded.affordances import affordances_of
from benchmark_adapter.sim.embedded.world import position_from_id

ID = re.compile(r"^[A-Za-z]+(\|[+-]\d{2}\.\d{2}){3}$")
SCENE = re.compile(r"^Emb(Kitchen|LivingRoom|Bedroom|Bathroom)\d{2}$")


def test_ids_are_ai2thor_shaped() -> None:
    assert object_id("Apple", 1.4, 0.7, -1.6) == "Apple|+01.40|+00.70|-01.60"
    assert coordinate(-0.001) == "+00.00"  # never "-00.00"
    assert task_id("K_D3", "EmbKitchen07", "prepare_food", 2, 1) == (
        "K_D3__EmbKitchen07__prepare_food_seed1"
    )
    assert task_id("K_D3", "EmbKitchen07", "prepare_food", 4, 0).endswith("_4agent_seed0")


@pytest.mark.parametrize("room", ROOMS)
def test_scenes_of_every_room_are_consistent(room: str) -> None:
    for scene in catalogue(room)[:5]:
        assert SCENE.match(scene.scene_id) and "FloorPlan" not in scene.scene_id
        ids = [o.id for o in scene.objects]
        assert len(ids) == len(set(ids))
        for obj in scene.objects:
            assert ID.match(obj.id), obj.id
            assert position_from_id(obj.id) == (obj.x, obj.y, obj.z)
            assert affordances_of(obj.type).any(), f"{obj.type} has no affordances"
        for holder in {o.parent for o in scene.objects if o.parent}:
            capacity = affordances_of(scene.get(holder).type).capacity
            assert len(scene.contents(holder)) <= capacity
        assert scene.free_poses and scene.loose()


def test_scenes_are_deterministic_and_seeds_respawn_small_objects() -> None:
    first = embedded_scene("living_room", 4, 0)
    embedded_scene.cache_clear()
    again = embedded_scene("living_room", 4, 0)
    assert first == again and first is not again
    respawned = embedded_scene("living_room", 4, 1)
    furniture = [o for o in first.objects if o.furniture]
    assert furniture == [o for o in respawned.objects if o.furniture]
    assert first.distractors([]) != respawned.distractors([])


def test_distractors_are_the_unused_small_objects() -> None:
    scene = embedded_scene("kitchen", 2, 0)
    used = [o.id for o in scene.loose()[:2]]
    distractors = scene.distractors(used)
    assert distractors and not {o.id for o in distractors} & set(used)
    assert all(not o.furniture for o in distractors)


def test_floorplan_rooms() -> None:
    assert room_of_floorplan("FloorPlan12") == "kitchen"
    assert room_of_floorplan("FloorPlan203") == "living_room"
    assert room_of_floorplan("FloorPlan318") == "bedroom"
    assert room_of_floorplan("FloorPlan401") == "bathroom"
    with pytest.raises(ValueError, match="not an iTHOR FloorPlan"):
        room_of_floorplan("FloorPlan901")

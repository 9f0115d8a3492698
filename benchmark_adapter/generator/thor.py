"""Scene catalogue entries from AI2-THOR FloorPlan metadata (the optional thor backend).

`scene_from_thor_metadata` turns a FloorPlan's object metadata list (AI2-THOR's schema:
`objectId`, `objectType`, `position`, `parentReceptacles`, `receptacle`, `pickupable`, …)
into a `Scene` the templates ground against exactly like an embedded one; configs grounded on
it carry the real `FloorPlanN` scene id. `thor_scene` reads that list from a running
simulator. Both need the `ai2thor` package (`pip install 'cocobench-agents[thor]'`).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from types import ModuleType
from typing import Any

from benchmark_adapter.generator.builder import spawn_action
from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.rooms import room_of_floorplan
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.sim.embedded.affordances import affordances_of

THOR_MISSING = "the thor backend is not installed: pip install 'cocobench-agents[thor]'"
# Structural types AI2-THOR lists as parents of nearly everything; never a useful parent.
STRUCTURE = frozenset({"Floor", "Wall", "Ceiling", "Window", "Doorway", "Doorframe"})


class ThorBackendMissing(ImportError):
    """`ai2thor` is not installed."""


def require_thor() -> ModuleType:
    """The `ai2thor` module, or `ThorBackendMissing` with the install command."""
    try:
        return importlib.import_module("ai2thor")
    except ImportError as exc:
        raise ThorBackendMissing(THOR_MISSING) from exc


def scene_from_thor_metadata(
    scene_id: str, objects: Iterable[Mapping[str, Any]], seed: int = 0
) -> Scene:
    """A catalogue entry for a FloorPlan from its `event.metadata["objects"]` list.

    Sliced pieces and structural objects are left out; an object's parent is the first of
    its `parentReceptacles` that is itself in the scene; furniture is what is not pickupable.
    """
    require_thor()
    records = [o for o in objects if _kept(o)]
    known = {o["objectId"] for o in records}
    scene_objects = tuple(_scene_object(o, known) for o in records)
    return Scene(scene_id, room_of_floorplan(scene_id), seed, scene_objects, source="thor")


def _kept(record: Mapping[str, Any]) -> bool:
    kind = str(record.get("objectType", ""))
    return bool(kind) and kind not in STRUCTURE and not kind.endswith("Sliced")


def _scene_object(record: Mapping[str, Any], known: set[str]) -> SceneObject:
    oid, kind = str(record["objectId"]), str(record["objectType"])
    parents = [p for p in record.get("parentReceptacles") or [] if p in known and p != oid]
    position = record.get("position") or {}
    pickupable = record.get("pickupable", affordances_of(kind).pickupable)
    return SceneObject(
        id=oid,
        type=kind,
        x=round(float(position.get("x", 0.0)), 2),
        y=round(float(position.get("y", 0.0)), 2),
        z=round(float(position.get("z", 0.0)), 2),
        parent=parents[0] if parents else None,
        furniture=not pickupable,
    )


def thor_scene(floor_plan: str, seed: int = 0) -> Scene:  # pragma: no cover - needs Unity
    """Start AI2-THOR on a FloorPlan (after `InitialRandomSpawn(seed)` when seed > 0) and
    read its catalogue entry. Needs a machine that can run the simulator."""
    require_thor()
    from benchmark_adapter.sim.thor.launch import open_controller
    from benchmark_adapter.sim.thor.options import ThorOptions
    from benchmark_adapter.sim.thor.pool import shutdown

    # Our launcher: headless platform choice and a guarded build lookup.
    controller = open_controller(ThorOptions.from_env(), floor_plan,
                                 {"agentMode": "default", "renderImage": False})
    try:
        if seed > 0:
            controller.step(**spawn_action(seed))
        return scene_from_thor_metadata(floor_plan, controller.last_event.metadata["objects"], seed)
    finally:
        shutdown(controller)

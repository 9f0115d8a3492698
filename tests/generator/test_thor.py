"""Grounding on AI2-THOR FloorPlan metadata (no Unity: a hand-written metadata list)."""

from __future__ import annotations

import sys
import types

import pytest

from benchmark_adapter.generator import TASK_TYPES, ThorBackendMissing, judge
from benchmark_adapter.generator.pipeline import make_candidate
from benchmark_adapter.generator.thor import THOR_MISSING, scene_from_thor_metadata

FRIDGE = "Fridge|-02.10|+00.00|+01.07"
COUNTER = "CounterTop|-01.87|+00.95|-00.61"
DRAWER = "Drawer|-01.56|+00.66|-00.20"


def _record(oid: str, pickupable: bool, parents: list[str] | None = None) -> dict:
    parts = oid.split("|")
    x, y, z = parts[1:4]
    kind = parts[4].split("_")[0] if len(parts) > 4 else parts[0]  # sliced pieces
    return {
        "objectId": oid,
        "objectType": kind,
        "position": {"x": float(x), "y": float(y), "z": float(z)},
        "pickupable": pickupable,
        "parentReceptacles": parents,
    }


METADATA = [
    _record("Floor|+00.00|+00.00|+00.00", False),
    _record(FRIDGE, False, ["Floor|+00.00|+00.00|+00.00"]),
    _record(COUNTER, False),
    _record(DRAWER, False),
    _record("LightSwitch|+02.33|+01.31|-00.16", False),
    _record("Knife|-01.50|+00.70|-00.22", True, [DRAWER]),
    _record("Potato|-01.66|+00.93|-02.15", True, [COUNTER]),
    _record("Tomato|-00.39|+00.96|-00.81", True, [COUNTER]),
    _record("Apple|-02.05|+00.85|+01.10", True, [FRIDGE]),
    _record("Lettuce|-01.81|+00.97|-00.94", True, [COUNTER]),
    _record("Bread|-01.20|+00.96|-00.70|BreadSliced_1", True, [COUNTER]),
]


@pytest.fixture
def fake_ai2thor(monkeypatch: pytest.MonkeyPatch) -> None:
    """Pretend the thor extra is installed (only the import is needed here)."""
    monkeypatch.setitem(sys.modules, "ai2thor", types.ModuleType("ai2thor"))


def test_missing_backend_says_how_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ai2thor", None)  # import fails even if installed
    with pytest.raises(ThorBackendMissing) as info:
        scene_from_thor_metadata("FloorPlan1", METADATA)
    assert str(info.value) == THOR_MISSING
    assert "pip install 'cocobench-agents[thor]'" in str(info.value)


@pytest.mark.usefixtures("fake_ai2thor")
def test_metadata_becomes_a_catalogue_entry() -> None:
    scene = scene_from_thor_metadata("FloorPlan1", METADATA)
    assert (scene.scene_id, scene.room, scene.source) == ("FloorPlan1", "kitchen", "thor")
    ids = [o.id for o in scene.objects]
    assert not any(i.startswith(("Floor|", "Bread|")) for i in ids)  # structure, slices
    assert scene.get(FRIDGE).furniture and scene.get(FRIDGE).parent is None
    knife = scene.get("Knife|-01.50|+00.70|-00.22")
    assert knife.parent == DRAWER and scene.enclosed(knife)
    assert {o.type for o in scene.loose()} == {"Potato", "Tomato", "Lettuce"}


@pytest.mark.usefixtures("fake_ai2thor")
@pytest.mark.parametrize("slug", ["prepare_food", "store_groceries"])
def test_templates_ground_on_floorplan_metadata(slug: str) -> None:
    scene = scene_from_thor_metadata("FloorPlan1", METADATA)
    candidate = make_candidate(TASK_TYPES[slug], scene, 2, 0)
    assert candidate.config is not None, candidate.problem
    config = candidate.config
    assert config["scene_id"] == "FloorPlan1" and config["provenance"]["scene_source"] == "thor"
    assert config["task_id"].startswith(f"{TASK_TYPES[slug].cell}__FloorPlan1__{slug}")
    assert judge(config).passed

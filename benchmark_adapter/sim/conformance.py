"""`check_controller`: the contract every backend must meet (in the spirit of Gymnasium's
`check_env`). Run it against a new backend before trusting its trajectories.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from benchmark_adapter.sim.protocol import Controller, Metadata

AGENT_KEYS = (
    "agent",
    "objects",
    "inventoryObjects",
    "lastActionSuccess",
    "errorMessage",
    "actionReturn",
)
OBJECT_KEYS = (
    "objectId",
    "objectType",
    "position",
    "visible",
    "pickupable",
    "isPickedUp",
    "receptacle",
    "receptacleObjectIds",
    "parentReceptacles",
    "openable",
    "isOpen",
    "toggleable",
    "isToggled",
    "sliceable",
    "isSliced",
)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class ConformanceError(AssertionError):
    """A backend breaks the `Controller` contract."""


def check_controller(make: Callable[[], Controller]) -> None:
    """Exercise a backend built by `make()` (twice, for determinism); raise on any breach."""
    first, second = make(), make()
    try:
        trace_a = _exercise(first)
        trace_b = _exercise(second)
        _expect(trace_a == trace_b, "the same calls gave different metadata (not deterministic)")
    finally:
        first.stop()
        second.stop()


def _exercise(ctl: Controller) -> list[str]:
    """Run the contract's calls; return a canonical trace of the metadata seen."""
    trace = [_canon(_check_metadata(ctl.reset(), ctl.agent_count))]
    trace.append(_canon(_check_unknown_action(ctl)))
    trace.append(_canon(_check_pass(ctl)))
    trace.append(_canon(_check_navigation(ctl)))
    pickupable = _first(ctl, "pickupable")
    if pickupable is not None and ctl.agent_count >= 2:
        trace.append(_canon(_check_one_holder(ctl, pickupable)))
    _check_frame(ctl)
    return trace


def _check_metadata(metadata: Sequence[Metadata], agent_count: int) -> Sequence[Metadata]:
    _expect(
        len(metadata) == agent_count,
        f"expected {agent_count} agents' metadata, got {len(metadata)}",
    )
    for i, md in enumerate(metadata):
        missing = [k for k in AGENT_KEYS if k not in md]
        _expect(not missing, f"agent {i} metadata lacks {missing}")
        for key in ("name", "position", "rotation", "cameraHorizon"):
            _expect(key in md["agent"], f"agent {i} metadata.agent lacks {key!r}")
        for obj in md["objects"]:
            gaps = [k for k in OBJECT_KEYS if k not in obj]
            _expect(not gaps, f"object {obj.get('objectId')} lacks {gaps}")
    return metadata


def _check_unknown_action(ctl: Controller) -> Sequence[Metadata]:
    md = ctl.step("NoSuchAction", agentId=0)
    _expect(md[0]["lastActionSuccess"] is False, "an unknown action must fail, not succeed")
    _expect(bool(md[0]["errorMessage"]), "a failed action must carry an errorMessage")
    return md


def _check_pass(ctl: Controller) -> Sequence[Metadata]:
    md = _check_metadata(ctl.step("Pass", agentId=ctl.agent_count - 1), ctl.agent_count)
    _expect(md[-1]["lastActionSuccess"] is True, "Pass must succeed")
    return md


def _check_navigation(ctl: Controller) -> Sequence[Metadata]:
    target = _first(ctl, "receptacle") or _first(ctl, "pickupable")
    _expect(target is not None, "the scene has no receptacle or pickupable object")
    md = ctl.step("GetInteractablePoses", agentId=0, objectId=target)
    poses = md[0]["actionReturn"]
    _expect(isinstance(poses, list) and poses, f"GetInteractablePoses({target}) gave no poses")
    reached = False
    for pose in poses:
        md = ctl.step("TeleportFull", agentId=0, **pose)
        if md[0]["lastActionSuccess"]:
            seen = [o for o in md[0]["objects"] if o["objectId"] == target]
            _expect(seen and seen[0]["visible"],
                    f"{target} is not visible from its own interactable pose")
            reached = True
            break
    _expect(reached, f"no interactable pose of {target} could be reached with TeleportFull")
    md = ctl.step(
        "TeleportFull", agentId=0, x=1e6, y=0.9, z=1e6, rotation=0, horizon=0, standing=True
    )
    _expect(md[0]["lastActionSuccess"] is False, "teleporting off the floor must fail")
    return md


def _check_one_holder(ctl: Controller, object_id: str) -> Sequence[Metadata]:
    for agent in range(ctl.agent_count):
        if ctl.last_metadata()[agent]["inventoryObjects"]:
            ctl.step("DropHandObject", agentId=agent, forceAction=True)
    md = ctl.step("PickupObject", agentId=0, objectId=object_id, forceAction=True)
    _expect(
        md[0]["lastActionSuccess"],
        f"forced PickupObject({object_id}) failed: {md[0]['errorMessage']}",
    )
    _expect(
        [o["objectId"] for o in md[0]["inventoryObjects"]] == [object_id],
        "a picked-up object must be in the agent's inventoryObjects",
    )
    md = ctl.step("PickupObject", agentId=1, objectId=object_id, forceAction=True)
    _expect(not md[1]["lastActionSuccess"], "an object must have at most one holder")
    return md


def _check_frame(ctl: Controller) -> None:
    png = ctl.frame(0)
    _expect(png[:8] == PNG_SIGNATURE, "frame() must return PNG bytes")
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    _expect(
        width >= 300 and height >= 300, f"frames must be at least 300×300, got {width}×{height}"
    )


def _first(ctl: Controller, flag: str) -> str | None:
    for obj in ctl.last_metadata()[0]["objects"]:
        if obj.get(flag):
            return obj["objectId"]
    return None


def _canon(metadata: Sequence[Mapping[str, Any]]) -> str:
    return json.dumps([dict(md) for md in metadata], sort_keys=True, default=str)


def _expect(condition: Any, message: str) -> None:
    if not condition:
        raise ConformanceError(message)

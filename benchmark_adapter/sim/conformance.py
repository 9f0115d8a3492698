"""`check_controller`: the contract every backend must meet (in the spirit of Gymnasium's
`check_env`). Run it against a new backend before trusting its trajectories.
"""

from __future__ import annotations

import graphlib
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
# Where a content may lie around its receptacle's position when the backend reports no
# `axisAlignedBoundingBox` (the embedded world's slots reach 0.41 m): horizontal and vertical
# metres. A content left behind by a moved receptacle lies metres away.
CONTENT_REACH, CONTENT_RISE = 0.6, 2.0
BOX_SLACK = 0.1  # metres around a reported bounding box


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
    trace = [_canon(_check_containment("reset", _check_metadata(ctl.reset(), ctl.agent_count)))]
    trace.append(_canon(_check_unknown_action(ctl)))
    trace.append(_canon(_check_pass(ctl)))
    trace.append(_canon(_check_navigation(ctl)))
    pickupable = _first(ctl, "pickupable")
    if pickupable is not None and ctl.agent_count >= 2:
        trace.append(_canon(_check_one_holder(ctl, pickupable)))
    nesting = _check_nothing_inside_itself(ctl)
    if nesting is not None:
        trace.append(_canon(nesting))
    trace += [_canon(md) for md in _check_contents_travel(ctl)]
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
    md = _step(ctl, "NoSuchAction", agentId=0)
    _expect(md[0]["lastActionSuccess"] is False, "an unknown action must fail, not succeed")
    _expect(bool(md[0]["errorMessage"]), "a failed action must carry an errorMessage")
    return md


def _check_pass(ctl: Controller) -> Sequence[Metadata]:
    md = _check_metadata(_step(ctl, "Pass", agentId=ctl.agent_count - 1), ctl.agent_count)
    _expect(md[-1]["lastActionSuccess"] is True, "Pass must succeed")
    return md


def _check_navigation(ctl: Controller) -> Sequence[Metadata]:
    target = _first(ctl, "receptacle") or _first(ctl, "pickupable")
    _expect(target is not None, "the scene has no receptacle or pickupable object")
    md = _step(ctl, "GetInteractablePoses", agentId=0, objectId=target)
    poses = md[0]["actionReturn"]
    _expect(isinstance(poses, list) and poses, f"GetInteractablePoses({target}) gave no poses")
    reached = False
    for pose in poses:
        md = _step(ctl, "TeleportFull", agentId=0, **pose)
        if md[0]["lastActionSuccess"]:
            seen = [o for o in md[0]["objects"] if o["objectId"] == target]
            _expect(seen and seen[0]["visible"],
                    f"{target} is not visible from its own interactable pose")
            reached = True
            break
    _expect(reached, f"no interactable pose of {target} could be reached with TeleportFull")
    md = _step(
        ctl, "TeleportFull", agentId=0, x=1e6, y=0.9, z=1e6, rotation=0, horizon=0, standing=True
    )
    _expect(md[0]["lastActionSuccess"] is False, "teleporting off the floor must fail")
    return md


def _check_one_holder(ctl: Controller, object_id: str) -> Sequence[Metadata]:
    for agent in range(ctl.agent_count):
        if ctl.last_metadata()[agent]["inventoryObjects"]:
            _step(ctl, "DropHandObject", agentId=agent, forceAction=True)
    md = _step(ctl, "PickupObject", agentId=0, objectId=object_id, forceAction=True)
    _expect(
        md[0]["lastActionSuccess"],
        f"forced PickupObject({object_id}) failed: {md[0]['errorMessage']}",
    )
    _expect(
        [o["objectId"] for o in md[0]["inventoryObjects"]] == [object_id],
        "a picked-up object must be in the agent's inventoryObjects",
    )
    md = _step(ctl, "PickupObject", agentId=1, objectId=object_id, forceAction=True)
    _expect(not md[1]["lastActionSuccess"], "an object must have at most one holder")
    return md


def _step(ctl: Controller, action: str, **kwargs: Any) -> Sequence[Metadata]:
    """`ctl.step`, then the containment invariants on the metadata it returned. A step that
    raises breaches the contract too (a failed action is reported, not raised)."""
    try:
        metadata = ctl.step(action, **kwargs)
    except Exception as exc:
        raise ConformanceError(f"after {action}: the step raised {exc!r}") from exc
    return _check_contents_within(action, _check_containment(action, metadata))


def _check_containment(action: str, metadata: Sequence[Metadata]) -> Sequence[Metadata]:
    """No object lies inside itself, directly or through what it contains (AI2-THOR never
    lets that happen; a walk over such parents never ends). Both `parentReceptacles` and
    `receptacleObjectIds` count, and may list transitive containers, as AI2-THOR's do."""
    for md in metadata:
        try:
            objects = list(md["objects"])
        except Exception as exc:  # a backend's metadata that cannot be read is a breach too
            raise ConformanceError(f"after {action}: reading the objects failed: {exc!r}") from exc
        inside: dict[str, set[str]] = {}  # receptacle -> what lies in it
        for obj in objects:
            oid = obj.get("objectId")
            for parent in obj.get("parentReceptacles") or []:
                inside.setdefault(parent, set()).add(oid)
            for content in obj.get("receptacleObjectIds") or []:
                inside.setdefault(oid, set()).add(content)
        cycle = _cycle(inside)
        _expect(cycle is None,
                f"after {action}: an object lies inside itself: {' -> '.join(cycle or [])}")
    return metadata


def _check_contents_within(action: str, metadata: Sequence[Metadata]) -> Sequence[Metadata]:
    """Every content lies within its receptacle's bounds (the reported bounding box, else
    `CONTENT_REACH`): contents travel with a receptacle that moves, as in AI2-THOR."""
    if not metadata:
        return metadata
    objects = {o.get("objectId"): o for o in metadata[0]["objects"]}
    for receptacle in objects.values():
        for content_id in receptacle.get("receptacleObjectIds") or []:
            content = objects.get(content_id)
            if content is not None and not _within(content, receptacle):
                raise ConformanceError(
                    f"after {action}: {content_id} lies {_distance(content, receptacle):.2f} m "
                    f"from {receptacle['objectId']}, which lists it among its contents"
                )
    return metadata


def _within(content: Mapping[str, Any], receptacle: Mapping[str, Any]) -> bool:
    point, centre = content["position"], receptacle["position"]
    box = receptacle.get("axisAlignedBoundingBox") or {}
    if box.get("center") and box.get("size"):
        return all(abs(point[k] - box["center"][k]) <= box["size"][k] / 2 + BOX_SLACK
                   for k in ("x", "y", "z"))
    return (_distance(content, receptacle) <= CONTENT_REACH
            and abs(point["y"] - centre["y"]) <= CONTENT_RISE)


def _distance(a: Mapping[str, Any], b: Mapping[str, Any]) -> float:
    pa, pb = a["position"], b["position"]
    return float(((pa["x"] - pb["x"]) ** 2 + (pa["z"] - pb["z"]) ** 2) ** 0.5)


def _check_contents_travel(ctl: Controller) -> list[Sequence[Metadata]]:
    """Load a portable receptacle, then pick it up, carry it, drop it, put it on furniture
    and push it: after each move its content still lies in it and within its bounds (the
    check of every `_step`). Nothing when the scene has no portable receptacle and another
    pickupable object, or a setup step fails (a physical backend may find no room)."""
    objects = ctl.last_metadata()[0]["objects"]
    carrier = next((o["objectId"] for o in objects
                    if o.get("pickupable") and o.get("receptacle")), None)
    content = next((o["objectId"] for o in objects if o.get("pickupable")
                    and not o.get("receptacle") and not o.get("isSliced")), None)
    furniture = next((o["objectId"] for o in objects if o.get("receptacle")
                      and not o.get("pickupable") and not o.get("openable")), None)
    if carrier is None or content is None:
        return []
    _empty_hands(ctl)
    if _is_closed(ctl, carrier):
        _step(ctl, "OpenObject", agentId=0, objectId=carrier, forceAction=True)
    for action, target in (("PickupObject", content), ("PutObject", carrier)):
        md = _step(ctl, action, agentId=0, objectId=target, forceAction=True,
                   placeStationary=True)
        if not md[0]["lastActionSuccess"]:
            return []
    moves: list[tuple[str, dict[str, Any]]] = [
        ("PickupObject", {"objectId": carrier}),
        ("TeleportFull", _far_pose(ctl)),
        ("DropHandObject", {}),
        ("PickupObject", {"objectId": carrier}),
    ]
    if furniture is not None:
        moves.append(("PutObject", {"objectId": furniture, "placeStationary": True}))
    moves.append(("PushObject", {"objectId": carrier, "moveMagnitude": 150.0}))
    trace = []
    for action, kwargs in moves:
        md = _step(ctl, action, agentId=0, forceAction=True, **kwargs)
        record = next(o for o in md[0]["objects"] if o["objectId"] == content)
        _expect(carrier in (record.get("parentReceptacles") or []),
                f"after {action} of {carrier}: {content} no longer lies in it")
        trace.append(md)
    return trace


def _far_pose(ctl: Controller) -> dict[str, Any]:
    """The reachable position furthest from agent 0, as a TeleportFull pose."""
    here = ctl.last_metadata()[0]["agent"]["position"]
    positions = _step(ctl, "GetReachablePositions", agentId=0)[0]["actionReturn"] or [here]
    far = max(positions, key=lambda p: (p["x"] - here["x"]) ** 2 + (p["z"] - here["z"]) ** 2)
    return {**far, "rotation": 0, "horizon": 0, "standing": True}


def _empty_hands(ctl: Controller) -> None:
    for agent in range(ctl.agent_count):
        if ctl.last_metadata()[agent]["inventoryObjects"]:
            _step(ctl, "DropHandObject", agentId=agent, forceAction=True)


def _cycle(inside: Mapping[str, set[str]]) -> list[str] | None:
    """A cycle of the containment graph as a closed path (`A -> B -> A`), or None."""
    try:
        graphlib.TopologicalSorter(inside).prepare()
    except graphlib.CycleError as exc:
        return list(exc.args[1])
    return None


def _check_nothing_inside_itself(ctl: Controller) -> Sequence[Metadata] | None:
    """Put one portable receptacle into another, pick the outer one up and try to put it
    into the inner one: the backend must refuse. None when the scene has no two portable
    receptacles or a setup step fails (a physical backend may find no room)."""
    portable = [
        o["objectId"] for o in ctl.last_metadata()[0]["objects"]
        if o.get("pickupable") and o.get("receptacle")
    ]
    if len(portable) < 2:
        return None
    inner, outer = portable[:2]
    for agent in range(ctl.agent_count):
        if ctl.last_metadata()[agent]["inventoryObjects"]:
            _step(ctl, "DropHandObject", agentId=agent, forceAction=True)
    for target in (inner, outer):
        if _is_closed(ctl, target):
            _step(ctl, "OpenObject", agentId=0, objectId=target, forceAction=True)
    setup = (
        ("PickupObject", {"objectId": inner}),
        ("PutObject", {"objectId": outer, "placeStationary": True}),
        ("PickupObject", {"objectId": outer}),
    )
    for action, kwargs in setup:
        if not _step(ctl, action, agentId=0, forceAction=True, **kwargs)[0]["lastActionSuccess"]:
            return None
    md = _step(ctl, "PutObject", agentId=0, objectId=inner, forceAction=True,
               placeStationary=True)
    _expect(not md[0]["lastActionSuccess"],
            f"putting {outer} into {inner}, which lies inside it, must fail")
    return md


def _is_closed(ctl: Controller, object_id: str) -> bool:
    record = next(o for o in ctl.last_metadata()[0]["objects"] if o["objectId"] == object_id)
    return bool(record.get("openable")) and not record.get("isOpen")


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

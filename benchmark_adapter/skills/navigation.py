"""Find: teleport navigation to a pose from which the object is visible (reference §4.3)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from benchmark_adapter.skills.native import NativeSession, find_object
from benchmark_adapter.skills.result import SkillResult

MIN_AGENT_SEPARATION = 0.45  # metres, horizontal: Find never picks a pose this close to a teammate
FALLBACK_CANDIDATES = 16
AGENT_EYE_HEIGHT = 0.9


def find(session: NativeSession, object_id: str) -> SkillResult:
    """Go where `object_id` is visible, avoiding teammates; teleport back on failure."""
    if session.object(object_id) is None:
        return session.result.fail(f"Object not found in metadata: {object_id}")
    start = _pose(session.me["agent"])
    ok, error = _via_interactable_poses(session, object_id, start)
    if ok is None:  # no pose was even tried: fall back to reachable positions
        ok, error = _fallback(session, object_id)
    if ok:
        return session.finish(session.me)
    session.act("TeleportFull", **start)
    return session.result.fail(error)


def _via_interactable_poses(
    session: NativeSession, object_id: str, start: dict[str, Any]
) -> tuple[bool | None, str]:
    """Try interactable poses nearest first, skipping those next to a teammate.

    Returns (True, "") on success, (False, error) when a teleport failed, and (None, "")
    when there was nothing to try.
    """
    own = session.act("GetInteractablePoses", objectId=object_id)
    poses = own["actionReturn"] if own["lastActionSuccess"] else None
    others = _other_positions(session)
    sx, sy, sz = start["x"], start["y"], start["z"]
    nearest_first = sorted(
        poses or [], key=lambda p: (p["x"] - sx) ** 2 + (p["y"] - sy) ** 2 + (p["z"] - sz) ** 2
    )
    last_error = ""
    for pose in nearest_first:
        if _near_other(pose, others):
            continue
        own = session.act("TeleportFull", **_teleport_args(pose))
        if _sees(own, object_id):
            return True, ""
        last_error = own["errorMessage"] or ""
    return (False, last_error) if last_error else (None, "")


def _fallback(session: NativeSession, object_id: str) -> tuple[bool, str]:
    """Reachable positions nearest the object, facing it, trying a few camera horizons."""
    target = session.object(object_id)["position"]
    own = session.act("GetReachablePositions")
    if not own["lastActionSuccess"]:
        return False, own["errorMessage"] or ""
    positions = own["actionReturn"] or []
    if not positions:
        return False, f"No reachable positions found for {object_id}"
    others = _other_positions(session)

    def rank(p: Mapping[str, float]) -> float:
        penalty = 1000.0 if _near_other(p, others) else 0.0
        return sum((p.get(k, 0.0) - target[k]) ** 2 for k in ("x", "y", "z")) + penalty

    horizons = (30, 0, 60, -30) if target["y"] < AGENT_EYE_HEIGHT + 0.3 else (0, 30, -30, 60)
    last_error = ""
    for p in sorted(positions, key=rank)[:FALLBACK_CANDIDATES]:
        if _near_other(p, others):
            continue
        yaw = math.degrees(math.atan2(target["x"] - p["x"], target["z"] - p["z"])) % 360.0
        for horizon in horizons:
            own = session.act(
                "TeleportFull",
                x=p["x"],
                y=p.get("y", 0.9),
                z=p["z"],
                rotation=yaw,
                horizon=horizon,
                standing=True,
            )
            if _sees(own, object_id):
                return True, ""
            last_error = own["errorMessage"] or ""
    return False, last_error or f"Could not navigate to a visible, unoccupied pose for {object_id}"


def _sees(own: Mapping[str, Any], object_id: str) -> bool:
    if not own["lastActionSuccess"]:
        return False
    obj = find_object(own, object_id)
    return bool(obj and obj["visible"])


def _pose(agent: Mapping[str, Any]) -> dict[str, Any]:
    p = agent["position"]
    return {
        "x": p["x"],
        "y": p["y"],
        "z": p["z"],
        "rotation": agent["rotation"]["y"],
        "horizon": agent["cameraHorizon"],
        "standing": agent.get("isStanding", True),
    }


def _teleport_args(pose: Mapping[str, Any]) -> dict[str, Any]:
    return {
        "x": pose["x"],
        "y": pose["y"],
        "z": pose["z"],
        "rotation": pose["rotation"],
        "horizon": pose["horizon"],
        "standing": pose.get("standing", True),
    }


def _other_positions(session: NativeSession) -> list[tuple[float, float]]:
    out = []
    for i, md in enumerate(session.metadata):
        if i != session.agent:
            p = md["agent"]["position"]
            out.append((p["x"], p["z"]))
    return out


def _near_other(p: Mapping[str, Any], others: Sequence[tuple[float, float]]) -> bool:
    return any(math.hypot(p["x"] - x, p["z"] - z) < MIN_AGENT_SEPARATION for x, z in others)

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
        return session.result.fail(f"Object {object_id} does not exist in the scene")
    start = _pose(session.me["agent"])
    others = _other_positions(session)
    last_error = ""
    own = session.act("GetInteractablePoses", objectId=object_id)
    poses = own["actionReturn"] if own["lastActionSuccess"] else None
    sx, sy, sz = start["x"], start["y"], start["z"]
    nearest_first = sorted(
        poses or [], key=lambda p: (p["x"] - sx) ** 2 + (p["y"] - sy) ** 2 + (p["z"] - sz) ** 2
    )
    for pose in nearest_first:
        if _near_other(pose, others):
            continue
        own = session.act("TeleportFull", **_teleport_args(pose))
        if _sees(own, object_id):
            return session.finish(own)
        last_error = own["errorMessage"] or last_error
    found, last_error = _fallback(session, object_id, others, last_error)
    if found:
        return session.finish(session.me)
    session.act("TeleportFull", **start)
    return session.result.fail(
        last_error or f"Could not navigate to a visible, unoccupied pose for {object_id}"
    )


def _fallback(
    session: NativeSession, object_id: str, others: list[tuple[float, float]], last_error: str
) -> tuple[bool, str]:
    """Reachable positions nearest the object, facing it, trying a few camera horizons."""
    obj = session.object(object_id)
    own = session.act("GetReachablePositions")
    positions = own["actionReturn"] if own["lastActionSuccess"] else []
    target = obj["position"]

    def rank(p: Mapping[str, float]) -> float:
        penalty = 1000.0 if _near_other(p, others) else 0.0
        return (p["x"] - target["x"]) ** 2 + (p["z"] - target["z"]) ** 2 + penalty

    horizons = (30, 0, 60, -30) if target["y"] < AGENT_EYE_HEIGHT + 0.3 else (0, 30, -30, 60)
    for p in sorted(positions or [], key=rank)[:FALLBACK_CANDIDATES]:
        if _near_other(p, others):
            continue
        yaw = math.degrees(math.atan2(target["x"] - p["x"], target["z"] - p["z"])) % 360.0
        for horizon in horizons:
            own = session.act(
                "TeleportFull",
                x=p["x"],
                y=p["y"],
                z=p["z"],
                rotation=yaw,
                horizon=horizon,
                standing=True,
            )
            if _sees(own, object_id):
                return True, last_error
            last_error = own["errorMessage"] or last_error
    return False, last_error


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

"""Find: teleport navigation to a pose from which the object is visible (reference §4.3)."""

from __future__ import annotations

import heapq
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
    poses, _ = _query(session, "GetInteractablePoses", objectId=object_id)
    others = _other_positions(session)
    sx, sy, sz = start["x"], start["y"], start["z"]
    nearest_first = sorted(
        poses or [], key=lambda p: (p["x"] - sx) ** 2 + (p["y"] - sy) ** 2 + (p["z"] - sz) ** 2
    )
    last_error = ""
    for pose in nearest_first:
        if _near_other(pose, others):
            continue
        error = _teleport_sees(session, object_id, **_teleport_args(pose))
        if error is None:
            return True, ""
        last_error = error
    return (False, last_error) if last_error else (None, "")


def _fallback(session: NativeSession, object_id: str) -> tuple[bool, str]:
    """Reachable positions nearest the object, facing it, trying a few camera horizons."""
    target = session.object(object_id)["position"]
    positions, error = _query(session, "GetReachablePositions")
    if error is not None:
        return False, error
    positions = positions or []
    if not positions:
        return False, f"No reachable positions found for {object_id}"
    others = _other_positions(session)
    tx, ty, tz = target["x"], target["y"], target["z"]

    def rank(p: Mapping[str, float]) -> float:
        penalty = 1000.0 if _near_other(p, others) else 0.0
        # sum(), as before (Python 3.12's sum of floats is compensated, unlike `+`).
        squares = ((p.get("x", 0.0) - tx) ** 2, (p.get("y", 0.0) - ty) ** 2,
                   (p.get("z", 0.0) - tz) ** 2)
        return sum(squares) + penalty

    horizons = (30, 0, 60, -30) if target["y"] < AGENT_EYE_HEIGHT + 0.3 else (0, 30, -30, 60)
    last_error = ""
    # nsmallest is sorted(...)[:n], ties kept in order, without sorting every position.
    for p in heapq.nsmallest(FALLBACK_CANDIDATES, positions, key=rank):
        if _near_other(p, others):
            continue
        yaw = math.degrees(math.atan2(target["x"] - p["x"], target["z"] - p["z"])) % 360.0
        for horizon in horizons:
            error = _teleport_sees(
                session,
                object_id,
                x=p["x"],
                y=p.get("y", 0.9),
                z=p["z"],
                rotation=yaw,
                horizon=horizon,
                standing=True,
            )
            if error is None:
                return True, ""
            last_error = error
    return False, last_error or f"Could not navigate to a visible, unoccupied pose for {object_id}"


def _query(session: NativeSession, action: str, **kwargs: Any) -> tuple[Any, str | None]:
    """Run a query: (its actionReturn, None) on success, else (None, its error message).

    The helpers below keep no metadata past their own action: a backend may have to build
    every snapshot still held in full before the next change (the embedded one does).
    """
    own = session.act(action, **kwargs)
    if own["lastActionSuccess"]:
        return own["actionReturn"], None
    return None, own["errorMessage"] or ""


def _teleport_sees(session: NativeSession, object_id: str, **pose: Any) -> str | None:
    """Teleport to `pose`: None when `object_id` is then visible, else the error ("" if
    none)."""
    own = session.act("TeleportFull", **pose)
    if _sees(own, object_id):
        return None
    return own["errorMessage"] or ""


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
    # A plain loop, not any() over a generator: a Find's fallback ranks every reachable
    # position with it.
    px, pz = p["x"], p["z"]
    for x, z in others:  # noqa: SIM110
        if math.hypot(px - x, pz - z) < MIN_AGENT_SEPARATION:
            return True
    return False

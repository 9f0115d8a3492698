"""Find: teleport navigation to a pose from which the object is visible (reference §4.3)."""

from __future__ import annotations

import heapq
import math
import threading
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
    nearest = heapq.nsmallest(FALLBACK_CANDIDATES, _contenders(positions, target, others),
                              key=rank)
    for p in nearest:
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


def _contenders(positions: Sequence[Mapping[str, float]], target: Mapping[str, float],
                others: Sequence[tuple[float, float]]) -> Sequence[Mapping[str, float]]:
    """The positions, in their order, that can be among the `FALLBACK_CANDIDATES` nearest
    `target` by `_fallback`'s rank: those whose rank, estimated with numpy, is within a
    relative 1e-9 of the estimated last candidate's. Ranking every position in Python took
    1.3 ms a fallback (about 590 positions), this 0.25 ms, under D1_image's random play. The
    estimate cannot pick the candidates itself: Python's `x ** 2` (the C library's pow)
    differs from `x * x` in the last bit for about 1 value in 1,200, and Python 3.12's
    sum() compensates; both are errors of ~1e-16 relative, so the exact rank, run on the
    contenders alone, chooses as it would over them all, ties in list order."""
    if len(positions) <= FALLBACK_CANDIDATES:
        return positions
    import numpy  # here: a fallback is rare, and numpy takes a while to import

    xs, ys, zs = _coordinates(positions)
    offset = xs - target["x"]
    estimate = offset * offset
    for column, centre in ((ys, target["y"]), (zs, target["z"])):
        offset = column - centre
        estimate += offset * offset
    near = numpy.zeros(len(positions), dtype=bool)
    for x, z in others:  # numpy's hypot is the C library's, as `_near_other`'s
        near |= numpy.hypot(xs - x, zs - z) < MIN_AGENT_SEPARATION
    estimate[near] += 1000.0
    last = numpy.partition(estimate, FALLBACK_CANDIDATES - 1)[FALLBACK_CANDIDATES - 1]
    keep = ~(estimate > last + abs(last) * 1e-9 + 1e-12)  # NaN kept: the exact rank judges
    return [positions[i] for i in numpy.flatnonzero(keep)]


#: The coordinates of the last few position lists, by the list (kept, so its id stays its
#: own): the embedded simulator answers every GetReachablePositions of a floor with the same
#: read-only list, and reading 576 positions into an array took 0.8 ms, more than ranking.
_KEPT_COORDINATES = 64
_coordinates_kept: dict[int, tuple[Sequence[Mapping[str, float]], tuple]] = {}
_coordinates_lock = threading.Lock()


def _coordinates(positions: Sequence[Mapping[str, float]]) -> tuple[Any, Any, Any]:
    """The positions' x, y and z as read-only numpy arrays (an absent one 0, as `rank`)."""
    import numpy

    with _coordinates_lock:
        kept = _coordinates_kept.get(id(positions))
    if kept is not None:
        return kept[1]
    columns = tuple(numpy.array([p.get(axis, 0.0) for p in positions], dtype=float)
                    for axis in "xyz")
    for column in columns:
        column.flags.writeable = False
    with _coordinates_lock:  # episodes may play in threads (the renderer's caches: alike)
        if len(_coordinates_kept) >= _KEPT_COORDINATES:
            _coordinates_kept.pop(next(iter(_coordinates_kept)))
        _coordinates_kept[id(positions)] = (positions, columns)
    return columns


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

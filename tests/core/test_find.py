"""Find (reference §4.3): teleport to a pose from which the object is visible, never within
0.45 m of a teammate, back to the start pose on failure."""

from __future__ import annotations

import heapq
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmark_adapter.skills.navigation import (
    FALLBACK_CANDIDATES,
    MIN_AGENT_SEPARATION,
    _contenders,
    _near_other,
)

from .worlds import (
    DRAWER_A,
    FRIDGE,
    GHOST,
    KITCHEN,
    KNIFE,
    LIGHT,
    PLATE,
    TOMATO,
    Sim,
    make_config,
    make_sim,
)


def test_separation_constant_is_the_references() -> None:
    assert MIN_AGENT_SEPARATION == 0.45


def _distance(sim: Sim, a: int, b: int) -> float:
    pa, pb = sim.world.agents[a], sim.world.agents[b]
    return math.hypot(pa.x - pb.x, pa.z - pb.z)


def _landing(sim: Sim, agent: int, object_id: str) -> tuple[float, float]:
    result = sim.run(f"Find(agent_{agent + 1}, {object_id})")
    assert result.success, result.errorMessage
    a = sim.world.agents[agent]
    return a.x, a.z


@pytest.mark.parametrize("object_id", sorted(set(KITCHEN.values())))
def test_find_makes_the_object_visible(object_id: str) -> None:
    sim = make_sim()
    result = sim.run(f"Find(agent_1, {object_id})")
    assert result.success is True and result.errorMessage == ""
    assert sim.obj(object_id, 0)["visible"] is True
    # the acting agent's metadata says so; the other agent has not moved
    assert result.native_trace[-1]["lastActionSuccess"] is True


def test_find_is_deterministic() -> None:
    first, second = make_sim(), make_sim()
    assert _landing(first, 0, TOMATO) == _landing(second, 0, TOMATO)
    assert first.pose(0) == second.pose(0)


def test_find_avoids_the_pose_a_teammate_stands_on() -> None:
    free = make_sim()
    best = _landing(free, 0, TOMATO)

    sim = make_sim()
    sim.place(1, *best)
    landed = _landing(sim, 0, TOMATO)
    assert landed != best
    assert _distance(sim, 0, 1) >= 0.45
    assert sim.obj(TOMATO, 0)["visible"] is True


@pytest.mark.parametrize("object_id", [TOMATO, FRIDGE, LIGHT, PLATE])
def test_find_never_lands_next_to_any_teammate(object_id: str) -> None:
    """Block the three best poses in turn with agents 2–4; Find still keeps 0.45 m away."""
    config = make_config(agents=4)
    blocked: list[tuple[float, float]] = []
    for k in range(1, 4):
        probe = make_sim(config)
        for i, (x, z) in enumerate(blocked, start=1):
            probe.place(i, x, z)
        for i in range(len(blocked) + 1, 4):  # park the rest in a far corner row
            probe.place(i, 3.0, -2.75 + 0.75 * i, 0.0)
        blocked.append(_landing(probe, 0, object_id))
        for other in range(1, 4):
            assert _distance(probe, 0, other) >= 0.45, (k, other)
        assert probe.obj(object_id, 0)["visible"] is True
    assert len(set(blocked)) == 3


def test_find_succeeds_from_many_starts_with_teammate_nearby() -> None:
    sim = make_sim()
    for x, z in [(-2.5, -2.5), (2.5, 2.5), (0.0, -2.0), (-2.0, 2.25)]:
        sim.place(0, x, z, 90.0)
        sim.place(1, *_landing(make_sim(), 0, KNIFE))
        assert sim.run(f"Find(agent_1, {KNIFE})").success
        assert _distance(sim, 0, 1) >= 0.45


def _boxed_in() -> Sim:
    """Every cell from which the Tomato can be seen lies next to agent_2.

    The walkable floor is cut down to the 3×3 block around agent_2 (0.5, 0.75), next to the
    Tomato (0.5, 0.2), plus agent_1's own cell far away (3.0, 3.0).
    """
    sim = make_sim()
    cells = {(cx, cz) for cx in (1, 2, 3) for cz in (2, 3, 4)} | {(12, 12)}
    sim.world.floor = frozenset(cells)
    sim.place(0, 3.0, 3.0, 90.0, 30.0)
    sim.place(1, 0.5, 0.75, 180.0)
    return sim


def test_find_fails_when_every_pose_is_occupied() -> None:
    sim = _boxed_in()
    start = sim.pose(0)
    result = sim.run(f"Find(agent_1, {TOMATO})")
    assert result.success is False
    assert result.errorMessage == (
        "Could not navigate to a visible, unoccupied pose for Tomato|+00.50|+00.95|+00.20")
    assert sim.pose(0) == start  # teleported back to the start pose
    assert sim.obj(TOMATO, 0)["visible"] is False
    assert result.native_trace[-1]["action"]["action"] == "TeleportFull"
    # no teleport ever targeted a cell next to agent_2
    for entry in result.native_trace:
        action = entry["action"]
        if action["action"] == "TeleportFull":
            assert math.hypot(action["x"] - 0.5, action["z"] - 0.75) >= 0.45


def test_find_fails_for_an_object_shut_in_a_closed_drawer(kitchen: Sim) -> None:
    for call in [f"Open(agent_1, {DRAWER_A})", f"PickUp(agent_1, {TOMATO})",
                 f"Put(agent_1, {DRAWER_A})", f"Close(agent_1, {DRAWER_A})"]:
        assert kitchen.run(call).success, call
    start = kitchen.pose(1)
    result = kitchen.run(f"Find(agent_2, {TOMATO})")
    assert result.success is False
    assert result.errorMessage == (
        "Could not navigate to a visible, unoccupied pose for Tomato|+00.50|+00.95|+00.20")
    assert kitchen.pose(1) == start
    natives = [t["action"]["action"] for t in result.native_trace]
    assert "GetReachablePositions" in natives  # the fallback was tried
    assert natives[-1] == "TeleportFull"
    assert all(t["action"]["agentId"] == 1 for t in result.native_trace)


def test_find_a_missing_object(kitchen: Sim) -> None:
    start = kitchen.pose(0)
    result = kitchen.run(f"Find(agent_1, {GHOST})")
    assert result.success is False
    assert GHOST in result.errorMessage
    assert result.native_trace == []
    assert kitchen.pose(0) == start


def _nearest_by_ranking_all(positions, target, others):
    """The fallback's candidates as it chose them before `_contenders`: every position
    ranked in Python."""
    tx, ty, tz = target["x"], target["y"], target["z"]

    def rank(p):
        penalty = 1000.0 if _near_other(p, others) else 0.0
        return sum(((p.get("x", 0.0) - tx) ** 2, (p.get("y", 0.0) - ty) ** 2,
                    (p.get("z", 0.0) - tz) ** 2)) + penalty
    return heapq.nsmallest(FALLBACK_CANDIDATES, positions, key=rank), rank


# A target among the positions (-3 to 3 m), on the grid (ties) or off it.
_coordinate = st.one_of(st.integers(-12, 12).map(lambda k: k * 0.25), st.floats(-3, 3))


@settings(max_examples=300, deadline=None)
@given(cells=st.lists(st.tuples(st.integers(-12, 12), st.integers(-12, 12)), min_size=0,
                      max_size=120, unique=True),
       target=st.tuples(_coordinate, st.floats(0, 2), _coordinate),
       others=st.lists(st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5)), max_size=3))
def test_the_fallback_picks_the_candidates_ranking_every_position_picks(cells, target,
                                                                         others) -> None:
    """A Find's fallback ranks only the positions numpy's estimate keeps (`_contenders`):
    its candidates, in their order, must be those the exact rank picks over every position,
    ties (a grid's symmetric cells, a target on the grid) among them."""
    positions = [{"x": cx * 0.25, "y": 0.9, "z": cz * 0.25} for cx, cz in cells]
    target = dict(zip("xyz", target))
    # Teammates about the target, where they push candidates out (`rank`'s penalty).
    others = [(target["x"] + dx, target["z"] + dz) for dx, dz in others]
    expected, rank = _nearest_by_ranking_all(positions, target, others)
    chosen = heapq.nsmallest(FALLBACK_CANDIDATES, _contenders(positions, target, others),
                             key=rank)
    assert chosen == expected
    assert all(a is b for a, b in zip(chosen, expected))


def test_the_fallback_reads_each_list_its_own_coordinates_from_threads() -> None:
    """The fallback keeps the coordinates of the last position lists by the list's id, the
    list kept with them so that no other list can take its id. Eight threads (episodes may
    play in threads) rank lists made afresh and dropped each time, more of them than are
    kept: each must get its own list's candidates, never another's whose id it reuses."""
    import random
    import sys
    from concurrent.futures import ThreadPoolExecutor

    target = {"x": 0.1, "y": 0.9, "z": -0.2}

    def positions(kind: int) -> list[dict[str, float]]:
        cells = random.Random(kind).sample(range(625), 40)
        return [{"x": (c % 25 - 12) * 0.25, "y": 0.9, "z": (c // 25 - 12) * 0.25}
                for c in cells]

    kinds = range(150)
    expected = {k: _nearest_by_ranking_all(positions(k), target, [])[0] for k in kinds}

    def play(seed: int) -> None:
        rng = random.Random(seed)
        for _ in range(300):
            kind = rng.choice(kinds)
            made = positions(kind)
            rank = _nearest_by_ranking_all(made, target, [])[1]
            assert heapq.nsmallest(FALLBACK_CANDIDATES, _contenders(made, target, []),
                                   key=rank) == expected[kind], kind

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # threads switch often, inside the cache's reads and writes
    try:
        with ThreadPoolExecutor(8) as pool:
            list(pool.map(play, range(8)))
    finally:
        sys.setswitchinterval(interval)

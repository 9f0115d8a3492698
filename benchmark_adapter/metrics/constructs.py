"""Construct scores C_D1..C_D4 with the reference's evidence gating (reference §7.4).

Each dimension has a *sample* (how often its mechanism was exercised) and a
*formula*. The gate withholds the score (``score=None``) and says why: no steps
(``na_no_actions``), sample 0 (``not_engaged``), sample < 2 (``low_signal``),
formula has no signal (``na``); otherwise ``scored``. The formula only runs once
the sample passes the gate, as in the reference.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.vocabulary import (
    DIMENSIONS,
    LOAD_BALANCING,
    MUTUAL_EXCLUSION,
    PRECEDENCE,
    PRODUCER_CONSUMER,
)

from .errors import TrajectoryError
from .general import n_agents, per_agent_actions
from .steps import (
    AFFORDANCE_MARKERS,
    CONCURRENCY_MARKERS,
    INTERACTION_SKILLS,
    INTRINSIC_PRECONDITION_MARKERS,
    NOOP_MARKERS,
    OCCUPANCY_MARKERS,
    Step,
    allowed_skills_by_agent,
    classify_step,
    extract_steps,
    has_marker,
    task_config,
)

STATUSES: tuple[str, ...] = ("scored", "not_engaged", "low_signal", "na", "na_no_actions")
#: Fewest mechanism events a rate may rest on (the reference's CONSTRUCT_MIN_SAMPLE).
MIN_SAMPLE = 2
# D2 counts only chain operations on objects whose config alias names a container.
CONTAINER_ALIAS_MARKERS = ("container", "basket", "drawer")
CHAIN_SKILLS = frozenset({"Open", "Put", "Close"})
# D3 station mode: skills that need the station when the config names none.
DEFAULT_LOCK_SKILLS = frozenset({"CleanObject", "FillObjectWithLiquid", "EmptyLiquidFromObject"})
D2_ILLEGAL_FACTOR = 0.5


@dataclass(frozen=True)
class ConstructScore:
    """One construct score: ``score`` is None unless ``status == "scored"``.

    ``sample`` is the evidence count the gate used; ``evidence`` holds the
    formula's inputs (empty when the gate stopped before the formula ran).
    """

    dim: str
    score: float | None
    status: str
    sample: int
    evidence: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ConstructEvidence:
    """What the formula of a trajectory's own dimension sees, landed step by landed step and
    without the gate: for drawing the mechanism (the viewer), never for scoring.

    ``history[k]`` is the formula's evidence after the first k + 1 landed steps, ``{}`` while
    the mechanism has not been exercised (the formula is undefined there). The other fields
    are the mechanism the formula watches, empty for the other dimensions: D2's containers;
    D3's exclusion mode (``shared_tool``, ``station`` or ``competitive``) and its keys
    (resource ids or lock skills); D4's declared buffers, their capacity and their occupancy
    after each landed step (none declared: no buffer fields).
    """

    dim: str
    history: tuple[dict[str, Any], ...]
    containers: tuple[str, ...] = ()
    exclusion_mode: str = ""
    exclusion_keys: frozenset[str] = frozenset()
    buffer_ids: tuple[str, ...] = ()
    buffer_capacity: float | None = None
    buffer_occupancy: tuple[int, ...] = ()


@dataclass(frozen=True)
class _Episode:
    config: Mapping[str, Any]
    constraints: Mapping[str, Any]
    steps: list[Step]
    categories: list[str]


Formula = tuple[float | None, dict[str, Any]]


def _clip01(x: float) -> float:
    return max(0.0, min(1.0, x))


def _number(value: Any, field_path: str) -> float | None:
    """A declared makespan/capacity: None when absent, else it must be a number."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TrajectoryError(field_path, "must be a number")
    return value


def _episode(traj: Mapping[str, Any]) -> _Episode:
    config = task_config(traj)
    steps = extract_steps(traj)
    allowed = allowed_skills_by_agent(config)
    return _Episode(
        config,
        config.get("task_constraints") or {},
        steps,
        [classify_step(s, allowed) for s in steps],
    )


# ---- D1: load balancing --------------------------------------------------------------


def _d1_sample(ep: _Episode) -> int:
    return len(ep.steps)


def _d1_formula(ep: _Episode) -> Formula:
    counts = per_agent_actions(ep.steps)
    n, total = n_agents(ep.config), sum(counts.values())
    makespan = max(counts.values(), default=0)
    declared = _number(
        ep.constraints.get("optimal_makespan"), "task_config.task_constraints.optimal_makespan"
    )
    reference = declared or -(-total // max(n, 1))  # ceil(total / n) when undeclared
    evidence = {
        "n_agents": n,
        "total_steps": total,
        "makespan": makespan,
        "reference_makespan": reference,
        "reference_source": "task_constraints" if declared else "ceil_total_over_n",
    }
    if makespan == 0 or n < 2:
        return None, evidence
    return _clip01(reference / makespan), evidence


# ---- D2: precedence ---------------------------------------------------------------------


def _d2_sample(ep: _Episode) -> int:
    return sum(1 for s in ep.steps if s.success and s.skill in INTERACTION_SKILLS)


def _container_ids(config: Mapping[str, Any]) -> list[str]:
    init_state = config.get("init_state")
    objects = (init_state.get("objects") if isinstance(init_state, Mapping) else None) or {}
    # Case-sensitive alias test, as in the reference (released aliases are lower case).
    return sorted(
        {
            str(oid)
            for alias, oid in objects.items()
            if any(m in alias for m in CONTAINER_ALIAS_MARKERS)
        }
    )


def _d2_ignored_failure(error: str) -> bool:
    # Failures that are not ordering mistakes: no-ops, pose/hand contention, empty/full hand.
    return any(
        has_marker(error, m)
        for m in (
            NOOP_MARKERS,
            OCCUPANCY_MARKERS,
            INTRINSIC_PRECONDITION_MARKERS,
            CONCURRENCY_MARKERS,
        )
    )


def _d2_formula(ep: _Episode) -> Formula:
    if not ep.constraints.get("precedence"):
        return None, {"reason": "no task_constraints.precedence"}
    containers = _container_ids(ep.config)
    chain = [
        s
        for s in ep.steps
        if s.skill in CHAIN_SKILLS and (not containers or s.target_id in containers)
    ]  # no containers: all ops
    correct = sum(1 for s in chain if s.success)
    violations = sum(1 for s in chain if not s.success and not _d2_ignored_failure(s.error))
    legal = "illegal_skill" not in ep.categories and "precondition_violation" not in ep.categories
    factor = 1.0 if legal else D2_ILLEGAL_FACTOR
    evidence = {
        "container_ids": containers,
        "correct": correct,
        "violations": violations,
        "legal_plan": legal,
        "legality_factor": factor,
    }
    if correct + violations == 0:
        return None, evidence
    return _clip01(1 - violations / (correct + violations)) * factor, evidence


# ---- D3: mutual exclusion ---------------------------------------------------------------

_D3_KEY_NAMES = {
    "shared_tool": "resource_ids",
    "station": "lock_skills",
    "competitive": "resource_ids",
}


def _d3_mode(constraints: Mapping[str, Any]) -> tuple[str, frozenset[str]]:
    """("shared_tool", resource ids) | ("station", lock skills) | ("competitive", {})."""
    entries = [r for r in constraints.get("resource_exclusion") or [] if isinstance(r, Mapping)]
    resource_ids = frozenset(str(r["resource_id"]) for r in entries if r.get("resource_id"))
    if resource_ids:
        return "shared_tool", resource_ids
    lock = frozenset(s for r in entries for s in r.get("skills_requiring_lock") or [])
    if lock or constraints.get("exclusive_resources"):
        return "station", lock or DEFAULT_LOCK_SKILLS
    return "competitive", frozenset()


def _d3_accesses(ep: _Episode) -> tuple[str, frozenset[str], list[Step]]:
    mode, keys = _d3_mode(ep.constraints)
    if mode == "shared_tool":
        access = [s for s in ep.steps if s.skill == "PickUp" and s.target_id in keys]
    elif mode == "station":
        access = [s for s in ep.steps if s.skill in keys]
    else:
        access = [s for s in ep.steps if s.skill == "PickUp" and s.target_id]
    return mode, keys, access


def _d3_sample(ep: _Episode) -> int:
    return len(_d3_accesses(ep)[2])


def _d3_collisions(mode: str, access: list[Step]) -> int:
    if mode == "shared_tool":  # PickUp refused because a teammate holds the tool
        return sum(
            1 for s in access if not s.success and has_marker(s.error, ("held by another agent",))
        )
    if mode == "station":  # any non-no-op failure of a station skill was a denial
        return sum(1 for s in access if not s.success and not has_marker(s.error, NOOP_MARKERS))
    return len(access) - len({s.target_id for s in access})  # duplicate claims


def _d3_formula(ep: _Episode) -> Formula:
    mode, keys, access = _d3_accesses(ep)
    collisions = _d3_collisions(mode, access)
    contention = _clip01(1 - collisions / len(access))
    # M* is the config's *top-level* optimal_makespan (K configs only); absent => 1.0.
    reference = _number(ep.config.get("optimal_makespan"), "task_config.optimal_makespan")
    efficiency = _clip01(reference / len(ep.steps)) if reference else 1.0
    evidence = {
        "mode": mode,
        _D3_KEY_NAMES[mode]: sorted(keys),
        "accesses": len(access),
        "collisions": collisions,
        "contention": contention,
        "reference_makespan": reference,
        "landed_steps": len(ep.steps),
        "efficiency": efficiency,
    }
    return _clip01(contention * efficiency), evidence


# ---- D4: producer-consumer ----------------------------------------------------------------


def _buffers(constraints: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    return [
        b
        for b in constraints.get("buffer_stations") or []
        if isinstance(b, Mapping) and b.get("objectId")
    ]


def _capacity(buffer: Mapping[str, Any]) -> float:
    value = _number(buffer.get("capacity"), "task_config.task_constraints.buffer_stations.capacity")
    return 1 if value is None else value  # the reference's default capacity


def _d4_sample(ep: _Episode) -> int:
    ids = {b["objectId"] for b in _buffers(ep.constraints)}
    if ids:
        return sum(1 for s in ep.steps if s.skill == "Put" and s.success and s.target_id in ids)
    return sum(1 for s in ep.steps if s.skill in {"Put", "PickUp"})


def _occupancy(step: Step, buffer_ids: set[str]) -> int:
    """Tracked objects resting on a buffer in the step's recorded post-step state."""
    if step.objects is None:
        raise TrajectoryError(
            f"trajectory[{step.index}].state.objects",
            "D4 needs the recorded object state of every step",
        )
    return sum(
        1
        for obj in step.objects.values()
        if isinstance(obj, Mapping)
        and any(b in (obj.get("parentReceptacles") or []) for b in buffer_ids)
    )


def _d4_overflows(ep: _Episode, ids: set[str], capacity: float) -> tuple[int, int]:
    rises, previous = 0, 0
    for step in ep.steps:  # an insertion pushing the buffer past capacity counts once
        occupancy = _occupancy(step, ids)
        rises += int(occupancy > capacity and occupancy > previous)
        previous = occupancy
    refused = sum(
        1
        for s in ep.steps
        if s.skill == "Put"
        and not s.success
        and s.target_id in ids
        and has_marker(s.error, AFFORDANCE_MARKERS)
    )
    return rises, refused


def _d4_formula(ep: _Episode) -> Formula:
    buffers = _buffers(ep.constraints)
    if not buffers:  # no declared buffer: penalise misplacements and waits per transfer
        transfers = sum(1 for s in ep.steps if s.skill in {"Put", "PickUp"})
        misses, waits = ep.categories.count("affordance_miss"), ep.categories.count("idle_wait")
        evidence = {
            "mode": "no_buffer",
            "transfers": transfers,
            "affordance_failures": misses,
            "wait_steps": waits,
        }
        return _clip01(1 - (misses + waits) / (transfers or 1)), evidence
    ids = {str(b["objectId"]) for b in buffers}
    capacity = max(_capacity(b) for b in buffers)
    handoffs = _d4_sample(ep)
    rises, refused = _d4_overflows(ep, ids, capacity)
    # Any Wait (even an illegal one) taken while the buffer is empty starves the consumer.
    starved = sum(1 for s in ep.steps if s.skill == "Wait" and _occupancy(s, ids) == 0)
    evidence = {
        "mode": "buffer",
        "buffer_ids": sorted(ids),
        "capacity": capacity,
        "handoffs": handoffs,
        "overflows": rises + refused,
        "occupancy_overflows": rises,
        "refused_put_overflows": refused,
        "starved_waits": starved,
    }
    # handoffs >= MIN_SAMPLE here: the gate already turned h = 0 into not_engaged.
    return _clip01(1 - (rises + refused + starved) / handoffs), evidence


# ---- gating ------------------------------------------------------------------------------


def _unknown_sample(ep: _Episode) -> int:
    return _d2_sample(ep)  # the reference's default evidence: successful interactions


_DIMS: dict[str, tuple[Callable[[_Episode], int], Callable[[_Episode], Formula]]] = {
    LOAD_BALANCING: (_d1_sample, _d1_formula),
    PRECEDENCE: (_d2_sample, _d2_formula),
    MUTUAL_EXCLUSION: (_d3_sample, _d3_formula),
    PRODUCER_CONSUMER: (_d4_sample, _d4_formula),
}


def _gate(dim: str, ep: _Episode) -> ConstructScore:
    if not ep.steps:
        return ConstructScore(dim, None, "na_no_actions", 0)
    sample_fn, formula = _DIMS.get(dim, (_unknown_sample, lambda _ep: (None, {})))
    sample = sample_fn(ep)
    if sample == 0:
        return ConstructScore(dim, None, "not_engaged", 0)
    if sample < MIN_SAMPLE:
        return ConstructScore(dim, None, "low_signal", sample)
    score, evidence = formula(ep)
    return ConstructScore(dim, score, "scored" if score is not None else "na", sample, evidence)


def construct_score(traj: Mapping[str, Any]) -> ConstructScore:
    """The construct score for the config's own ``coordination_dim``."""
    return _gate(_own_dim(traj), _episode(traj))


def _own_dim(traj: Mapping[str, Any]) -> str:
    dim = task_config(traj).get("coordination_dim")
    if not isinstance(dim, str) or not dim:
        raise TrajectoryError("task_config.coordination_dim", "missing or not a string")
    return dim


def cross_construct_scores(traj: Mapping[str, Any]) -> dict[str, ConstructScore]:
    """All four construct scores applied to one trajectory, each with its own gating."""
    ep = _episode(traj)
    return {dim: _gate(dim, ep) for dim in DIMENSIONS}


# ---- evidence over time --------------------------------------------------------------------


def construct_evidence(traj: Mapping[str, Any]) -> ConstructEvidence:
    """The evidence of the config's own ``coordination_dim`` (one of `DIMENSIONS`) after each
    landed step, and the mechanism it watches (`ConstructEvidence`). Raises `TrajectoryError`
    for a trajectory lacking what the formula needs (D4: every step's object state)."""
    dim = _own_dim(traj)
    if dim not in _DIMS:
        raise TrajectoryError("task_config.coordination_dim",
                              f"{dim!r} is not one of {', '.join(DIMENSIONS)}")
    ep = _episode(traj)
    sample, formula = _DIMS[dim]
    history = []
    for k in range(1, len(ep.steps) + 1):
        prefix = _Episode(ep.config, ep.constraints, ep.steps[:k], ep.categories[:k])
        history.append(formula(prefix)[1] if sample(prefix) > 0 else {})
    return ConstructEvidence(dim, tuple(history), **_MECHANISMS[dim](ep))


def _d2_mechanism(ep: _Episode) -> dict[str, Any]:
    return {"containers": tuple(_container_ids(ep.config))}


def _d3_mechanism(ep: _Episode) -> dict[str, Any]:
    mode, keys = _d3_mode(ep.constraints)
    return {"exclusion_mode": mode, "exclusion_keys": keys}


def _d4_mechanism(ep: _Episode) -> dict[str, Any]:
    buffers = _buffers(ep.constraints)
    if not buffers:
        return {}
    ids = {str(b["objectId"]) for b in buffers}
    return {"buffer_ids": tuple(sorted(ids)),
            "buffer_capacity": max(_capacity(b) for b in buffers),
            "buffer_occupancy": tuple(_occupancy(s, ids) for s in ep.steps)}


_MECHANISMS: dict[str, Callable[[_Episode], dict[str, Any]]] = {
    LOAD_BALANCING: lambda _ep: {},  # the mechanism is the steps themselves: each agent's load
    PRECEDENCE: _d2_mechanism,
    MUTUAL_EXCLUSION: _d3_mechanism,
    PRODUCER_CONSUMER: _d4_mechanism,
}


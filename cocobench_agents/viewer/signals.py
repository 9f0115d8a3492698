"""The coordination views: a per-agent Gantt of steps coloured by the benchmark's step
classification, and the construct's own signal over time.

The signal is the benchmark's construct formula run on every prefix of the episode, without
the evidence gate (`metrics.construct_evidence`), so each event (a precedence violation, a
collision, an overflow, a starved wait) is dated at the step where the formula first counts
it. Nothing here scores: the numbers are the formula's own evidence.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.metrics import ConstructEvidence, TrajectoryError, construct_evidence
from benchmark_adapter.metrics.general import per_agent_actions
from benchmark_adapter.metrics.steps import STEP_CATEGORIES, Step
from benchmark_adapter.vocabulary import (
    LOAD_BALANCING,
    MUTUAL_EXCLUSION,
    PRECEDENCE,
    PRODUCER_CONSUMER,
)

#: Evidence counters whose every increase is an event worth a marker, per dimension.
EVENT_COUNTERS: dict[str, tuple[tuple[str, str], ...]] = {
    PRECEDENCE: (("violations", "precedence violation"),),
    MUTUAL_EXCLUSION: (("collisions", "collision"),),
    PRODUCER_CONSUMER: (("occupancy_overflows", "overflow"),
                        ("refused_put_overflows", "refused put"),
                        ("starved_waits", "starved wait"), ("affordance_failures", "misplacement"),
                        ("wait_steps", "wait")),
}
TITLES = {
    LOAD_BALANCING: "Load balance: each agent's steps against the reference makespan M*",
    PRECEDENCE: "Precedence: containers open/closed and precedence violations",
    MUTUAL_EXCLUSION: "Mutual exclusion: who holds the shared resource, and each collision",
    PRODUCER_CONSUMER: "Producer-consumer: buffer occupancy, overflows and starved waits",
}


@dataclass(frozen=True)
class GanttCell:
    row: int
    slot: int
    category: str
    ordinal: int
    label: str


@dataclass
class Gantt:
    """Steps on a grid: one row per agent, one column per round (or per step when the
    planner has no rounds)."""

    agents: list[str]
    slots: int
    by_round: bool
    cells: list[GanttCell]
    categories: Sequence[str] = STEP_CATEGORIES


@dataclass(frozen=True)
class Event:
    ordinal: int  # the landed step (1-based)
    kind: str
    text: str


@dataclass
class Signal:
    """A construct's signal over the landed steps: numeric series (with an optional
    reference line), categorical tracks and dated events."""

    dim: str
    title: str
    steps: int
    series: list[tuple[str, list[float]]] = field(default_factory=list)
    reference: tuple[float, str] | None = None
    tracks: list[tuple[str, list[str]]] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    evidence: dict[str, Any] = field(default_factory=dict)
    unavailable: str | None = None

    @property
    def y_max(self) -> float:
        values = [v for _, vs in self.series for v in vs]
        if self.reference:
            values.append(self.reference[0])
        return max([1.0, *values])


def gantt(agents: Sequence[str], steps: Sequence[Step], categories: Sequence[str]) -> Gantt:
    """The Gantt of an episode's landed steps (agents outside the config get a row too)."""
    rows = list(dict.fromkeys([*agents, *(s.agent for s in steps)]))
    by_round = bool(steps) and all(isinstance(s.round_index, int) for s in steps)
    first = min((s.round_index for s in steps), default=0) if by_round else 0
    cells = [GanttCell(rows.index(s.agent), (s.round_index - first) if by_round else i, cat,
                       i + 1, _call(s))
             for i, (s, cat) in enumerate(zip(steps, categories))]
    slots = max((c.slot for c in cells), default=-1) + 1
    return Gantt(rows, slots, by_round, cells)


def construct_signal(traj: Mapping[str, Any], steps: Sequence[Step]) -> Signal:
    """The signal of the episode's own coordination dimension (`steps`: its landed steps)."""
    config = traj.get("task_config") or {}
    dim = str(config.get("coordination_dim") or "")
    signal = Signal(dim, TITLES.get(dim, f"{dim}: no signal view"), len(steps))
    if dim not in TITLES:
        signal.unavailable = f"no signal view for dimension {dim or '(none)'}"
        return signal
    try:
        evidence = construct_evidence(traj)
    except TrajectoryError as exc:
        signal.unavailable = f"the trajectory lacks what the signal needs: {exc}"
        return signal
    signal.evidence = evidence.history[-1] if evidence.history else {}
    _events(signal, dim, evidence.history)
    _DRAW[dim](signal, config, evidence, traj.get("trajectory") or [], steps)
    return signal


def _events(signal: Signal, dim: str, history: Sequence[dict[str, Any]]) -> None:
    previous: dict[str, Any] = {}
    for ordinal, evidence in enumerate(history, start=1):
        for counter, kind in EVENT_COUNTERS.get(dim, ()):
            now, before = evidence.get(counter), previous.get(counter) or 0
            if isinstance(now, (int, float)) and now > before:
                signal.events.append(Event(ordinal, kind, f"{kind} #{int(now)}"))
        if evidence:
            previous = evidence


def _draw_d1(signal: Signal, config: Mapping[str, Any], evidence: ConstructEvidence,
             items: Sequence[Any], steps: Sequence[Step]) -> None:
    agents = [str(a.get("id")) for a in config.get("agents") or [] if isinstance(a, Mapping)]
    loads = [per_agent_actions(list(steps[:k])) for k in range(1, len(steps) + 1)]
    for agent in dict.fromkeys([*agents, *(s.agent for s in steps)]):
        signal.series.append((agent, [float(load.get(agent, 0)) for load in loads]))
    reference = signal.evidence.get("reference_makespan")
    if isinstance(reference, (int, float)):
        signal.reference = (float(reference), f"M* = {reference:g}")


def _draw_d2(signal: Signal, config: Mapping[str, Any], evidence: ConstructEvidence,
             items: Sequence[Any], steps: Sequence[Step]) -> None:
    for container in evidence.containers:
        signal.tracks.append((_short(container), [_open_state(s, container) for s in steps]))


def _draw_d3(signal: Signal, config: Mapping[str, Any], evidence: ConstructEvidence,
             items: Sequence[Any], steps: Sequence[Step]) -> None:
    mode, keys = evidence.exclusion_mode, evidence.exclusion_keys
    if mode == "shared_tool":
        for resource in sorted(keys):
            signal.tracks.append((f"holder of {_short(resource)}",
                                  [_holder(items[s.index], resource) for s in steps]))
    elif mode == "station":
        signal.tracks.append(("station used by",
                              [s.agent if s.skill in keys else "" for s in steps]))


def _draw_d4(signal: Signal, config: Mapping[str, Any], evidence: ConstructEvidence,
             items: Sequence[Any], steps: Sequence[Step]) -> None:
    capacity = evidence.buffer_capacity
    if capacity is None:
        return  # no declared buffer: the events (misplacements, waits) are the signal
    signal.series.append(("buffer occupancy", [float(n) for n in evidence.buffer_occupancy]))
    signal.reference = (float(capacity), f"capacity {capacity:g}")


_DRAW = {LOAD_BALANCING: _draw_d1, PRECEDENCE: _draw_d2, MUTUAL_EXCLUSION: _draw_d3,
         PRODUCER_CONSUMER: _draw_d4}


def _open_state(step: Step, object_id: str) -> str:
    for obj in (step.objects or {}).values():
        if isinstance(obj, Mapping) and obj.get("objectId") == object_id:
            return "open" if obj.get("isOpen") else "closed"
    return ""


def _holder(item: Mapping[str, Any], object_id: str) -> str:
    state = item.get("state") if isinstance(item, Mapping) else None
    for agent in (state or {}).get("agents") or []:
        if isinstance(agent, Mapping) and object_id in (agent.get("inventory") or []):
            return str(agent.get("agent") or "")
    return ""


def _short(object_id: str) -> str:
    """`Fridge|+00.50|+00.00|+03.25` -> `Fridge`."""
    return object_id.split("|", 1)[0]


def _call(step: Step) -> str:
    target = step.target_id
    return f"{step.skill}({_short(target)})" if target else step.skill

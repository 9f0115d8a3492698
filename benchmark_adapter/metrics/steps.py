"""Step extraction and the reference's step-level failure taxonomy (reference §7.2).

A *step* is a trajectory item that carries a ``skill_result``; init and
``policy_stop`` items are not steps. Everything else in the metrics package is
computed from the list of :class:`Step` objects built here, so field validation
happens in exactly one place.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.vocabulary import SKILL_NAMES

from .errors import TrajectoryError

#: Step categories, in the order the reference tests them (first match wins).
STEP_CATEGORIES: tuple[str, ...] = (
    "illegal_skill",
    "idle_wait",
    "progress",
    "redundant_noop",
    "occupancy_conflict",
    "affordance_miss",
    "concurrency_conflict",
    "precondition_violation",
    "action_failure",
)

# Error-text signatures, matched as case-insensitive substrings like the reference.
NOOP_MARKERS: tuple[str, ...] = (
    "already off",
    "already on",
    "already open",
    "already close",
    "already satisfied",
    "already empty",
    "already filled",
    "already clean",
    "already sliced",
    "already cooked",
)
OCCUPANCY_MARKERS: tuple[str, ...] = ("unoccupied pose", "could not navigate to a visible")
AFFORDANCE_MARKERS: tuple[str, ...] = ("no valid positions",)
CONCURRENCY_MARKERS: tuple[str, ...] = ("is already held by another", "already picked up by")
# Failures intrinsic to the action itself (empty/full hand): not a *declared* ordering
# violation, so the D2 construct ignores them (they still break legal_plan).
INTRINSIC_PRECONDITION_MARKERS: tuple[str, ...] = (
    "is not holding any object",
    "hand has something in it already",
    "can't pick up anything",
    "is not pickupable",
)
#: Skills that act on an object; a failure of one of these with no known marker
#: is a precondition violation, any other failure (Find/Explore) an action failure.
INTERACTION_SKILLS: frozenset[str] = frozenset(SKILL_NAMES) - {"Find", "Explore", "Wait"}


def has_marker(text: str | None, markers: tuple[str, ...]) -> bool:
    """True when ``text`` contains any of ``markers`` (case-insensitive)."""
    low = (text or "").lower()
    return any(marker in low for marker in markers)


@dataclass(frozen=True)
class Step:
    """One executed skill call, flattened from a trajectory item.

    ``index`` is the item's position in ``traj["trajectory"]`` (used in error
    paths); ``objects`` is the item's post-step ``state.objects`` or None when
    the item recorded no state.
    """

    index: int
    skill: str
    agent: str
    success: bool
    error: str = ""
    args: Mapping[str, Any] = field(default_factory=dict)
    round_index: int | None = None
    message: str | None = None
    objects: Mapping[str, Any] | None = None

    @property
    def target_id(self) -> str | None:
        """The object a step acts on: the receptacle for Put, else the object."""
        return self.args.get("receptacleId") or self.args.get("objectId") or None


def task_config(traj: Mapping[str, Any]) -> Mapping[str, Any]:
    """The task config embedded in a trajectory; raises if absent."""
    if not isinstance(traj, Mapping):
        raise TrajectoryError("<root>", "a trajectory must be a JSON object")
    config = traj.get("task_config")
    if not isinstance(config, Mapping):
        raise TrajectoryError("task_config", "missing or not an object")
    return config


def trajectory_items(traj: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The raw ``trajectory`` item list; raises if absent or malformed."""
    if not isinstance(traj, Mapping):
        raise TrajectoryError("<root>", "a trajectory must be a JSON object")
    items = traj.get("trajectory")
    if not isinstance(items, list):
        raise TrajectoryError("trajectory", "missing or not a list")
    for i, item in enumerate(items):
        if not isinstance(item, Mapping):
            raise TrajectoryError(f"trajectory[{i}]", "item is not an object")
    return items


def _require(result: Mapping[str, Any], key: str, path: str, kind: type) -> Any:
    value = result.get(key)
    if not isinstance(value, kind) or (kind is str and not value):
        raise TrajectoryError(f"{path}.{key}", f"missing or not a {kind.__name__}")
    return value


def _parse_step(item: Mapping[str, Any], index: int, path: str) -> Step:
    result = item["skill_result"]
    if not isinstance(result, Mapping):
        raise TrajectoryError(f"{path}.skill_result", "not an object")
    rpath = f"{path}.skill_result"
    if "success" not in result:
        raise TrajectoryError(f"{rpath}.success", "missing")
    state = item.get("state")
    objects = state.get("objects") if isinstance(state, Mapping) else None
    return Step(
        index=index,
        skill=_require(result, "skill", rpath, str),
        agent=_require(result, "agent", rpath, str),
        success=bool(result["success"]),
        error=str(result.get("errorMessage") or ""),
        args=result.get("args") if isinstance(result.get("args"), Mapping) else {},
        round_index=item.get("round_index"),
        message=item.get("message") if isinstance(item.get("message"), str) else None,
        objects=objects if isinstance(objects, Mapping) else None,
    )


#: Within `steps_parsed_once()`: the steps parsed per item list (by id, with the list
#: itself, so an id is never taken for another list's).
_PARSED: contextvars.ContextVar[dict[int, tuple[list, list[Step]]] | None] = (
    contextvars.ContextVar("parsed_steps", default=None))


@contextlib.contextmanager
def steps_parsed_once() -> Iterator[None]:
    """Parse each trajectory's steps once in this block (scoring reads them in every
    metric): the trajectories must not change inside it."""
    token = _PARSED.set({})
    try:
        yield
    finally:
        _PARSED.reset(token)


def extract_steps(traj: Mapping[str, Any]) -> list[Step]:
    """All steps of a trajectory (items with a non-empty ``skill_result``), in order."""
    items = trajectory_items(traj)
    parsed = _PARSED.get()
    known = parsed.get(id(items)) if parsed is not None else None
    if known is not None and known[0] is items:
        return list(known[1])
    steps = [
        _parse_step(item, i, f"trajectory[{i}]")
        for i, item in enumerate(items)
        if item.get("skill_result")
    ]
    if parsed is not None:
        parsed[id(items)] = (items, steps)
    return list(steps)


def allowed_skills_by_agent(config: Mapping[str, Any]) -> dict[str, frozenset[str]]:
    """Per-agent allowed skills; agents with no list at all are unrestricted.

    An agent's own ``allowed_skills`` wins; an empty/missing list falls back to the
    task-level list (as the menu does, §5.2); an agent still without skills is
    left out of the map, so none of its steps count as illegal.
    """
    task_level = _skill_names(config.get("allowed_skills"), "task_config.allowed_skills")
    agents = config.get("agents") or []
    if not isinstance(agents, list):
        raise TrajectoryError("task_config.agents", "not a list")
    out: dict[str, frozenset[str]] = {}
    for index, agent in enumerate(agents):
        if not isinstance(agent, Mapping) or not agent.get("id"):
            continue
        path = f"task_config.agents[{index}]"
        if not isinstance(agent["id"], str):
            raise TrajectoryError(f"{path}.id", "not a string")
        skills = _skill_names(agent.get("allowed_skills"), f"{path}.allowed_skills") or task_level
        if skills:
            out[agent["id"]] = frozenset(skills)
    return out


def _skill_names(value: Any, path: str) -> list[str]:
    """A list of skill names from a task config (absent: none)."""
    if not value:
        return []
    if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
        raise TrajectoryError(path, "not a list of skill names")
    return value


def _as_step(step: Step | Mapping[str, Any]) -> Step:
    if isinstance(step, Step):
        return step
    if isinstance(step, Mapping) and "skill_result" in step:
        return _parse_step(step, -1, "step")
    # A bare skill_result dict, as the reference's classifier takes.
    return _parse_step({"skill_result": step}, -1, "step")


def classify_step(
    step: Step | Mapping[str, Any], allowed_skills_by_agent: Mapping[str, frozenset[str]]
) -> str:
    """Category of one step (a :class:`Step`, a trajectory item or a skill_result dict).

    Tests run in the reference's order and the first match wins; see
    :data:`STEP_CATEGORIES`.
    """
    s = _as_step(step)
    allowed = allowed_skills_by_agent.get(s.agent)
    if allowed is not None and s.skill not in allowed:
        return "illegal_skill"
    return _outcome_category(s.skill, s.success, s.error)


# Scoring classifies each step in several metrics, and the same failure texts recur across
# an episode's steps: the marker search runs once per distinct (skill, outcome, text).
@functools.lru_cache(maxsize=4096)
def _outcome_category(skill: str, success: bool, error: str | None) -> str:
    """The category of an allowed step from its skill and outcome alone."""
    if skill == "Wait":
        return "idle_wait"  # a Wait is idling whatever its outcome
    if success:
        return "progress"
    for category, markers in (
        ("redundant_noop", NOOP_MARKERS),
        ("occupancy_conflict", OCCUPANCY_MARKERS),
        ("affordance_miss", AFFORDANCE_MARKERS),
        ("concurrency_conflict", CONCURRENCY_MARKERS),
    ):
        if has_marker(error, markers):
            return category
    return "precondition_violation" if skill in INTERACTION_SKILLS else "action_failure"


def classify_steps(traj: Mapping[str, Any]) -> list[str]:
    """Category of every step of a trajectory, aligned with :func:`extract_steps`."""
    allowed = allowed_skills_by_agent(task_config(traj))
    return [classify_step(step, allowed) for step in extract_steps(traj)]


def count_categories(categories: list[str]) -> dict[str, int]:
    """Counts of each category, every category present (zeros included), in order."""
    return {name: categories.count(name) for name in STEP_CATEGORIES}


def step_taxonomy(traj: Mapping[str, Any]) -> dict[str, int]:
    """Step-category counts of a trajectory, all categories, in reference order."""
    return count_categories(classify_steps(traj))

"""Whether a schema-valid config can be a fair task: checks applied when a config is loaded.

`TaskConfig` is the tolerant schema (it also reads configs embedded in old trajectories); these
checks reject, at load time, configs that would run but could not be scored fairly or would
break the harness later: vacuous goals, a team that does not match its size, unknown skills or
predicates, an unusable step budget, or a task id that is unsafe as a folder name.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

from benchmark_adapter.vocabulary import SKILL_NAMES

from .config import GoalPredicate, TaskConfig

#: Task ids name the episode folders of a run, so they are limited to a portable file name.
TASK_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,127}")
#: Agent ids are `agent_<k>`; the simulator's agent index is k - 1 (reference §4.1).
AGENT_ID = re.compile(r"agent_([1-9][0-9]*)")
#: The largest `difficulty.step_budget` accepted: ten times the largest released budget (96).
MAX_STEP_BUDGET = 1000

#: Goal predicate kinds (reference §2.2) and the arguments each needs. `filled` may also name a
#: `liquid`. Object arguments are aliases of `init_state.objects` or raw object ids.
PREDICATE_ARGS: dict[str, tuple[str, ...]] = {
    "on": ("object", "receptacle"),
    "on_sliced_piece": ("source", "receptacle"),
    "closed": ("object",),
    "open": ("object",),
    "toggled": ("object", "value"),
    "sliced": ("object",),
    "sliced_by": ("object", "agent"),
    "clean": ("object",),
    "filled": ("object",),
    "empty": ("object",),
    "cooked": ("object",),
}
_OBJECT_ARGS = frozenset({"object", "receptacle", "source"})

Problem = tuple[str, str]  # (dotted field, what is wrong)


def problems(task: TaskConfig) -> list[Problem]:
    """Every reason `task` cannot be run as a fair task, in field order (empty: none)."""
    return [*_task_id(task), *_team(task), *_skills(task), *_goals(task), *_budget(task)]


def _task_id(task: TaskConfig) -> Iterator[Problem]:
    if not TASK_ID.fullmatch(task.task_id):
        shown = task.task_id if len(task.task_id) <= 60 else task.task_id[:57] + "..."
        yield "task_id", (
            f"{shown!r} is not a safe task id: use 1 to 128 letters, digits, '_', '.' or '-', "
            "starting with a letter or digit (it names the episode's folder)")


def _team(task: TaskConfig) -> Iterator[Problem]:
    if task.agent_count != len(task.agents):
        yield "agent_count", f"{task.agent_count}, but {len(task.agents)} agents are listed"
    declared = task.init_state.controller_init.agentCount
    if declared is not None and declared != task.agent_count:
        yield "init_state.controller_init.agentCount", (
            f"{declared}, but agent_count is {task.agent_count}")
    seen: set[str] = set()
    for i, agent in enumerate(task.agents):
        match = AGENT_ID.fullmatch(agent.id)
        if agent.id in seen:
            yield f"agents.{i}.id", f"duplicated agent id {agent.id!r}"
        elif match is None or int(match[1]) > len(task.agents):
            yield f"agents.{i}.id", (
                f"{agent.id!r}: agent ids are agent_1 … agent_{len(task.agents)}")
        seen.add(agent.id)


def _skills(task: TaskConfig) -> Iterator[Problem]:
    lists = [("allowed_skills", task.allowed_skills)] + [
        (f"agents.{i}.allowed_skills", agent.allowed_skills) for i, agent in enumerate(task.agents)
    ]
    for field, skills in lists:
        unknown = [s for s in skills if s not in SKILL_NAMES]
        if unknown:
            yield field, f"unknown skill {unknown[0]!r} (known: {', '.join(SKILL_NAMES)})"


def _goals(task: TaskConfig) -> Iterator[Problem]:
    if not task.goal_predicates:
        yield "goal_predicates", "no goals: every episode would count as a success"
    for i, goal in enumerate(task.goal_predicates):
        yield from _goal(task, i, goal)


def _goal(task: TaskConfig, i: int, goal: GoalPredicate) -> Iterator[Problem]:
    field = f"goal_predicates.{i}"
    needed = PREDICATE_ARGS.get(goal.predicate)
    if needed is None:
        yield f"{field}.predicate", (
            f"unknown predicate {goal.predicate!r} (known: {', '.join(PREDICATE_ARGS)})")
        return
    for name in needed:
        value = goal.arg(name)
        if value is None:
            yield f"{field}.{name}", f"missing: a {goal.predicate!r} goal needs {needed}"
        elif name in _OBJECT_ARGS and (not isinstance(value, str) or not value):
            yield f"{field}.{name}", f"expected an object alias or id, got {value!r}"
        elif name == "agent" and value not in task.agent_ids:
            yield f"{field}.agent", f"{value!r} is not an agent of this task"
        elif name == "value" and not isinstance(value, bool):
            yield f"{field}.value", f"expected true or false, got {value!r}"


def _budget(task: TaskConfig) -> Iterator[Problem]:
    budget = task.difficulty.step_budget
    if budget is None:
        # The reference runs such a config without any limit; a model could then play forever.
        yield "difficulty.step_budget", (
            "missing: every task needs a step budget (the top-level step_budget is not read, "
            "as in the reference)")
    elif not 1 <= budget <= MAX_STEP_BUDGET:
        yield "difficulty.step_budget", f"{budget}: must be between 1 and {MAX_STEP_BUDGET}"

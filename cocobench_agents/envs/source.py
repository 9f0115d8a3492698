"""What an environment is built from: the instances of a task source (anything `--task` /
`--suite` takes) and one condition (``D1_blind``), resolved as `cocobench run` resolves them."""

from __future__ import annotations

from benchmark_adapter.tasks import TaskConfig, load_tasks
from cocobench_agents.engine.resolve import find_task
from cocobench_agents.envs.seated import EnvError, check_seated
from cocobench_agents.graphs import planner_spec
from cocobench_agents.harness import Condition, parse_conditions


def instances(source: str, task_id: str | None) -> list[TaskConfig]:
    """The instances of `source`, or the one `task_id` names (an id of `source`, or a
    task-config file)."""
    if task_id is not None:
        return [find_task(task_id, source)]
    configs = load_tasks(source)
    if not configs:
        raise EnvError(f"the task source {source!r} holds no instances")
    return configs


def one_condition(condition: str) -> Condition:
    """The condition `condition` names, which must be one of a planner with seats to play
    (an unknown name is the run's own error)."""
    conditions = parse_conditions(condition)
    if len(conditions) != 1:
        raise EnvError(f"condition {condition!r} names {len(conditions)} conditions: an "
                       "environment takes one, such as D1_blind")
    chosen = conditions[0]
    check_seated(planner_spec(chosen.planner))
    return chosen

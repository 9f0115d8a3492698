"""`largest_action_id`: the largest menu id an instance's episode can show is Γ at its
longest, which the simulator's own slicing reaches (each object sliced or not, whichever lists
more actions)."""

from __future__ import annotations

import pytest

from benchmark_adapter.menu import ActionSpace
from benchmark_adapter.menu_bound import largest_action_id
from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.tasks import TaskConfig, load_tasks
from tests.paths import SHARED_TASKS


def _sources() -> list[TaskConfig]:
    configs = load_tasks("cocobench-full")[::7] + load_tasks("demo")
    if SHARED_TASKS.is_dir():
        configs += load_tasks(str(SHARED_TASKS))
    return configs


def _last_id(controller: EmbeddedController, config: TaskConfig) -> int:
    objects = controller.last_metadata()[0]["objects"]
    return ActionSpace.build(config.agent_ids, objects).entries[-1].action_id


def _sliced(config: TaskConfig, object_id: str) -> int:
    """The last id of Γ once the simulator has sliced `object_id` alone."""
    controller = EmbeddedController(config)
    controller.reset()
    answer = controller.step("SliceObject", agentId=0, objectId=object_id, forceAction=True)
    assert answer[0]["lastActionSuccess"], answer[0]["errorMessage"]
    return _last_id(controller, config)


@pytest.mark.parametrize("config", _sources(), ids=lambda c: c.task_id)
def test_the_bound_is_gamma_at_its_longest(config: TaskConfig) -> None:
    controller = EmbeddedController(config)
    controller.reset()
    first = _last_id(controller, config)
    sliceable = [o["objectId"] for o in controller.last_metadata()[0]["objects"]
                 if o["sliceable"]]
    # Each object's part of Γ is its own: the longest Γ slices exactly those whose slicing
    # lengthens it.
    longest = first + sum(max(0, _sliced(config, o) - first) for o in sliceable)
    assert largest_action_id(config) == longest


def test_some_instances_of_the_full_suite_can_show_ids_above_255() -> None:
    # Why the environment sizes its action space by this bound, not by a fixed 255.
    assert max(largest_action_id(c) for c in load_tasks("cocobench-full")) > 255

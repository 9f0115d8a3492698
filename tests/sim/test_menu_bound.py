"""`largest_action_id`: no state of an instance's episode shows a larger menu id, and slicing
what slices into more actions reaches it exactly."""

from __future__ import annotations

import pytest

from benchmark_adapter.menu import ActionSpace
from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.sim.embedded.menu_bound import _actions, _most_actions, largest_action_id
from benchmark_adapter.tasks import TaskConfig
from cocobench_agents.envs.source import instances
from tests.paths import SHARED_TASKS


def _sources() -> list[TaskConfig]:
    configs = instances("cocobench-full", None)[::7] + instances("demo", None)
    if SHARED_TASKS.is_dir():
        configs += instances(str(SHARED_TASKS), None)
    return configs


def _last_id(controller: EmbeddedController, config: TaskConfig) -> int:
    objects = controller.last_metadata()[0]["objects"]
    return ActionSpace.build(config.agent_ids, objects).entries[-1].action_id


@pytest.mark.parametrize("config", _sources(), ids=lambda c: c.task_id)
def test_the_bound_is_gamma_at_its_longest(config: TaskConfig) -> None:
    bound = largest_action_id(config)
    controller = EmbeddedController(config)
    controller.reset()
    assert _last_id(controller, config) <= bound
    # Slice every object whose pieces list more actions than it does: Γ is then longest.
    for obj in controller.last_metadata()[0]["objects"]:
        if obj["sliceable"] and _most_actions(obj) > _actions(obj):
            answer = controller.step("SliceObject", agentId=0, objectId=obj["objectId"],
                                     forceAction=True)[0]
            assert answer["lastActionSuccess"], answer["errorMessage"]
    assert _last_id(controller, config) == bound


def test_some_instances_of_the_full_suite_can_show_ids_above_255() -> None:
    # Why the environment sizes its action space by this bound, not by a fixed 255.
    assert max(largest_action_id(c) for c in instances("cocobench-full", None)) > 255

"""The three quality gates every candidate must pass to be kept (paper, §Benchmark Construction).

* placement: the instance can be set up: its init actions succeed, the team has room to
  stand, every important object has the affordances its goals need, can be seen from some
  standing pose, each goal receptacle has room for what goes in it, and a shared tool can be
  held by one agent only;
* oracle: the oracle plan reaches the goal with a legal plan;
* metric: the oracle's construct score on the instance's own dimension is at least 0.95.

Oracle and metric are `benchmark_adapter.validation.validate_task`, the same check as
`cocobench validate`; placement runs first in the embedded world the episode will use.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.metrics.steps import NOOP_MARKERS, has_marker
from benchmark_adapter.scene_setup import apply_init_actions
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.world import World
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.validation import validate_task
from benchmark_adapter.vocabulary import DEFAULT_BACKEND

GATES = ("placement", "oracle", "metric")
KNIVES = ("Knife", "ButterKnife")
# Affordance each goal predicate needs of its object (receptacles are checked separately).
GOAL_NEEDS = {
    "on": "pickupable",
    "closed": "openable",
    "open": "openable",
    "toggled": "toggleable",
    "sliced": "sliceable",
    "sliced_by": "sliceable",
}


@dataclass(frozen=True)
class Verdict:
    """What the gates said about one candidate: the gate that rejected it (None if kept)."""

    task_id: str
    gate: str | None
    reason: str = ""

    @property
    def passed(self) -> bool:
        return self.gate is None


def judge(config_data: dict[str, Any], backend: str = DEFAULT_BACKEND) -> Verdict:
    """Run the three gates on a candidate config, stopping at the first that rejects it.

    The placement gate reads the embedded world; the oracle and metric gates run on
    `backend`."""
    config = TaskConfig.model_validate(config_data)
    problems = placement_problems(config)
    if problems:
        return Verdict(config.task_id, "placement", problems[0])
    row = validate_task(config, backend=backend)
    if row.passed:
        return Verdict(config.task_id, None)
    gate = row.reason.split(":", 1)[0]
    # An oracle that crashed is an oracle-gate failure too.
    return Verdict(config.task_id, gate if gate in GATES else "oracle", row.reason)


def placement_problems(config: TaskConfig) -> list[str]:
    """Why the instance cannot be set up as written (empty when it can)."""
    controller = EmbeddedController(config)
    try:
        controller.reset()
    except ValueError as exc:  # no room on the floor grid for the whole team
        return [f"placement: {exc}"]
    trace = apply_init_actions(controller, config.init_state.init_actions)
    failed = [
        f"placement: init {t['action'].get('action')} failed ({t['errorMessage']})"
        for t in trace
        if not t["lastActionSuccess"] and not has_marker(t["errorMessage"], NOOP_MARKERS)
    ]
    if failed:
        return failed
    world = controller.world
    assert world is not None  # reset() built it
    return [
        *_affordance_problems(config, world),
        *_pose_problems(config, controller),
        *_capacity_problems(config, world),
        *_exclusion_problems(config, controller),
    ]


def _affordance_problems(config: TaskConfig, world: World) -> Iterator[str]:
    for goal in config.goal_predicates:
        obj = world.objects[config.resolve(goal.arg("object"))]
        need = GOAL_NEEDS.get(goal.predicate)
        if need and not getattr(obj.aff, need):
            yield f"placement: {obj.id} is not {need} ({goal.predicate} goal)"
        receptacle = goal.arg("receptacle")
        if receptacle and not world.objects[config.resolve(receptacle)].aff.receptacle:
            yield f"placement: {config.resolve(receptacle)} is not a receptacle"
    for station in config.task_constraints.get("buffer_stations", []):
        if not world.objects[station["objectId"]].aff.receptacle:
            yield f"placement: buffer {station['objectId']} is not a receptacle"


def _pose_problems(config: TaskConfig, controller: EmbeddedController) -> Iterator[str]:
    """Every important object must be visible from at least one standing pose."""
    for alias, object_id in config.init_state.objects.items():
        own = controller.step("GetInteractablePoses", agentId=0, objectId=object_id)[0]
        if not own["actionReturn"]:
            yield f"placement: {alias} ({object_id}) has no interactable pose"


def _capacity_problems(config: TaskConfig, world: World) -> Iterator[str]:
    """Each receptacle must hold what the goals put in it, plus one item per buffer station."""
    needed: Counter[str] = Counter()
    for goal in config.goal_predicates:
        if goal.predicate == "on":
            needed[config.resolve(goal.arg("receptacle"))] += 1
    for station in config.task_constraints.get("buffer_stations", []):
        needed[station["objectId"]] += 1
    for receptacle_id, count in sorted(needed.items()):
        receptacle = world.objects[receptacle_id]
        free = receptacle.aff.capacity - len(receptacle.contents)
        if free < count:
            yield (
                f"placement: {receptacle_id} has room for {free} more object(s), "
                f"{count} needed ({len(receptacle.contents)} already in it)"
            )


def _exclusion_problems(config: TaskConfig, controller: EmbeddedController) -> Iterator[str]:
    """A shared tool must be a knife that a second agent cannot take from the first.

    Runs last: it leaves the tool in agent 0's hand."""
    for resource in config.task_constraints.get("resource_exclusion", []):
        tool = resource["resource_id"]
        if tool.split("|")[0] not in KNIVES:
            yield f"placement: shared resource {tool} is not a knife"
            continue
        first = controller.step("PickupObject", agentId=0, objectId=tool, forceAction=True)[0]
        second = controller.step("PickupObject", agentId=1, objectId=tool, forceAction=True)[1]
        if not first["lastActionSuccess"] or second["lastActionSuccess"]:
            yield f"placement: {tool} is not exclusively held (pickup exclusion not enforced)"

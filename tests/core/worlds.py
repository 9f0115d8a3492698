"""Small synthetic worlds for the core tests: a kitchen whose object positions are read from ids.

Positions (x, y, z) are encoded in the ids, as in AI2-THOR; the embedded simulator grounds its
world from them. Agents start where the scene seed puts them; tests that care about where an
agent stands move it with `place` (the world is plain mutable state).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import pytest

from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.world import SimAgent, World
from benchmark_adapter.skills import SkillExecutor, SkillResult
from benchmark_adapter.skills.native import find_object
from benchmark_adapter.tasks import TaskConfig
from tests.paths import SHARED_DATA

# The real configs live beside the repository: /work/shared/cocobench-data next to /work/main.
DATA = SHARED_DATA
TASKS = DATA / "tasks"
SHARED_FILES = sorted(TASKS.glob("*.json")) if TASKS.is_dir() else []
needs_data = pytest.mark.skipif(not TASKS.is_dir(),
                                reason=f"shared CoCoBench data not found at {TASKS}")

KNIFE = "Knife|+00.50|+00.95|-00.50"
TOMATO = "Tomato|+00.50|+00.95|+00.20"
FRIDGE = "Fridge|-01.50|+00.00|+01.00"
COUNTER = "CounterTop|+01.00|+00.90|+00.00"
DRAWER_A = "Drawer|-01.00|+00.60|-01.00"
DRAWER_B = "Drawer|+01.50|+00.60|-01.50"  # sorts before DRAWER_A ('+' < '-')
LIGHT = "LightSwitch|+02.00|+01.30|+01.50"
PLATE = "Plate|+00.00|+00.95|+01.00"
MUG = "Mug|-00.50|+00.95|-00.50"
GHOST = "Apple|+09.00|+00.90|+09.00"  # named nowhere in the kitchen config

KITCHEN: dict[str, str] = {
    "knife": KNIFE, "tomato": TOMATO, "fridge": FRIDGE, "counter": COUNTER,
    "drawer": DRAWER_A, "drawer_2": DRAWER_B, "light": LIGHT, "plate": PLATE, "mug": MUG,
}
ALL_SKILLS = ["Find", "Explore", "Wait", "PickUp", "Put", "Drop", "Open", "Close", "ToggleOn",
              "ToggleOff", "Slice", "CleanObject", "FillObjectWithLiquid",
              "EmptyLiquidFromObject", "PushObject", "PullObject", "BreakObject"]


def make_config(objects: Mapping[str, str] | None = None, *, agents: int = 2,
                goals: Iterable[Mapping[str, Any]] = (),
                init_actions: Iterable[Mapping[str, Any]] = (),
                skills: list[str] | None = None,
                agent_skills: Mapping[str, list[str]] | None = None,
                constraints: Mapping[str, Any] | None = None,
                task_name: str = "test_kitchen", family: str = "X", dim: str = "D1",
                scene: str = "TestKitchen", visibility: float = 1.5, seed: int = 0,
                ) -> TaskConfig:
    """A small task config over `objects` (default: the kitchen)."""
    objects = dict(KITCHEN if objects is None else objects)
    agent_skills = agent_skills or {}
    return TaskConfig.model_validate({
        "task_id": f"{family}_{dim}__{scene}__seed{seed}",
        "coordination_dim": dim, "task_family": family, "task_name": task_name,
        "scene_id": scene, "agent_count": agents, "seed": seed,
        "agents": [{"id": f"agent_{i}", "allowed_skills": agent_skills.get(f"agent_{i}", [])}
                   for i in range(1, agents + 1)],
        "init_state": {
            "controller_init": {"scene": scene, "agentCount": agents, "gridSize": 0.25,
                                "visibilityDistance": visibility},
            "objects": objects,
            "init_actions": [dict(a) for a in init_actions],
        },
        "allowed_skills": list(ALL_SKILLS if skills is None else skills),
        "goal_predicates": [dict(g) for g in goals],
        "task_constraints": dict(constraints or {}),
    })


def touch(world: World) -> None:
    """Tell the metadata cache that the test changed the world by hand."""
    world.version += 1


def place(world: World, index: int, x: float, z: float, yaw: float = 0.0,
          horizon: float = 0.0) -> SimAgent:
    """Put agent `index` at a pose (no collision checks)."""
    agent = world.agents[index]
    agent.x, agent.z, agent.yaw, agent.horizon = x, z, yaw, horizon
    touch(world)
    return agent


@dataclass
class Sim:
    """A reset embedded controller and an executor on it."""

    ctl: EmbeddedController
    ex: SkillExecutor

    @property
    def world(self) -> World:
        return self.ctl.world

    def run(self, call: str) -> SkillResult:
        return self.ex.execute(call)

    def obj(self, object_id: str, agent: int = 0) -> Mapping[str, Any] | None:
        """An object's record in one agent's current metadata."""
        return find_object(self.ctl.last_metadata()[agent], object_id)

    def md(self, agent: int = 0) -> Mapping[str, Any]:
        return self.ctl.last_metadata()[agent]

    def pose(self, agent: int) -> tuple[float, float, float, float]:
        a = self.world.agents[agent]
        return (a.x, a.z, a.yaw, a.horizon)

    def place(self, index: int, x: float, z: float, yaw: float = 0.0,
              horizon: float = 0.0) -> SimAgent:
        return place(self.world, index, x, z, yaw, horizon)


def make_sim(config: TaskConfig | None = None) -> Sim:
    ctl = EmbeddedController(config or make_config())
    ctl.reset()
    return Sim(ctl, SkillExecutor(ctl))

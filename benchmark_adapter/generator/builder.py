"""Turn a template's `Draft` into a complete CoCoBench task config (a plain dict).

The config has the released configs' fields in their order (reference §2.1), so nothing
downstream can tell a generated instance from a released one. Budgets and reference makespans
come from the oracle plan the config names (`provenance.oracle`).
"""

from __future__ import annotations

from typing import Any

from benchmark_adapter.generator.budgets import (
    legacy_step_budget,
    oracle_steps,
    step_budget,
)
from benchmark_adapter.generator.ids import task_id
from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.oracles import oracle_stats
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import Draft, TaskType, forced_put
from benchmark_adapter.sim.embedded.affordances import affordances_of
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import LOAD_BALANCING, MUTUAL_EXCLUSION

GENERATOR_NAME = "cocobench-agents generator"
GENERATOR_VERSION = "1.0.0"


def assemble(task_type: TaskType, scene: Scene, agents: int, seed: int, draft: Draft) -> dict:
    """The config of one candidate instance."""
    config: dict[str, Any] = {
        "task_id": task_id(task_type.cell, scene.scene_id, task_type.slug, agents, seed),
        "coordination_dim": task_type.dim,
        "task_family": task_type.family,
        "task_name": draft.task_name,
        "scene_id": scene.scene_id,
        "agent_count": agents,
        "agents": draft.agents,
        "seed": seed,
    }
    if draft.assignment is not None:
        config["assignment"] = draft.assignment
    config["init_state"] = {
        "controller_init": {
            "scene": scene.scene_id,
            "agentCount": agents,
            "gridSize": 0.25,
            "visibilityDistance": 1.5,
        },
        "objects": {alias: o.id for alias, o in draft.objects.items()},
        "init_actions": init_actions(scene, seed, draft),
        "design_notes": draft.notes,
    }
    config |= {
        "allowed_skills": _team_skills(draft.agents),
        "goal_predicates": draft.goals,
        "task_constraints": dict(draft.constraints),
        "success_fn": "all_goal_predicates_and_legal_plan",
        "eval_layer": "L0",
        "provenance": _provenance(task_type, scene, agents, seed, draft),
    }
    _add_budgets(config, task_type, draft)
    return config


def init_actions(scene: Scene, seed: int, draft: Draft) -> list[dict[str, Any]]:
    """Spawn seed, presence checks, receptacle contents, closed containers, template set-up."""
    actions: list[dict[str, Any]] = []
    if seed > 0:  # as the reference's spawn-seed rewrite; the ids are already post-spawn
        actions.append(spawn_action(seed))
    actions += [{"action": "assert_present", "objectId": o.id} for o in draft.objects.values()]
    important = {o.id for o in draft.objects.values()}
    closed_by_stocking = set()
    for alias in draft.stocked:
        receptacle = draft.objects[alias]
        contents = [o for o in scene.contents(receptacle.id) if o.id not in important]
        if contents:
            actions += _stock(receptacle, contents, close=alias in draft.closed)
            closed_by_stocking.add(alias)
    for alias in draft.closed:
        if alias not in closed_by_stocking:
            actions.append(_native("CloseObject", draft.objects[alias].id))
    return actions + draft.setup


def spawn_action(seed: int) -> dict[str, Any]:
    """The reference's `InitialRandomSpawn` for a spawn seed (also how `thor_scene` spawns)."""
    return {
        "action": "InitialRandomSpawn",
        "randomSeed": seed,
        "forceVisible": False,
        "numPlacementAttempts": 5,
        "placeStationary": True,
    }


def _native(action: str, object_id: str) -> dict[str, Any]:
    return {"action": action, "objectId": object_id, "forceAction": True}


def _stock(
    receptacle: SceneObject, contents: list[SceneObject], close: bool
) -> list[dict[str, Any]]:
    """Put a receptacle's scene contents into it at reset (agent 0, forced, as the reference's
    K generator moves objects), so they take up its capacity in the episode's world."""
    openable = affordances_of(receptacle.type).openable
    actions = [_native("OpenObject", receptacle.id)] if openable else []
    for item in contents:
        actions.append({**_native("PickupObject", item.id), "agentId": 0})
        actions.append(forced_put(receptacle.id))
    if openable and close:
        actions.append(_native("CloseObject", receptacle.id))
    return actions


def _team_skills(agents: list[dict[str, Any]]) -> list[str]:
    """The task-level skill list: the shared list, or the sorted union for role teams."""
    lists = [a["allowed_skills"] for a in agents]
    if all(skills == lists[0] for skills in lists):
        return list(lists[0])
    return sorted({s for skills in lists for s in skills})


def _provenance(
    task_type: TaskType, scene: Scene, agents: int, seed: int, draft: Draft
) -> dict[str, Any]:
    return {
        "generator": GENERATOR_NAME,
        "generator_version": GENERATOR_VERSION,
        "template": task_type.slug,
        "task_type": task_type.title,
        "oracle": task_type.oracle,
        "scene": scene.scene_id,
        "scene_source": scene.source,
        "room": scene.room,
        "agent_count": agents,
        "seed": seed,
        "spawn_seed": seed,
        "placement_verified": True,
        "instruction": draft.instruction,
        **draft.provenance,
    }


def _add_budgets(config: dict[str, Any], task_type: TaskType, draft: Draft) -> None:
    """Difficulty, budgets and reference makespans from the oracle plan's length."""
    stats = oracle_stats(TaskConfig.model_validate(config))
    steps = oracle_steps(stats.calls)
    if task_type.dim == LOAD_BALANCING:
        config["task_constraints"]["optimal_makespan"] = stats.makespan
    k_makespan = stats.calls if task_type.dim == MUTUAL_EXCLUSION else None
    difficulty = {
        "object_count": draft.object_count,
        "step_budget": step_budget(task_type.cell, steps),
        "partial_observability": True,
        "oracle_steps": steps,
    }
    # Keep the released field order: difficulty before provenance, budgets last.
    provenance = config.pop("provenance")
    config["difficulty"] = difficulty
    config["provenance"] = provenance
    config["step_budget"] = legacy_step_budget(steps, k_makespan)
    if k_makespan is not None:
        # K's reference makespan: every agent's 7 + 2·items steps, i.e. the whole plan.
        config["optimal_makespan"] = k_makespan

"""Hand-built trajectory dicts in the reference ``trajectory.json`` format, for tests."""

from __future__ import annotations

from typing import Any

ALL_SKILLS = ["Find", "Explore", "Wait", "PickUp", "Put", "Drop", "Open", "Close"]
K_SKILLS = ["Find", "Explore", "Wait", "PickUp", "Drop", "Slice"]

# Object ids shaped like the released data (opaque strings to the metrics).
KNIFE = "Knife|+00.87|+00.70|-00.60"
BOX = "Box|-02.93|+00.75|+03.53"
PLATE = "Plate|+00.96|+01.65|-02.61"
FRIDGE = "Fridge|-02.10|+00.00|+01.07"
COUNTER = "CounterTop|+00.69|+00.95|-02.48"
KEYCHAIN = "KeyChain|-02.39|+00.73|+06.30"
CARD = "CreditCard|-01.60|+00.69|+01.18"
APPLE = "Apple|-00.47|+01.15|+00.48"
TOMATO = "Tomato|-00.39|+01.14|-00.81"
POTATO = "Potato|-01.66|+00.93|-02.15"
SOFA = "Sofa|-02.40|00.00|+03.42"

# Executor error texts: a Put into a closed box (precondition violation), a PickUp of the
# knife a teammate holds (concurrency conflict), a Put onto a full receptacle (affordance miss).
CLOSED = f"{BOX} is closed; Open it first"
HELD = f"{KNIFE} is already held by another agent"
NO_ROOM = "No valid positions to place object found"


def make_config(
    dim: str = "D1",
    family: str = "G",
    n_agents: int = 2,
    skills: list[str] | None = None,
    objects: dict[str, str] | None = None,
    constraints: dict[str, Any] | None = None,
    **top_level: Any,
) -> dict[str, Any]:
    """A task config; every agent gets ``skills`` (default: the 8 loading skills)."""
    skills = ALL_SKILLS if skills is None else skills
    config = {
        "task_id": f"{family}_{dim}__FloorPlan201__seed0",
        "coordination_dim": dim,
        "task_family": family,
        "scene_id": "FloorPlan201",
        "agent_count": n_agents,
        "agents": [
            {"id": f"agent_{i}", "role": f"R{i}", "allowed_skills": list(skills)}
            for i in range(1, n_agents + 1)
        ],
        "init_state": {"objects": dict(objects or {})},
        "allowed_skills": list(skills),
        "goal_predicates": [],
        "task_constraints": dict(constraints or {}),
    }
    config.update(top_level)
    return config


def step(
    agent: str,
    skill: str,
    obj: str | None = None,
    *,
    to: str | None = None,
    ok: bool = True,
    error: str = "",
    round_index: int | None = None,
    message: str | None = None,
    objects: dict[str, Any] | None = None,
    decision: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """One action item; ``to`` makes it a Put (``obj`` = held object, ``to`` = receptacle)."""
    args = {"objectId": obj, "receptacleId": to} if to else ({"objectId": obj} if obj else {})
    item: dict[str, Any] = {
        "step_index": None,  # filled in by make_traj
        "label": f"{skill}({agent})",
        "image": None,
        "state": {"objects": objects or {}, "agents": []},
        "skill_result": {
            "skill": skill,
            "agent": agent,
            "args": args,
            "success": ok,
            "errorMessage": error,
            "native_trace": [],
        },
        "eval": {"success": False, "checks": []},
    }
    if round_index is not None:
        item["round_index"] = round_index
    if message is not None:
        item["message"] = message
    if decision is not None:
        item["policy_decision"] = decision
    return item


def stop(reason: str | None, status: str | None = None, **fields: Any) -> dict[str, Any]:
    """A ``policy_stop`` item carrying a decision with ``terminal_reason``."""
    decision = {
        "policy": "centralized_vlm",
        "status": status or reason,
        "terminal_reason": reason,
        **fields,
    }
    return {
        "step_index": None,
        "label": "policy_stop",
        "image": None,
        "state": {"objects": {}, "agents": []},
        "eval": {"success": False, "checks": []},
        "policy_decision": decision,
    }


def make_traj(
    config: dict[str, Any],
    items: list[dict[str, Any]],
    *,
    success: bool = False,
    passed: int = 0,
    total: int = 0,
) -> dict[str, Any]:
    """A full trajectory: init item + ``items``; final_eval with ``passed``/``total`` checks."""
    init = {
        "step_index": 0,
        "label": "init",
        "image": None,
        "state": {"objects": {}, "agents": []},
        "eval": {"success": False, "checks": []},
        "native_trace": [],
    }
    counter = 0
    for item in items:
        counter += "skill_result" in item
        item["step_index"] = counter
    checks = [
        {"predicate": "on", "objectId": f"o{i}", "passed": i < passed, "detail": ""}
        for i in range(total)
    ]
    return {
        "task_id": config["task_id"],
        "task_config": config,
        "init_trace": [],
        "final_eval": {"success": success, "checks": checks},
        "trajectory": [init, *items],
    }


def placed(aliases: dict[str, str], on_buffer: list[str], buffer: str = PLATE) -> dict[str, Any]:
    """``state.objects`` where the aliases in ``on_buffer`` rest on ``buffer``."""
    return {
        alias: {
            "objectId": oid,
            "visible": True,
            "isDirty": False,
            "isFilledWithLiquid": False,
            "fillLiquid": None,
            "isToggled": None,
            "parentReceptacles": [buffer] if alias in on_buffer else [COUNTER],
        }
        for alias, oid in aliases.items()
    }


def illegal_success(config: dict[str, Any], *items: dict[str, Any]) -> dict[str, Any]:
    """A successful episode whose plan is illegal: a Put into the closed box, then the Open;
    ``items`` follow."""
    steps = [
        step("agent_1", "Put", KEYCHAIN, to=BOX, ok=False, error=CLOSED),
        step("agent_1", "Open", BOX),
        *items,
    ]
    return make_traj(config, steps, success=True, passed=1, total=1)

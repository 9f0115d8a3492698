"""`SkillExecutor`: high-level skills → native actions, with the reference's refusals (§4.2).

PickUp, Put, Open, Close and Drop are issued with `forceAction: true`, which skips AI2-THOR's
visibility requirement (reference QUIRK §4.2): a planner can succeed at them without a Find.
ToggleOn/Off and Slice are not forced and need the object in view.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.skills.calls import CallSyntaxError, SkillCall, agent_index, parse_call
from benchmark_adapter.skills.native import NativeSession
from benchmark_adapter.skills.navigation import find
from benchmark_adapter.skills.result import SkillResult

EXPLORE = {
    "forward": ("MoveAhead", {"moveMagnitude": 0.25}),
    "back": ("MoveBack", {"moveMagnitude": 0.25}),
    "left": ("MoveLeft", {"moveMagnitude": 0.25}),
    "right": ("MoveRight", {"moveMagnitude": 0.25}),
    "turn_left": ("RotateLeft", {}),
    "turn_right": ("RotateRight", {}),
    "look_up": ("LookUp", {}),
    "look_down": ("LookDown", {}),
}
KNIVES = ("Knife", "ButterKnife")

Skill = Callable[[NativeSession, SkillCall], SkillResult]


def _find(s: NativeSession, call: SkillCall) -> SkillResult:
    return find(s, call.args[0])


def _explore(s: NativeSession, call: SkillCall) -> SkillResult:
    direction = call.args[0] if call.args else ""
    if direction not in EXPLORE:
        return s.result.fail(f"Unsupported direction: {direction}")
    action, kwargs = EXPLORE[direction]
    return s.finish(s.act(action, **kwargs))


def _wait(s: NativeSession, call: SkillCall) -> SkillResult:
    return s.finish(s.act("Pass"))


def _checked(s: NativeSession, object_id: str, flag: str = "") -> str | None:
    """Refusal text if the object is missing or lacks an affordance, else None."""
    obj = s.object(object_id)
    if obj is None:
        return f"Object not found in metadata: {object_id}"
    if flag and not obj.get(flag):
        return f"Object {object_id} does not satisfy affordance: {flag}"
    return None


def _pickup(s: NativeSession, call: SkillCall) -> SkillResult:
    oid = call.args[0]
    holder = s.holder_of(oid)
    if holder is not None and holder != s.agent:
        return s.result.fail(f"{oid} is already held by another agent")
    refusal = _checked(s, oid, "pickupable")
    if refusal:
        return s.result.fail(refusal)
    return s.finish(s.act("PickupObject", objectId=oid, forceAction=True))


def _put(s: NativeSession, call: SkillCall) -> SkillResult:
    rid = call.args[0]
    held = s.held()
    if held is None:
        return s.result.fail("Agent is not holding any object")
    s.result.args = {"objectId": held["objectId"], "receptacleId": rid}
    refusal = _checked(s, held["objectId"]) or _checked(s, rid, "receptacle")
    if refusal:
        return s.result.fail(refusal)
    receptacle = s.object(rid)
    if receptacle.get("openable") and not receptacle.get("isOpen"):
        return s.result.fail(f"{rid} is closed; Open it first")
    return s.finish(s.act("PutObject", objectId=rid, forceAction=True, placeStationary=True))


def _drop(s: NativeSession, call: SkillCall) -> SkillResult:
    return s.finish(s.act("DropHandObject", forceAction=True))


def _simple(action: str, flag: str, force: bool) -> Skill:
    """A skill that checks one affordance and issues one native action on its object."""

    def skill(s: NativeSession, call: SkillCall) -> SkillResult:
        oid = call.args[0]
        refusal = _checked(s, oid, flag)
        if refusal:
            return s.result.fail(refusal)
        extra = {"forceAction": True} if force else {}
        return s.finish(s.act(action, objectId=oid, **extra))

    return skill


def _slice(s: NativeSession, call: SkillCall) -> SkillResult:
    held = s.held()
    if held is None:
        return s.result.fail("Agent must hold a Knife or ButterKnife to slice")
    if held["objectType"] not in KNIVES:
        return s.result.fail(f"Agent is holding {held['objectId']}, not a Knife/ButterKnife")
    return _simple("SliceObject", "sliceable", False)(s, call)


def _fill(s: NativeSession, call: SkillCall) -> SkillResult:
    oid = call.args[0]
    liquid = call.args[1] if len(call.args) > 1 else "water"
    refusal = _checked(s, oid)
    if refusal:
        return s.result.fail(refusal)
    return s.finish(s.act("FillObjectWithLiquid", objectId=oid, fillLiquid=liquid))


def _push(action: str) -> Skill:
    def skill(s: NativeSession, call: SkillCall) -> SkillResult:
        oid = call.args[0]
        magnitude = float(call.args[1]) if len(call.args) > 1 else 150.0
        if not math.isfinite(magnitude):  # refused before it reaches a native call's record
            return s.result.fail(f"moveMagnitude must be a finite number, got {call.args[1]}")
        refusal = _checked(s, oid)
        if refusal:
            return s.result.fail(refusal)
        return s.finish(s.act(action, objectId=oid, moveMagnitude=magnitude))

    return skill


# One implementation for each of `vocabulary.SKILL_NAMES` (what task checks accept), in order.
SKILLS: dict[str, Skill] = {
    "Find": _find,
    "Explore": _explore,
    "Wait": _wait,
    "PickUp": _pickup,
    "Put": _put,
    "Drop": _drop,
    "Open": _simple("OpenObject", "openable", True),
    "Close": _simple("CloseObject", "openable", True),
    "ToggleOn": _simple("ToggleObjectOn", "toggleable", False),
    "ToggleOff": _simple("ToggleObjectOff", "toggleable", False),
    "Slice": _slice,
    "CleanObject": _simple("CleanObject", "dirtyable", False),
    "FillObjectWithLiquid": _fill,
    "EmptyLiquidFromObject": _simple("EmptyLiquidFromObject", "", False),
    "PushObject": _push("PushObject"),
    "PullObject": _push("PullObject"),
    "BreakObject": _simple("BreakObject", "breakable", False),
}
# Skills whose first argument is an object id (the others take none or a direction).
OBJECT_SKILLS = frozenset(SKILLS) - {"Explore", "Wait", "Drop"}


def result_args(call: SkillCall) -> dict[str, str | None]:
    """The `args` record of a call, as the reference writes it."""
    if call.skill == "Explore":
        return {"direction": call.args[0] if call.args else ""}
    if call.skill == "Put":  # the held object is filled in once known
        return {"receptacleId": call.args[0] if call.args else ""}
    return {"objectId": call.args[0]} if call.args else {}


class SkillExecutor:
    """Runs skill calls on any `Controller`; failures are returned, never raised."""

    def __init__(self, controller: Controller) -> None:
        self.controller = controller

    def execute(self, call: SkillCall | str) -> SkillResult:
        """Run one skill call (a `SkillCall` or its string form)."""
        try:
            parsed = parse_call(call) if isinstance(call, str) else call
        except CallSyntaxError as exc:
            return SkillResult(skill="", agent="", args={}).fail(str(exc))
        result = SkillResult(skill=parsed.skill, agent=parsed.agent, args=result_args(parsed))
        skill = SKILLS.get(parsed.skill)
        if skill is None:
            return result.fail(f"Unsupported skill: {parsed.skill}")
        if parsed.skill in OBJECT_SKILLS and not parsed.args:
            return result.fail(f"{parsed.skill} needs an object id")
        try:
            session = NativeSession(self.controller, result, agent_index(parsed.agent))
            if session.agent >= len(session.metadata):
                return result.fail(f"Unknown agent {parsed.agent}")
            return skill(session, parsed)
        except Exception as exc:  # noqa: BLE001 - as the reference: any skill error is a failure
            return result.fail(repr(exc))

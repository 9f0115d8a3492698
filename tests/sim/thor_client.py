"""A third-party client of ai2thor's `Controller` API, for the ThorCompatController tests.

Written the way code for AI2-THOR is written — the reference implementation's env for one:
it knows nothing of this project (standard library only), takes a task config as its raw
JSON dict and any object that behaves like `ai2thor.controller.Controller`, resets with the
scene, applies the init actions, runs skill calls as per-agent native actions (reading
`event.events[i].metadata`, `lastActionSuccess`, `errorMessage`, `actionReturn`, and
pointing `last_event` at the acting agent's event before Open/Close, as the reference does),
and checks the goal predicates on agent 0's metadata.
"""

from __future__ import annotations

import math
import re
from typing import Any

MIN_SEPARATION = 0.45  # metres between agents, as the reference's Find keeps
CALL = re.compile(r"^\s*(\w+)\s*\((.*)\)\s*$")
EXPLORE = {"forward": "MoveAhead", "back": "MoveBack", "left": "MoveLeft", "right": "MoveRight",
           "turn_left": "RotateLeft", "turn_right": "RotateRight", "look_up": "LookUp",
           "look_down": "LookDown"}
FORCED = {"PickupObject", "PutObject", "DropHandObject", "OpenObject", "CloseObject"}


def agent_meta(event: Any, agent: int = 0) -> dict[str, Any]:
    """One agent's metadata from a single- or multi-agent event."""
    events = getattr(event, "events", None)
    return (events[agent] if events else event).metadata


def find_object(event: Any, object_id: str, agent: int = 0) -> dict[str, Any] | None:
    return next((o for o in agent_meta(event, agent)["objects"] if o["objectId"] == object_id),
                None)


def _object_skill(action: str) -> Any:
    """A skill that is one native action on its object."""
    def skill(self: ThirdPartyEnv, agent: int, oid: str) -> tuple[bool, str]:
        return self._simple(agent, {"action": action, "objectId": oid})
    return skill


class ThirdPartyEnv:
    """Skill calls `Skill(agent_k, arg…)` over an ai2thor-like controller."""

    def __init__(self, config: dict[str, Any], controller: Any) -> None:
        self.config, self.controller = config, controller
        self.aliases = config["init_state"]["objects"]
        self.native_log: list[dict[str, Any]] = []  # every native action and its outcome
        self.skill_log: list[dict[str, Any]] = []

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self) -> list[dict[str, Any]]:
        init = self.config["init_state"]
        scene = init["controller_init"].get("scene") or self.config["scene_id"]
        self.controller.reset(scene=scene)
        return [self._init_action(dict(a)) for a in init.get("init_actions", [])]

    def _init_action(self, action: dict[str, Any]) -> dict[str, Any]:
        kind, oid = action["action"], action.get("objectId")
        obj = find_object(self.controller.last_event, oid) if oid else None
        if kind == "assert_present":
            return {"action": action, "ok": obj is not None}
        if kind == "ensure_toggle_state":
            want = bool(action["isToggled"])
            if obj is None or bool(obj["isToggled"]) == want:
                return {"action": action, "ok": True}
            name = "ToggleObjectOn" if want else "ToggleObjectOff"
            return self._native(0, {"action": name, "objectId": oid, "forceAction": True})
        if kind == "ensure_empty":
            if obj is None or not obj["isFilledWithLiquid"]:
                return {"action": action, "ok": True}
            return self._native(0, {"action": "EmptyLiquidFromObject", "objectId": oid})
        agent = action.pop("agentId", 0)
        return self._native(agent, action)

    # -- native stepping -----------------------------------------------------------------

    def _native(self, agent: int, action: dict[str, Any]) -> dict[str, Any]:
        payload = {**action, "agentId": agent}
        previous = self.controller.last_event
        if payload["action"] in ("OpenObject", "CloseObject") and previous.events:
            self.controller.last_event = previous.events[agent]  # the reference's workaround
        try:
            meta = agent_meta(self.controller.step(payload), agent)
            entry = {"action": payload, "ok": bool(meta["lastActionSuccess"]),
                     "error": meta["errorMessage"], "return": meta["actionReturn"]}
        except ValueError as exc:  # ai2thor: an invalid action or argument
            entry = {"action": payload, "ok": False, "error": str(exc), "return": None}
        self.native_log.append(entry)
        return entry

    def _meta(self, agent: int = 0) -> dict[str, Any]:
        return agent_meta(self.controller.last_event, agent)

    def _held(self, agent: int) -> str | None:
        inventory = self._meta(agent)["inventoryObjects"]
        return inventory[0]["objectId"] if inventory else None

    # -- skills ----------------------------------------------------------------------------

    def run(self, call: str) -> dict[str, Any]:
        match = CALL.match(call)
        if match is None:
            raise ValueError(f"not a skill call: {call}")
        skill = match.group(1)
        agent_name, *args = [a.strip() for a in match.group(2).split(",")]
        agent = int(agent_name.removeprefix("agent_")) - 1
        ok, error = getattr(self, f"_skill_{skill}")(agent, *args)
        record = {"skill": skill, "agent": agent_name, "args": args, "success": ok,
                  "error": error}
        self.skill_log.append(record)
        return record

    def _simple(self, agent: int, action: dict[str, Any]) -> tuple[bool, str]:
        if action["action"] in FORCED:
            action["forceAction"] = True
        entry = self._native(agent, action)
        return entry["ok"], entry["error"]

    def _skill_Find(self, agent: int, oid: str) -> tuple[bool, str]:
        entry = self._native(agent, {"action": "GetInteractablePoses", "objectId": oid})
        if not entry["ok"]:
            return False, entry["error"]
        here = self._meta(agent)["agent"]["position"]
        others = [self._meta(i)["agent"]["position"] for i in range(self._agent_count())
                  if i != agent]
        poses = sorted(entry["return"] or [], key=lambda p: _distance(p, here))
        for pose in poses:
            if any(_distance(pose, o) < MIN_SEPARATION for o in others):
                continue
            teleport = {"action": "TeleportFull", "x": pose["x"], "y": pose["y"],
                        "z": pose["z"], "rotation": pose["rotation"],
                        "horizon": pose["horizon"], "standing": pose["standing"]}
            if self._native(agent, teleport)["ok"] and find_object(
                    self.controller.last_event, oid, agent)["visible"]:
                return True, ""
        return False, f"no free pose sees {oid}"

    def _skill_PickUp(self, agent: int, oid: str) -> tuple[bool, str]:
        for other in range(self._agent_count()):
            if other != agent and self._held(other) == oid:
                return False, f"{oid} is already held by another agent"
        return self._simple(agent, {"action": "PickupObject", "objectId": oid})

    def _skill_Put(self, agent: int, receptacle: str) -> tuple[bool, str]:
        if self._held(agent) is None:
            return False, "Agent is not holding any object"
        target = find_object(self.controller.last_event, receptacle)
        if target and target["openable"] and not target["isOpen"]:
            return False, f"{receptacle} is closed; Open it first"
        return self._simple(agent, {"action": "PutObject", "objectId": receptacle,
                                    "placeStationary": True})

    def _skill_Drop(self, agent: int) -> tuple[bool, str]:
        return self._simple(agent, {"action": "DropHandObject"})

    def _skill_Explore(self, agent: int, direction: str) -> tuple[bool, str]:
        action = {"action": EXPLORE[direction]}
        if action["action"].startswith("Move"):
            action["moveMagnitude"] = 0.25
        return self._simple(agent, action)

    def _skill_Wait(self, agent: int) -> tuple[bool, str]:
        return self._simple(agent, {"action": "Pass"})

    _skill_Open = _object_skill("OpenObject")
    _skill_Close = _object_skill("CloseObject")
    _skill_ToggleOn = _object_skill("ToggleObjectOn")
    _skill_ToggleOff = _object_skill("ToggleObjectOff")
    _skill_Slice = _object_skill("SliceObject")

    def _agent_count(self) -> int:
        return len(getattr(self.controller.last_event, "events", None) or [None])

    # -- goals -----------------------------------------------------------------------------

    def goals_met(self) -> list[bool]:
        """Each goal predicate of the config on agent 0's metadata now."""
        return [self._goal(g) for g in self.config["goal_predicates"]]

    def _goal(self, goal: dict[str, Any]) -> bool:
        kind = goal["predicate"]
        objects = {o["objectId"]: o for o in self._meta(0)["objects"]}
        if kind == "on_sliced_piece":
            prefix = self.aliases.get(goal["source"], goal["source"]) + "|"
            receptacle = self.aliases.get(goal["receptacle"], goal["receptacle"])
            return any(oid.startswith(prefix) and receptacle in (o["parentReceptacles"] or [])
                       for oid, o in objects.items())
        obj = objects.get(self.aliases.get(goal["object"], goal["object"]))
        if obj is None:
            return False
        if kind == "on":
            receptacle = self.aliases.get(goal["receptacle"], goal["receptacle"])
            return receptacle in (obj["parentReceptacles"] or [])
        if kind == "sliced_by":
            return obj["isSliced"] and any(
                s["skill"] == "Slice" and s["success"] and s["agent"] == goal["agent"]
                and s["args"] == [obj["objectId"]] for s in self.skill_log)
        states = {"closed": not obj["isOpen"], "open": obj["isOpen"],
                  "sliced": obj["isSliced"], "clean": obj["isDirty"] is False,
                  "toggled": bool(obj["isToggled"]) == bool(goal.get("value")),
                  "empty": not obj["isFilledWithLiquid"], "cooked": obj["isCooked"],
                  "filled": obj["isFilledWithLiquid"]}
        return bool(states[kind])


def _distance(a: dict[str, Any], b: dict[str, Any]) -> float:
    return math.hypot(a["x"] - b["x"], a["z"] - b["z"])

"""The action space Γ: global action ids, aliases, per-agent compaction (reference §5.1–5.3).

Rebuilt after every step from agent 0's object metadata. Ids are indices in the global list,
so they are large, non-contiguous after filtering, and can shift between steps (the reference's
behaviour; stable ids are a planner-side option).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import AFFORDANCE_FLAGS

EXPLORE_DIRECTIONS = (
    "forward",
    "back",
    "left",
    "right",
    "turn_left",
    "turn_right",
    "look_up",
    "look_down",
)
ARGUMENT_FREE = frozenset({"Explore", "Wait", "Drop"})


@dataclass(frozen=True)
class MenuEntry:
    """One action a planner can choose."""

    action_id: int
    agent: str
    name: str
    skill: str
    args: tuple[str, ...] = ()

    @cached_property  # (an entry outlives many menus; each menu's options name its call)
    def call(self) -> str:
        """The skill-call string the executor runs."""
        return f"{self.skill}({', '.join((self.agent, *self.args))})"

    def to_dict(self) -> dict[str, Any]:
        """The observation's `action_menu` record."""
        return {
            "action_id": self.action_id,
            "agent": self.agent,
            "name": self.name,
            "call": self.call,
        }


def candidate_objects(objects: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """Objects with an affordance, minus sliced sources (their pieces replace them)."""
    ids = [o["objectId"] for o in objects]
    out = []
    for obj in objects:
        if not any(obj.get(flag) for flag in AFFORDANCE_FLAGS):
            continue
        prefix = obj["objectId"] + "|"
        if any(other.startswith(prefix) for other in ids):
            continue
        out.append(obj)
    return out


def aliases(objects: Sequence[Mapping[str, Any]]) -> dict[str, str]:
    """objectId → alias: `Drawer`, `Drawer_2`, … by type, visible-to-agent-0 first."""
    by_type: dict[str, list[Mapping[str, Any]]] = {}
    for obj in objects:
        by_type.setdefault(obj["objectType"], []).append(obj)
    out = {}
    for t in sorted(by_type):
        ranked = sorted(by_type[t], key=lambda o: (not o.get("visible"), o["objectId"]))
        for i, obj in enumerate(ranked):
            out[obj["objectId"]] = t if i == 0 else f"{t}_{i + 1}"
    return out


def _agent_phrases(objs: list[tuple[str, Mapping[str, Any]]]) -> list[tuple[str, str, tuple]]:
    """(phrase, skill, args) in the reference's per-agent block order: all Finds, the
    explores and wait, then one skill category at a time over every alias that affords it."""

    def having(*flags: str) -> list[tuple[str, tuple[str]]]:
        return [(a, (o["objectId"],)) for a, o in objs if any(o.get(f) for f in flags)]

    out = [(f"find a {a}", "Find", (o["objectId"],)) for a, o in objs]  # all are candidates
    out += [(f"explore {d}", "Explore", (d,)) for d in EXPLORE_DIRECTIONS]
    out.append(("wait", "Wait", ()))
    out += [(f"pick up the {a}", "PickUp", oid) for a, oid in having("pickupable")]
    out += [(f"put object in hand on the {a}", "Put", oid) for a, oid in having("receptacle")]
    out.append(("drop object in hand", "Drop", ()))
    for a, oid in having("openable"):
        out += [(f"open the {a}", "Open", oid), (f"close the {a}", "Close", oid)]
    for a, oid in having("toggleable"):
        out += [(f"turn on the {a}", "ToggleOn", oid), (f"turn off the {a}", "ToggleOff", oid)]
    out += [(f"slice the {a}", "Slice", oid) for a, oid in having("sliceable")]
    out += [(f"clean the {a}", "CleanObject", oid) for a, oid in having("dirtyable")]
    for a, oid in having("canFillWithLiquid"):
        out += [
            (f"fill the {a} with water", "FillObjectWithLiquid", (*oid, "water")),
            (f"empty liquid from the {a}", "EmptyLiquidFromObject", oid),
        ]
    for a, oid in having("pickupable", "moveable"):
        out += [(f"push the {a}", "PushObject", oid), (f"pull the {a}", "PullObject", oid)]
    out += [(f"break the {a}", "BreakObject", oid) for a, oid in having("breakable")]
    return out


def phrases_per_object(obj: Mapping[str, Any]) -> int:
    """How many phrases one candidate object adds to each agent's block of Γ."""
    return len(_agent_phrases([("", obj)])) - PHRASES_PER_AGENT


#: The phrases of each agent's block of Γ that name no object: the explores, wait and drop.
PHRASES_PER_AGENT = len(_agent_phrases([]))


@dataclass(frozen=True)
class ActionSpace:
    """The global action list of one step and the aliases it was built with."""

    entries: tuple[MenuEntry, ...]
    alias_of: Mapping[str, str]

    @classmethod
    def build(cls, agent_ids: Sequence[str], objects: Sequence[Mapping[str, Any]]) -> ActionSpace:
        """Build Γ from agent 0's object metadata."""
        cands = candidate_objects(objects)
        alias_of = aliases(cands)
        ordered = sorted(cands, key=lambda o: _alias_key(alias_of[o["objectId"]]))
        objs = [(alias_of[o["objectId"]], o) for o in ordered]
        phrases = _agent_phrases(objs)
        entries = []
        for agent in agent_ids:
            for phrase, skill, args in phrases:
                entries.append(MenuEntry(len(entries), agent, f"{agent}: {phrase}", skill, args))
        return cls(tuple(entries), alias_of)


def _alias_key(alias: str) -> tuple[str, int]:
    base, _, n = alias.partition("_")
    return (base, int(n) if n.isdigit() else 1)


def compact(
    space: ActionSpace, config: TaskConfig, agent0_objects: Sequence[Mapping[str, Any]]
) -> list[MenuEntry]:
    """The menu actually shown: allowed skills, D4 role gating, important objects only."""
    important = set(config.important_ids)
    parents = {o["objectId"]: o.get("parentReceptacles") or [] for o in agent0_objects}
    gate = _RoleGate(config, parents)
    allowed_by_agent = {a: set(config.allowed_skills_for(a)) for a in config.agent_ids}
    out = []
    for e in space.entries:
        allowed = allowed_by_agent[e.agent]
        if allowed and e.skill not in allowed:
            continue
        if not gate.allows(e):
            continue
        if e.args and e.skill not in ARGUMENT_FREE and e.args[0] not in important:
            continue
        out.append(e)
    return out


class _RoleGate:
    """D4 producer/consumer gating (reference §5.2.2)."""

    def __init__(self, config: TaskConfig, parents: Mapping[str, list[str]]) -> None:
        pc = config.producer_consumer
        self.active = bool(pc)
        self.buffer = (pc or {}).get("buffer")
        self.targets = set((pc or {}).get("targets") or [])
        self.producers = set(config.producers())
        self.consumers = set(config.consumers())
        self.parents = parents

    def allows(self, e: MenuEntry) -> bool:
        if not self.active:
            return True
        role_player = e.agent in self.producers or e.agent in self.consumers
        if role_player and e.skill == "Drop":
            return False
        if e.agent in self.producers and e.skill == "Put":
            return e.args[0] == self.buffer
        if e.agent in self.consumers and e.skill == "Put":
            return e.args[0] in self.targets
        if e.agent in self.consumers and e.skill == "PickUp":
            return self.buffer in self.parents.get(e.args[0], [])
        return True


def menu_line(entry: MenuEntry, centralized: bool) -> str:
    """One menu line as the prompts show it (reference §5.3)."""
    if centralized:
        return f"  {entry.action_id}: {entry.name} [{entry.agent}]"
    return f"  {entry.action_id}: {entry.name}"


def menu_lines(entries: Sequence[MenuEntry], centralized: bool) -> list[str]:
    """All menu lines, or the reference's placeholder for an empty menu."""
    return [menu_line(e, centralized) for e in entries] or ["  (no actions available)"]

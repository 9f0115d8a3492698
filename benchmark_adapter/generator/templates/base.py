"""What a task-type template is, what it produces (`Draft`), and the helpers templates share.

A template grounds one task type in one scene for a team size: it picks concrete objects, writes
the goal predicates, constraints, roles and instruction, and returns a `Draft`. The config
builder turns a draft into a full CoCoBench config. A scene that lacks what the template needs
raises `Ungroundable`, which the pipeline counts as a placement-gate rejection.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.sim.embedded.affordances import affordances_of

# Skill sets, as in the released configs of each family (reference §2.5).
LOADER_SKILLS = ["Find", "Explore", "Wait", "PickUp", "Put", "Drop", "Open", "Close"]
SORTER_SKILLS = ["Find", "Explore", "PickUp", "Put"]
TIDIER_SKILLS = ["Find", "Explore", "PickUp", "Put", "Open", "Close"]
GROCER_SKILLS = ["Find", "Explore", "PickUp", "Put", "ToggleOn", "ToggleOff", "Open", "Close"]
CHEF_SKILLS = ["Find", "Explore", "Wait", "PickUp", "Drop", "Slice"]
PRODUCER_SKILLS = ["Find", "Explore", "PickUp", "Put", "Drop"]
CONSUMER_SKILLS = ["Find", "Explore", "PickUp", "Put"]

FOODS = ("Potato", "Lettuce", "Tomato", "Apple", "Bread", "Egg")
SLICEABLE_FOODS = ("Potato", "Lettuce", "Tomato", "Apple", "Bread")
# Hangers only take what hangs on them.
ACCEPTS = {"TowelHolder": {"HandTowel", "Cloth"}, "ToiletPaperHanger": {"ToiletPaper"}}


class Ungroundable(Exception):
    """The scene lacks what the template needs (objects, receptacles, a source zone)."""


@dataclass
class Draft:
    """A grounded task before the config builder adds ids, init actions and budgets.

    `objects` maps config aliases to scene objects, in the config's alias order. `stocked`
    names receptacles whose scene contents are put into the episode's world (so they take up
    capacity); `closed` names containers force-closed at the start; `setup` holds further init
    actions (light on, fridge open, knife moved to a counter).
    """

    task_name: str
    objects: dict[str, SceneObject]
    goals: list[dict[str, Any]]
    constraints: dict[str, Any]
    agents: list[dict[str, Any]]
    instruction: str
    notes: list[str]
    object_count: int
    stocked: list[str] = field(default_factory=list)
    closed: list[str] = field(default_factory=list)
    setup: list[dict[str, Any]] = field(default_factory=list)
    assignment: dict[str, str] | None = None
    provenance: dict[str, Any] = field(default_factory=dict)


Grounder = Callable[[Scene, int, random.Random], Draft]


@dataclass(frozen=True)
class TaskType:
    """One of the paper's ten task types: its cell, rooms, oracle plan and grounder."""

    slug: str
    title: str
    family: str
    dim: str
    rooms: tuple[str, ...]
    oracle: str
    ground: Grounder

    @property
    def cell(self) -> str:
        """Family × dimension, e.g. `G_D1`."""
        return f"{self.family}_{self.dim}"


# -- picking objects ---------------------------------------------------------------------


def pick_loose(
    scene: Scene,
    rng: random.Random,
    count: int,
    types: Iterable[str] = (),
    exclude: Iterable[str] = (),
) -> list[SceneObject]:
    """`count` small objects in plain sight, of distinct types, none of `exclude` (ids/types)."""
    skip = set(exclude)
    pool = [o for o in scene.loose(*types) if o.id not in skip and o.type not in skip]
    by_type = {o.type: o for o in reversed(pool)}  # first of each type, in scene order
    if len(by_type) < count:
        wanted = "/".join(types) if types else "small"
        raise Ungroundable(f"{len(by_type)} {wanted} objects in plain sight, {count} needed")
    return [by_type[t] for t in rng.sample(sorted(by_type), count)]


def pick_furniture(
    scene: Scene, rng: random.Random, types: Sequence[str], count: int = 1
) -> list[SceneObject]:
    """`count` distinct pieces of furniture of the given types."""
    pool = [o for o in scene.of_type(*types) if o.furniture]
    if len(pool) < count:
        raise Ungroundable(f"{len(pool)} {'/'.join(types)} in the scene, {count} needed")
    return rng.sample(pool, count)


def only(scene: Scene, object_type: str) -> SceneObject:
    """The scene's object of a type (the first, if there are several)."""
    found = scene.of_type(object_type)
    if not found:
        raise Ungroundable(f"no {object_type} in the scene")
    return found[0]


def accepts(receptacle: SceneObject, item: SceneObject) -> bool:
    """Whether an item may be placed on a receptacle (hangers take only what hangs)."""
    allowed = ACCEPTS.get(receptacle.type)
    return affordances_of(receptacle.type).receptacle and (allowed is None or item.type in allowed)


# -- teams and text ----------------------------------------------------------------------


def agent_ids(count: int) -> list[str]:
    """`agent_1` … `agent_N`."""
    return [f"agent_{i}" for i in range(1, count + 1)]


def team(roles: Sequence[str], skills: Sequence[Sequence[str]]) -> list[dict[str, Any]]:
    """Agent records `{id, role, allowed_skills}`."""
    return [
        {"id": agent, "role": role, "allowed_skills": list(own)}
        for agent, role, own in zip(agent_ids(len(roles)), roles, skills)
    ]


def role_names(stem: str, count: int) -> list[str]:
    """`Stem-A`, `Stem-B` for two agents (as the released two-agent configs), else
    `Stem-1` … `Stem-N`."""
    if count == 2:
        return [f"{stem}-A", f"{stem}-B"]
    return [f"{stem}-{i}" for i in range(1, count + 1)]


def series(words: Sequence[str]) -> str:
    """`A`, `A and B`, `A, B, and C`."""
    if len(words) <= 2:
        return " and ".join(words)
    return ", ".join(words[:-1]) + ", and " + words[-1]


def numbered_names(objects: Sequence[SceneObject]) -> list[str]:
    """Display names: the type, numbered (`Drawer_1`, `Drawer_2`) when a type repeats."""
    repeats = {o.type for o in objects if sum(p.type == o.type for p in objects) > 1}
    seen: dict[str, int] = {}
    names = []
    for o in objects:
        if o.type in repeats:
            seen[o.type] = seen.get(o.type, 0) + 1
            names.append(f"{o.type}_{seen[o.type]}")
        else:
            names.append(o.type)
    return names


def on_goals(pairs: Iterable[tuple[str, str]]) -> list[dict[str, Any]]:
    """`on` predicates for (object alias, receptacle alias) pairs."""
    return [{"predicate": "on", "object": o, "receptacle": r} for o, r in pairs]


# -- init actions ------------------------------------------------------------------------


def forced_put(receptacle_id: str) -> dict[str, Any]:
    """The init action putting what agent 0 holds on or in a receptacle, as the reference's
    K generator records it."""
    return {
        "action": "PutObject",
        "objectId": receptacle_id,
        "agentId": 0,
        "forceAction": True,
        "placeStationary": True,
    }

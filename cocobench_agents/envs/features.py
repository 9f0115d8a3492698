"""The numeric observation (``observation="numeric"``): the world, the menu and the goal as
fixed-size float32 tables, so that Gymnasium's `FlattenObservation` gives a vector a policy
network takes (the default observation's prompt text flattens to millions of entries).

Objects are numbered by slot: the order in which the episode first lists them (the scene's
objects at reset, then slices as they appear), so an object keeps its slot for the whole
episode and the menu's and the goal's columns name it by ``slot + 1`` (0: none). Type, skill,
predicate and direction ids are 1 + their index in `OBJECT_TYPES`, `SKILL_NAMES`,
`PREDICATES` and `EXPLORE_DIRECTIONS` (0: none; an object type outside the list is
``len(OBJECT_TYPES) + 1``). The layout is docs/environments.md's table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from benchmark_adapter.goals import CHECKS
from benchmark_adapter.menu import EXPLORE_DIRECTIONS
from benchmark_adapter.sim.embedded import affordances
from benchmark_adapter.sim.embedded.world import make_object, referenced_ids
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import SKILL_NAMES
from cocobench_agents.envs.seated import DONE, EnvError, SeatedEpisode
from cocobench_agents.models.protocol import MenuOption

#: What the observation option takes: the prompt text (the default) or the numeric tables.
OBSERVATIONS = ("text", "numeric")
#: The object types the embedded world knows (its affordance table and the slices it cuts).
OBJECT_TYPES: tuple[str, ...] = tuple(sorted(
    affordances.TYPES | {affordances.slice_pieces(t)[0] for t in affordances.SLICEABLE}))
#: The goal predicates, in the benchmark's order (`goals.CHECKS`).
PREDICATES: tuple[str, ...] = tuple(CHECKS)
#: An object's state flags, as its metadata names them.
STATE_FLAGS = ("visible", "isOpen", "isToggled", "isSliced", "isDirty", "isFilledWithLiquid",
               "isCooked", "isBroken", "isPickedUp")
#: An object's affordance flags.
AFFORDANCES = affordances.FLAGS
#: How many menus' entry tables an episode keeps (cleared when full).
MENU_TABLES = 64
#: The columns of the tables, in order (docs/environments.md says what each holds).
OBJECT_COLUMNS = ("present", "type", "x", "y", "z", *STATE_FLAGS, "held_by", "inside",
                  "in_goal", *AFFORDANCES)
ENTRY_COLUMNS = ("on_menu", "skill", "robot", "object", "receptacle", "direction")
GOAL_COLUMNS = ("present", "predicate", "passed", "object", "receptacle", "robot", "value")
CONTEXT_COLUMNS = ("budget_used", "steps", "budget", "seat_robot")


def object_bound(config: TaskConfig) -> int:
    """The most objects `config`'s episode can list: the scene's objects at reset, each
    sliceable one with its pieces too (slicing keeps the source in the metadata)."""
    init = config.init_state
    objects = [make_object(i) for i in referenced_ids(init.objects, init.init_actions)]
    return len(objects) + sum(affordances.slice_pieces(o.type)[1]
                              for o in objects if o.aff.sliceable)


@dataclass(frozen=True)
class NumericLayout:
    """The sizes of a source's numeric observations: every instance's fits."""

    objects: int  # rows of the object table
    entries: int  # rows of the menu table: DONE, then ids 0..max_menu (as the action mask)
    checks: int  # rows of the goal table
    robots: int  # the most robots an instance has

    @classmethod
    def of(cls, configs: Sequence[TaskConfig], max_menu: int) -> NumericLayout:
        return cls(objects=max(map(object_bound, configs)), entries=max_menu + 2,
                   checks=max(len(c.goal_predicates) for c in configs),
                   robots=max(len(c.agent_ids) for c in configs))

    def fields(self) -> dict[str, spaces.Space]:
        """The numeric observation's spaces (besides the action mask and a frame)."""
        slots, robots = float(self.objects), float(self.robots)
        objects_high = {"type": len(OBJECT_TYPES) + 1, "x": np.inf, "y": np.inf, "z": np.inf,
                        "held_by": robots, "inside": slots}
        objects_low = {"x": -np.inf, "y": -np.inf, "z": -np.inf}
        entry_high = {"skill": len(SKILL_NAMES), "robot": robots, "object": slots,
                      "receptacle": slots, "direction": len(EXPLORE_DIRECTIONS)}
        goal_high = {"predicate": len(PREDICATES), "object": slots, "receptacle": slots,
                     "robot": robots}
        context_high = {"steps": np.inf, "budget": np.inf, "seat_robot": robots}
        return {
            "objects": _table(self.objects, OBJECT_COLUMNS, objects_high, objects_low),
            "entries": _table(self.entries, ENTRY_COLUMNS, entry_high),
            "goal": _table(self.checks, GOAL_COLUMNS, goal_high),
            "context": _table(None, CONTEXT_COLUMNS, context_high)}


def _table(rows: int | None, columns: Sequence[str], high: Mapping[str, float],
           low: Mapping[str, float] | None = None) -> spaces.Box:
    """A float32 Box of `rows` × `columns` (a vector when `rows` is None), each column in
    [low, high] (default [0, 1])."""
    top = np.array([high.get(c, 1.0) for c in columns], np.float32)
    bottom = np.array([(low or {}).get(c, 0.0) for c in columns], np.float32)
    shape = (len(columns),) if rows is None else (rows, len(columns))
    return spaces.Box(np.broadcast_to(bottom, shape), np.broadcast_to(top, shape), shape,
                      np.float32)


class WorldFeatures:
    """The numeric tables of one live episode, its object slots kept from its reset on."""

    def __init__(self, layout: NumericLayout) -> None:
        self.layout = layout
        self._tools: object = None  # the episode's tools: made afresh by each reset
        self._slots: dict[str, int] = {}
        self._tables: dict[int, tuple[Sequence[MenuOption], np.ndarray]] = {}  # by menu
        self._shared: tuple[object, int, dict[str, np.ndarray]] | None = None

    def shared(self, episode: SeatedEpisode) -> dict[str, np.ndarray]:
        """The object and goal tables now (the same for every seat; made once a step)."""
        if self._tools is not episode.tools:
            self._tools, self._slots, self._tables = episode.tools, {}, {}
        key = len(episode.episode.items)
        if self._shared is None or self._shared[0] is not self._tools \
                or self._shared[1] != key:
            tables = {"objects": self._objects(episode), "goal": self._goal(episode)}
            self._shared = (self._tools, key, tables)
        return self._shared[2]

    def encode(self, episode: SeatedEpisode, seat: str, menu: Sequence[MenuOption]
               ) -> dict[str, np.ndarray]:
        """`seat`'s numeric observation: the shared tables, its menu's entries and its
        context."""
        tables = self.shared(episode)
        agents = episode.spec.config.agent_ids
        used = episode.tools.step_index
        budget = episode.spec.budget
        context = np.array([min(used / budget, 1.0), used, budget,
                            agents.index(seat) + 1 if seat in agents else 0], np.float32)
        return {"objects": tables["objects"].copy(), "entries": self._entries(episode, menu),
                "goal": tables["goal"].copy(), "context": context}

    def _slot(self, object_id: str) -> int:
        slot = self._slots.get(object_id)
        if slot is None:
            slot = self._slots[object_id] = len(self._slots)
            if slot >= self.layout.objects:
                raise EnvError(f"object {object_id} is the episode's {slot + 1}th: the numeric "
                               f"observation holds {self.layout.objects} objects")
        return slot

    def _ref(self, object_id: str | None) -> int:
        """An object's column value: its slot + 1 (0: none, or an object never listed)."""
        if not object_id or object_id not in self._slots:
            return 0
        return self._slots[object_id] + 1

    def _objects(self, episode: SeatedEpisode) -> np.ndarray:
        world = episode.episode
        objects = world.objects()
        for obj in objects:
            self._slot(obj["objectId"])
        agents = world.config.agent_ids
        holder = {oid: agents.index(a) + 1 for a, held in world.inventories().items()
                  for oid in held}
        in_goal = {oid for _, args in world.goals.goals
                   for oid in (args.obj, args.receptacle, args.source) if oid}
        rows = []
        for obj in objects:
            oid = obj["objectId"]
            position = obj.get("position") or {}
            parents = obj.get("parentReceptacles")
            rows.append([1.0, _type_id(obj.get("objectType", "")), position.get("x", 0.0),
                         position.get("y", 0.0), position.get("z", 0.0),
                         *[obj.get(f) or 0 for f in STATE_FLAGS], holder.get(oid, 0),
                         self._ref(parents[0] if parents else None), oid in in_goal,
                         *[obj.get(f) or 0 for f in AFFORDANCES]])
        table = np.zeros((self.layout.objects, len(OBJECT_COLUMNS)), np.float32)
        if rows:  # (one conversion: row by row was most of an observation's time)
            table[[self._slots[o["objectId"]] for o in objects]] = np.array(rows, np.float32)
        return table

    def _goal(self, episode: SeatedEpisode) -> np.ndarray:
        world = episode.episode
        checks = world.items[-1]["eval"]["checks"]
        agents = world.config.agent_ids
        table = np.zeros((self.layout.checks, len(GOAL_COLUMNS)), np.float32)
        for row, ((goal, args), check) in enumerate(zip(world.goals.goals, checks)):
            table[row] = [1.0, PREDICATES.index(goal.predicate) + 1
                          if goal.predicate in PREDICATES else 0,
                          bool(check["passed"]), self._ref(args.obj or args.source),
                          self._ref(args.receptacle),
                          agents.index(args.agent) + 1 if args.agent in agents else 0,
                          bool(args.value)]
        return table

    def _entries(self, episode: SeatedEpisode, menu: Sequence[MenuOption]) -> np.ndarray:
        # A seat's menu is the same object until it changes (`EpisodeTools`' menu views), and
        # its table depends on nothing else once its objects have slots: made once per menu.
        made = self._tables.get(id(menu))
        if made is None or made[0] is not menu:
            if len(self._tables) >= MENU_TABLES:
                self._tables.clear()
            made = self._tables[id(menu)] = (menu, self._entry_table(episode, menu))
        return made[1].copy()

    def _entry_table(self, episode: SeatedEpisode, menu: Sequence[MenuOption]) -> np.ndarray:
        table = np.zeros((self.layout.entries, len(ENTRY_COLUMNS)), np.float32)
        if not menu:
            return table
        snapshot = episode.tools.snapshot
        by_call = {e.call: e for e in snapshot.action_menu} if snapshot is not None else {}
        agents = episode.spec.config.agent_ids
        rows = [option.action_id - DONE for option in menu]
        table[[0, *rows], 0] = 1.0  # DONE, and each id on the menu
        for row, option in zip(rows, menu):
            entry = by_call.get(option.call)
            if entry is None:  # a planner's own menu entry (not a skill call): its id only
                continue
            objects = [a for a in entry.args if a in self._slots]
            direction = next((a for a in entry.args if a in EXPLORE_DIRECTIONS), None)
            table[row, 1:] = (
                _SKILL_IDS.get(entry.skill, 0),
                agents.index(entry.agent) + 1 if entry.agent in agents else 0,
                self._ref(objects[0] if objects else None),
                self._ref(objects[1] if len(objects) > 1 else None),
                EXPLORE_DIRECTIONS.index(direction) + 1 if direction else 0)
        return table


_TYPE_IDS = {t: i + 1 for i, t in enumerate(OBJECT_TYPES)}
_SKILL_IDS = {s: i + 1 for i, s in enumerate(SKILL_NAMES)}


def _type_id(object_type: str) -> int:
    return _TYPE_IDS.get(object_type, len(OBJECT_TYPES) + 1)


def check_observation(observation: Any) -> None:
    """`observation` is one of `OBSERVATIONS` (`EnvError` otherwise)."""
    if observation not in OBSERVATIONS:
        raise EnvError(f"observation must be {' or '.join(map(repr, OBSERVATIONS))}, not "
                       f"{observation!r}")

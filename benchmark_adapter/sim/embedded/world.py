"""The embedded world's state and its grounding from a task config.

Object ids are opaque except for their position: AI2-THOR encodes an object's position in its
id (`Type|x|y|z`), and that is all the grounding reads from it (reference §10.17). Everything
else comes from the type's affordances.
"""

from __future__ import annotations

import functools
import math
import random
import zlib
from dataclasses import dataclass, field

from benchmark_adapter.sim.embedded.affordances import Affordances, affordances_of

GRID = 0.25
AGENT_Y = 0.9  # AI2-THOR's agent position height
CAMERA_HEIGHT = 1.5763  # standing camera height above the floor
AGENT_RADIUS = 0.2  # two agents collide when closer than twice this
# Metres: no scene is near this large, so a coordinate beyond it is off every floor (and the
# grid arithmetic on it cannot overflow).
MAX_COORDINATE = 1e4
# Metres from the origin: AI2-THOR's scenes lie within about 10 m of it (every config here
# within 7.3 m). The floor grid spans every object, so an id placing one further (a task
# config's `Apple|+3000.00|…`) would take minutes and gigabytes to build (300 m: 14 s).
MAX_SCENE_COORDINATE = 50.0
# Put slots lie 0.08 m apart around a receptacle's position, three to a row (`_attach`); a
# content lies within its receptacle's slots plus this margin (metres, horizontally).
SLOT_SPACING, CONTENT_MARGIN = 0.08, 0.12


@dataclass
class SimObject:
    """One object of the world, with its mutable state."""

    id: str
    type: str
    x: float
    y: float
    z: float
    aff: Affordances
    is_open: bool = False
    is_toggled: bool = False
    is_sliced: bool = False
    is_dirty: bool = False
    is_filled: bool = False
    fill_liquid: str | None = None
    is_broken: bool = False
    is_cooked: bool = False
    parent: str | None = None
    contents: list[str] = field(default_factory=list)
    held_by: int | None = None


@dataclass
class SimAgent:
    """One agent: a pose on the grid and at most one held object."""

    index: int
    x: float
    z: float
    yaw: float = 0.0
    horizon: float = 0.0
    standing: bool = True
    held: str | None = None
    last_action: str = ""
    last_success: bool = True
    last_error: str = ""
    last_return: object = None

    @property
    def name(self) -> str:
        """AI2-THOR's agent name (`agent_k` in the benchmark is agentId k-1)."""
        return f"agent_{self.index + 1}"


class ContainmentError(RuntimeError):
    """The world's containment is no longer a forest: a cycle, or a link one side lacks.

    The executor's rules never let this happen; raising stops a walk over the parents that
    would otherwise loop forever (issue 24)."""


@dataclass
class World:
    """Objects, agents and the walkable floor grid.

    Containment is a forest: each object has at most one `parent`, which lists it in its
    `contents`, and no object is inside itself, directly or through what it contains.
    """

    objects: dict[str, SimObject]
    agents: list[SimAgent]
    floor: frozenset[tuple[int, int]]  # walkable cells, in grid units
    visibility_distance: float = 1.5
    version: int = 0  # bumped on every change, for caches

    def cell_of(self, x: float, z: float) -> tuple[int, int]:
        """Grid cell containing a floor point."""
        return (round(x / GRID), round(z / GRID))

    def walkable(self, x: float, z: float) -> bool:
        """Whether an agent may stand at (x, z)."""
        if not (abs(x) <= MAX_COORDINATE and abs(z) <= MAX_COORDINATE):  # NaN too
            return False
        cx, cz = self.cell_of(x, z)
        on_grid = abs(cx * GRID - x) < 1e-6 and abs(cz * GRID - z) < 1e-6
        return on_grid and (cx, cz) in self.floor

    def ancestors(self, obj: SimObject) -> list[SimObject]:
        """The receptacles `obj` lies in, innermost first.

        A chain longer than the number of objects must loop: the walk stops there (so it is
        bounded by the number of objects) and raises `ContainmentError` naming the loop, as
        it does for an unknown parent, instead of running forever.
        """
        chain: list[SimObject] = []
        parent_id = obj.parent
        while parent_id is not None:
            parent = self.objects.get(parent_id)
            if parent is None:
                raise ContainmentError(f"{obj.id} lies in {parent_id}, which is not an object")
            chain.append(parent)
            if len(chain) > len(self.objects):
                raise ContainmentError(f"containment cycle: {_loop(obj, chain)}")
            parent_id = parent.parent
        return chain

    def lies_within(self, obj: SimObject, outer: SimObject) -> bool:
        """Whether `obj` is `outer` or lies inside it, directly or transitively."""
        return obj.id == outer.id or any(p.id == outer.id for p in self.ancestors(obj))

    def descendants(self, obj: SimObject) -> list[SimObject]:
        """Everything that lies in `obj`, at any depth (bounded like `ancestors`)."""
        out: list[SimObject] = []
        pending = list(obj.contents)
        while pending:
            content = self.objects[pending.pop()]
            out.append(content)
            if len(out) > len(self.objects):
                raise ContainmentError(f"containment cycle below {obj.id}")
            pending.extend(content.contents)
        return out

    def carrier(self, obj: SimObject) -> int | None:
        """The agent whose hand holds `obj` or a receptacle it lies in (None if nobody):
        in AI2-THOR a picked-up receptacle's contents travel in the hand with it."""
        if obj.held_by is not None or obj.parent is None:
            return obj.held_by
        return next((p.held_by for p in self.ancestors(obj) if p.held_by is not None), None)

    def check_containment(self) -> None:
        """Raise `ContainmentError` unless containment is a forest whose links agree both
        ways (`parent` and `contents`), held objects lie in nothing, each content lies
        within its receptacle's bounds and every position is finite."""
        for obj in self.objects.values():
            if not all(math.isfinite(v) for v in (obj.x, obj.y, obj.z)):
                raise ContainmentError(f"{obj.id} has a non-finite position")
            if obj.parent is not None:
                parent = self.objects.get(obj.parent)
                if parent is None or obj.id not in parent.contents:
                    raise ContainmentError(
                        f"{obj.id} names {obj.parent} as its parent, which does not list it"
                    )
                if obj.held_by is not None:
                    raise ContainmentError(f"{obj.id} is held and lies in {obj.parent}")
            if len(set(obj.contents)) != len(obj.contents):
                raise ContainmentError(f"{obj.id} lists an object twice: {obj.contents}")
            for content_id in obj.contents:
                content = self.objects.get(content_id)
                if content is None or content.parent != obj.id:
                    raise ContainmentError(
                        f"{obj.id} lists {content_id}, whose parent is not {obj.id}"
                    )
            self.ancestors(obj)
        for obj in self.objects.values():  # a forest now: where its contents lie
            parent = self.objects[obj.parent] if obj.parent is not None else None
            if parent is not None and not within_bounds(obj, parent):
                raise ContainmentError(
                    f"{obj.id} lies {math.hypot(obj.x - parent.x, obj.z - parent.z):.2f} m "
                    f"from {parent.id}, which contains it"
                )

    def blocking_agent(self, x: float, z: float, ignore: int) -> SimAgent | None:
        """Another agent whose body would overlap an agent standing at (x, z)."""
        for other in self.agents:
            if other.index != ignore and math.hypot(other.x - x, other.z - z) < 2 * AGENT_RADIUS:
                return other
        return None


def content_reach(receptacle: SimObject) -> float:
    """How far (horizontally) from a receptacle's position its contents may lie: its
    furthest put slot plus a margin, or its footprint if wider (a Plate 0.2 m, a CounterTop
    0.53 m, a Bed 0.8 m)."""
    rows = (max(receptacle.aff.capacity, 1) - 1) // 3
    return max(SLOT_SPACING * math.hypot(1, rows) + CONTENT_MARGIN, receptacle.aff.footprint)


def within_bounds(content: SimObject, receptacle: SimObject, slack: float = 1e-6) -> bool:
    """Whether `content` lies where a content of `receptacle` can: within `content_reach`
    of it horizontally, between its base and its top."""
    reach = content_reach(receptacle) + slack
    top = receptacle.y + receptacle.aff.height
    return (math.hypot(content.x - receptacle.x, content.z - receptacle.z) <= reach
            and receptacle.y - slack <= content.y <= top + slack)


def _loop(obj: SimObject, chain: list[SimObject]) -> str:
    """The path from `obj` up its looping `chain` to the first object seen twice."""
    path, seen = [obj.id], {obj.id}
    for parent in chain:
        path.append(parent.id)
        if parent.id in seen:
            break
        seen.add(parent.id)
    return " -> ".join(path)


def position_from_id(object_id: str) -> tuple[float, float, float]:
    """The position encoded in an AI2-THOR id; a stable pseudo-position if there is none."""
    parts = object_id.split("|")
    try:
        return float(parts[1]), float(parts[2]), float(parts[3])
    except (IndexError, ValueError):
        rng = random.Random(zlib.crc32(object_id.encode()))
        return rng.uniform(-2, 2), 0.9, rng.uniform(-2, 2)


def type_from_id(object_id: str) -> str:
    """The object type: the id's prefix (the last part for sliced pieces)."""
    parts = object_id.split("|")
    if len(parts) > 4 and parts[-1][:1].isalpha():
        return parts[-1].split("_")[0]
    return parts[0]


def make_object(object_id: str) -> SimObject:
    """An object in its default state, placed where its id says."""
    x, y, z = position_from_id(object_id)
    t = type_from_id(object_id)
    return SimObject(id=object_id, type=t, x=x, y=y, z=z, aff=affordances_of(t))


def referenced_ids(objects: dict[str, str], init_actions: list[dict]) -> list[str]:
    """Important objects plus any object an init action names, in first-seen order."""
    ids = list(dict.fromkeys(objects.values()))
    for action in init_actions:
        oid = action.get("objectId")
        if isinstance(oid, str) and "|" in oid and oid not in ids:
            ids.append(oid)
    return ids


def build_floor(objects: list[SimObject], margin: float = 1.25) -> frozenset[tuple[int, int]]:
    """Walkable cells: the objects' bounding box plus a margin, minus furniture footprints.
    `ValueError` naming an object that lies beyond `MAX_SCENE_COORDINATE` or at no finite
    position (its id says so)."""
    for obj in objects:
        if not all(abs(v) <= MAX_SCENE_COORDINATE for v in (obj.x, obj.y, obj.z)):  # NaN too
            raise ValueError(f"{obj.id} lies at ({obj.x:g}, {obj.y:g}, {obj.z:g}): not "
                             f"within {MAX_SCENE_COORDINATE:g} m of the scene's origin")
    return _floor(tuple((o.x, o.z, o.aff.footprint) for o in objects), margin)


@functools.lru_cache(maxsize=256)
def _floor(
    geometry: tuple[tuple[float, float, float], ...], margin: float
) -> frozenset[tuple[int, int]]:
    """Cached: every reset of the same scene grounds the same floor."""
    xs = [x for x, _, _ in geometry] or [0.0]
    zs = [z for _, z, _ in geometry] or [0.0]
    x0, x1 = math.floor((min(xs) - margin) / GRID), math.ceil((max(xs) + margin) / GRID)
    z0, z1 = math.floor((min(zs) - margin) / GRID), math.ceil((max(zs) + margin) / GRID)
    cells = {(cx, cz) for cx in range(x0, x1 + 1) for cz in range(z0, z1 + 1)}
    for bx, bz, r in geometry:
        if r <= 0:
            continue
        # A cell within r of the blocker is within r on each axis: test only those (with a
        # cell of slack), not the whole room.
        for cx in range(math.floor((bx - r) / GRID) - 1, math.ceil((bx + r) / GRID) + 2):
            for cz in range(math.floor((bz - r) / GRID) - 1, math.ceil((bz + r) / GRID) + 2):
                if math.hypot(bx - cx * GRID, bz - cz * GRID) <= r:
                    cells.discard((cx, cz))
    return frozenset(cells)


def place_agents(
    floor: frozenset[tuple[int, int]],
    count: int,
    seed: int,
    scene: str,
    min_separation: float = 0.75,
) -> list[SimAgent]:
    """Agents on distinct walkable cells, chosen deterministically from the seed and scene."""
    return [SimAgent(index=index, x=x, z=z, yaw=yaw)
            for index, (x, z, yaw) in enumerate(
                _placements(floor, count, seed, scene, min_separation))]


# A run plays each task under several planners, models and samples, and drawing the shuffle
# of every floor cell was most of a reset: each task's placement is drawn once.
@functools.lru_cache(maxsize=1024)
def _placements(floor: frozenset[tuple[int, int]], count: int, seed: int, scene: str,
                min_separation: float) -> tuple[tuple[float, float, float], ...]:
    """`place_agents`' poses (x, z, yaw), in agent order."""
    rng = random.Random(zlib.crc32(f"{scene}:{seed}".encode()))
    cells = sorted(floor)
    placed: list[tuple[float, float, float]] = []
    for cx, cz in rng.sample(cells, len(cells)):
        x, z = cx * GRID, cz * GRID
        if all(math.hypot(px - x, pz - z) >= min_separation for px, pz, _ in placed):
            placed.append((x, z, 90.0 * rng.randrange(4)))
        if len(placed) == count:
            return tuple(placed)
    raise ValueError(f"scene {scene}: no room for {count} agents on the floor grid")


def ground_world(
    scene: str,
    objects: dict[str, str],
    init_actions: list[dict],
    agent_count: int,
    seed: int,
    visibility_distance: float = 1.5,
) -> World:
    """Build the world of a task config: its objects, floor and agents."""
    sim_objects = {oid: make_object(oid) for oid in referenced_ids(objects, init_actions)}
    floor = build_floor(list(sim_objects.values()))
    agents = place_agents(floor, agent_count, seed, scene)
    return World(
        objects=sim_objects, agents=agents, floor=floor, visibility_distance=visibility_distance
    )

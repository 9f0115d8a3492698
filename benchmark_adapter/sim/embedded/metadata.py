"""Per-agent metadata in AI2-THOR's schema, built lazily.

Building every object's record for every agent after every native action dominates the cost
of a step, and the executor usually reads only a few fields. So each `AgentMetadata` holds its
scalar fields and builds `objects` on first access. The controller freezes (materialises) any
metadata still referenced before it changes the world, so a mapping is always a snapshot of
the moment it was returned. Likewise a snapshot builds each agent's metadata on first access,
and the controller builds the rest of any snapshot still referenced before its next action.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, overload

from benchmark_adapter.sim.embedded.vision import visible
from benchmark_adapter.sim.embedded.world import AGENT_Y, SimAgent, SimObject, World


def object_record(world: World, obj: SimObject) -> dict[str, Any]:
    """An object's metadata without the per-agent fields (`visible`, `distance`)."""
    a = obj.aff
    return {
        "objectId": obj.id,
        "objectType": obj.type,
        "name": obj.id.replace("|", "_"),
        "position": {"x": obj.x, "y": obj.y, "z": obj.z},
        "rotation": {"x": 0.0, "y": 0.0, "z": 0.0},
        "pickupable": a.pickupable,
        "isPickedUp": obj.held_by is not None,
        "receptacle": a.receptacle,
        "receptacleObjectIds": list(obj.contents) if a.receptacle else None,
        "parentReceptacles": _parents(world, obj),
        "openable": a.openable,
        "isOpen": obj.is_open,
        "openness": 1.0 if obj.is_open else 0.0,
        "toggleable": a.toggleable,
        "isToggled": obj.is_toggled,
        "sliceable": a.sliceable,
        "isSliced": obj.is_sliced,
        "dirtyable": a.dirtyable,
        "isDirty": obj.is_dirty,
        "canFillWithLiquid": a.canFillWithLiquid,
        "isFilledWithLiquid": obj.is_filled,
        "fillLiquid": obj.fill_liquid,
        "breakable": a.breakable,
        "isBroken": obj.is_broken,
        "cookable": a.cookable,
        "isCooked": obj.is_cooked,
        "moveable": a.moveable,
    }


def _parents(world: World, obj: SimObject) -> list[str] | None:
    return [p.id for p in world.ancestors(obj)] or None


def _record_inputs(world: World, obj: SimObject) -> tuple:
    """Everything `object_record` reads of `obj` that can change (its id, type and frozen
    affordances cannot)."""
    return (obj.x, obj.y, obj.z, obj.held_by is not None, tuple(obj.contents),
            tuple(p.id for p in world.ancestors(obj)), obj.is_open, obj.is_toggled,
            obj.is_sliced, obj.is_dirty, obj.is_filled, obj.fill_liquid, obj.is_broken,
            obj.is_cooked)


def agent_record(agent: SimAgent) -> dict[str, Any]:
    """An agent's pose, as its metadata's ``agent``."""
    return {
        "name": agent.name,
        "position": {"x": agent.x, "y": AGENT_Y, "z": agent.z},
        "rotation": {"x": 0.0, "y": agent.yaw, "z": 0.0},
        "cameraHorizon": agent.horizon,
        "isStanding": agent.standing,
    }


def inventory(world: World, agent: SimAgent) -> list[dict[str, Any]]:
    """What an agent holds, as its metadata's ``inventoryObjects``."""
    held = world.objects.get(agent.held) if agent.held else None
    return [{"objectId": held.id, "objectType": held.type}] if held else []


class ObjectTable:
    """Object records of the current world version, shared by every agent's metadata."""

    def __init__(self, world: World) -> None:
        self.world = world
        self._version = -1
        self._records: list[dict[str, Any]] = []
        # Each object's last record with the object and inputs it was built from: an action
        # changes one object or a few (an agent's move none), so most records are kept as
        # they are. Like the records of one version, they are read-only.
        self._built: dict[str, tuple[SimObject, tuple, dict[str, Any]]] = {}

    def records(self) -> list[dict[str, Any]]:
        """Records for the current version (rebuilt only after the world changed, and then
        only those of objects that changed)."""
        world = self.world
        if self._version != world.version:
            built, records = self._built, []
            for obj in world.objects.values():
                inputs = _record_inputs(world, obj)
                known = built.get(obj.id)
                if known is None or known[0] is not obj or known[1] != inputs:
                    known = built[obj.id] = (obj, inputs, object_record(world, obj))
                records.append(known[2])
            self._records, self._version = records, world.version
        return self._records

    def for_agent(self, agent: SimAgent) -> list[dict[str, Any]]:
        """Records with this agent's `visible` and `distance`."""
        world = self.world
        out = []
        for record, obj in zip(self.records(), world.objects.values()):
            distance = math.hypot(obj.x - agent.x, obj.z - agent.z)
            out.append({**record, "visible": visible(world, agent, obj), "distance": distance})
        return out

    def one_for_agent(self, agent: SimAgent, object_id: str) -> dict[str, Any] | None:
        """The record `for_agent` holds for `object_id` (None if no such object), built
        alone."""
        world = self.world
        obj = world.objects.get(object_id)
        if obj is None:
            return None
        distance = math.hypot(obj.x - agent.x, obj.z - agent.z)
        return {**object_record(world, obj), "visible": visible(world, agent, obj),
                "distance": distance}


class AgentMetadata(Mapping[str, Any]):
    """One agent's metadata; `objects` is built on first access."""

    __slots__ = ("__weakref__", "_agent", "_data", "_objects", "_table")

    def __init__(self, table: ObjectTable, agent: SimAgent, scene: str) -> None:
        self._table, self._agent, self._objects = table, agent, None
        self._data = {
            "agentId": agent.index,
            "sceneName": scene,
            "fov": 90.0,
            "agent": agent_record(agent),
            "inventoryObjects": inventory(table.world, agent),
            "lastAction": agent.last_action,
            "lastActionSuccess": agent.last_success,
            "errorMessage": agent.last_error,
            "actionReturn": agent.last_return,
        }

    def freeze(self) -> None:
        """Build `objects` now, before the world changes."""
        if self._objects is None:
            self._objects = self._table.for_agent(self._agent)

    def find_object(self, object_id: str) -> dict[str, Any] | None:
        """The record `objects` holds for `object_id` (None if none). A skill looks up one
        object after most native actions (a Find's teleports test one target): while
        `objects` is unbuilt the world is as it was at the snapshot, so the record is built
        alone, equal to the one `objects` would hold."""
        if self._objects is None:
            return self._table.one_for_agent(self._agent, object_id)
        return next((o for o in self._objects if o["objectId"] == object_id), None)

    def __getitem__(self, key: str) -> Any:
        if key == "objects":
            self.freeze()
            return self._objects
        return self._data[key]

    def __iter__(self) -> Iterator[str]:
        yield from self._data
        yield "objects"

    def __len__(self) -> int:
        return len(self._data) + 1


class Snapshot(Sequence[AgentMetadata]):
    """Every agent's metadata as of one moment, each agent's built on first access (a
    Find's teleports read only the acting agent's). Its factory builds the rest before the
    next action changes any agent, so every entry is of that moment."""

    __slots__ = ("__weakref__", "_agents", "_built", "_factory")

    def __init__(self, factory: MetadataFactory, agents: list[SimAgent]) -> None:
        self._factory, self._agents = factory, agents
        self._built: list[AgentMetadata | None] = [None] * len(agents)

    def __len__(self) -> int:
        return len(self._agents)

    def __iter__(self) -> Iterator[AgentMetadata]:
        # Sequence's own __iter__ indexes until an IndexError: this one is several times
        # cheaper, and a skill's checks iterate every agent's metadata.
        for index in range(len(self._agents)):
            yield self[index]

    @overload
    def __getitem__(self, index: int) -> AgentMetadata: ...

    @overload
    def __getitem__(self, index: slice) -> list[AgentMetadata]: ...

    def __getitem__(self, index: int | slice) -> AgentMetadata | list[AgentMetadata]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self._agents)))]
        md = self._built[index]  # an IndexError as a list's
        if md is None:
            md = self._built[index] = self._factory.metadata(self._agents[index])
        return md

    def build(self) -> None:
        """Build every agent's metadata now."""
        for i, md in enumerate(self._built):
            if md is None:
                self._built[i] = self._factory.metadata(self._agents[i])


class MetadataFactory:
    """Hands out metadata snapshots; builds what live snapshots have not built before each
    action, and freezes the live metadata before each world change."""

    def __init__(self, world: World, scene: str) -> None:
        self.table = ObjectTable(world)
        self.scene = scene
        self._live: list[weakref.ref[AgentMetadata]] = []
        self._snapshots: list[weakref.ref[Snapshot]] = []

    def snapshot(self) -> Snapshot:
        """Every agent's metadata as of now."""
        out = Snapshot(self, self.table.world.agents)
        self._snapshots.append(weakref.ref(out))
        return out

    def metadata(self, agent: SimAgent) -> AgentMetadata:
        """`agent`'s metadata as of now."""
        md = AgentMetadata(self.table, agent, self.scene)
        self._live.append(weakref.ref(md))
        return md

    def before_action(self) -> None:
        """Build every entry a live snapshot has not built: any action changes the acting
        agent's last action."""
        for ref in self._snapshots:
            snapshot = ref()
            if snapshot is not None:
                snapshot.build()
        self._snapshots = []

    def before_change(self) -> None:
        """Freeze every snapshot someone still holds."""
        self.before_action()
        for ref in self._live:
            md = ref()
            if md is not None:
                md.freeze()
        self._live = []

"""D4 handoff: Relay Items and Indirect Relay (C_D4), Cross-Zone Handoff (J_D4).

Items travel source -> one transfer point (buffer capacity 1) -> final receptacle. With two
agents one producer feeds one consumer; larger teams fan in/out: producers are the first
⌊n/2⌋ agents, consumers the rest. The menu enforces the roles (reference §5.2).
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from typing import Any

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import (
    CONSUMER_SKILLS,
    FOODS,
    PRODUCER_SKILLS,
    Draft,
    TaskType,
    Ungroundable,
    agent_ids,
    on_goals,
    only,
    pick_loose,
    series,
    team,
)
from benchmark_adapter.generator.templates.relay_places import (
    cross_zone_places,
    relay_places,
)
from benchmark_adapter.vocabulary import PRODUCER_CONSUMER


def roles(agents: int) -> tuple[list[str], list[str]]:
    """(producers, consumers): one each for two agents, else the first ⌊n/2⌋ produce."""
    ids = agent_ids(agents)
    split = max(1, agents // 2)
    return ids[:split], ids[split:]


def _role_names(agents: int, fan_prefix: str) -> list[str]:
    producers, consumers = roles(agents)
    if agents == 2:
        return ["Agent-Source", "Agent-Target"]
    return [f"{fan_prefix}Source-{i}" for i in range(1, len(producers) + 1)] + [
        f"{fan_prefix}Target-{i}" for i in range(1, len(consumers) + 1)
    ]


def _relay_constraints(
    agents: int, buffer: SceneObject, target: SceneObject, names: tuple[str, str, str]
) -> dict[str, Any]:
    """precedence, roles, buffer station and producer/consumer block (reference §2.4)."""
    item, transfer, final = names
    producers, consumers = roles(agents)
    note = (
        "Relay enforced at the action menu: producers Put->buffer only; consumers PickUp only "
        f"on-buffer objects, Put->{final} only."
    )
    if agents == 2:
        pc: dict[str, Any] = {"producer": producers[0], "consumer": consumers[0]}
    else:
        pc = {"producers": producers, "consumers": consumers}
    return {
        "precedence": [
            [f"Source.Put({item}, {transfer})", f"Target.PickUp({item} from {transfer})"],
            [f"Target.PickUp({item})", f"Target.Put({item}, {final})"],
        ],
        "role_constraints": ["Producers handle source-to-buffer; consumers handle "
                             "buffer-to-target."],
        "legal_plan": f"Each {item} must pass through the transfer point before the final "
        "placement.",
        "buffer_stations": [{"objectId": buffer.id, "capacity": 1}],
        "producer_consumer": pc
        | {"buffer": buffer.id, "targets": [target.id], "note": note},
    }


def _relay_draft(
    task_name: str,
    items: Sequence[SceneObject],
    buffer: tuple[str, SceneObject],
    target: tuple[str, SceneObject],
    agents: int,
    item_alias: str = "item",
    fan_prefix: str = "",
    consumer_extra: Sequence[str] = (),
) -> Draft:
    (buffer_alias, buffer_obj), (target_alias, target_obj) = buffer, target
    producers, consumers = roles(agents)
    skills = [PRODUCER_SKILLS] * len(producers) + [CONSUMER_SKILLS + list(consumer_extra)] * len(
        consumers
    )
    objects = {f"{item_alias}_{i}": o for i, o in enumerate(items, 1)}
    objects |= {buffer_alias: buffer_obj, target_alias: target_obj}
    return Draft(
        task_name=task_name,
        objects=objects,
        goals=on_goals((f"{item_alias}_{i}", target_alias) for i in range(1, len(items) + 1)),
        constraints=_relay_constraints(
            agents, buffer_obj, target_obj, (item_alias, buffer_alias, target_alias)
        ),
        agents=team(_role_names(agents, fan_prefix), skills),
        instruction="",
        notes=[
            f"{len(items)} items are relayed source -> {buffer_obj.type} (buffer capacity 1) "
            f"-> {target_obj.type} by {len(producers)} producer(s) and {len(consumers)} "
            "consumer(s).",
            "Producers may only Put on the buffer; consumers may only PickUp on-buffer items "
            "and Put on the target.",
        ],
        object_count=len(items),
        stocked=[target_alias],
    )


def item_count(agents: int) -> int:
    """Items to relay: three, or one per agent in larger teams (as the released configs)."""
    return max(3, agents)


def relay_items(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Move items to a target by relaying them through an intermediate surface."""
    items = pick_loose(scene, rng, item_count(agents))
    transfer, target = relay_places(scene, items, rng)
    name = f"{scene.room}_multi_object_relay" if agents == 2 else "multi_object_relay_fan"
    draft = _relay_draft(name, items, ("transfer", transfer), ("target", target), agents)
    draft.instruction = (
        f"Move the {series([i.type for i in items])} to the {target.type} by relaying them "
        f"through the intermediate {transfer.type}."
    )
    return draft


def indirect_relay(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Put foods in the fridge by passing them over a plate first."""
    plates = scene.loose("Plate")
    if not plates:
        raise Ungroundable("no Plate in plain sight to serve as the transfer point")
    foods = pick_loose(scene, rng, item_count(agents), FOODS)
    fridge = only(scene, "Fridge")
    draft = _relay_draft(
        "multi_object_relay_via_transfer_point",
        foods,
        ("transfer_plate", plates[0]),
        ("fridge", fridge),
        agents,
        item_alias="food",
        consumer_extra=("Open", "Close"),
    )
    draft.stocked = []  # a loaded fridge door cannot swing (reference §10.2): keep it empty
    draft.setup = [
        {
            "action": "OpenObject",
            "objectId": fridge.id,
            "forceAction": True,
            "note": "Fridge starts open so the consumers can deposit relayed foods.",
        }
    ]
    draft.instruction = (
        f"Put the {series([f.type for f in foods])} in the Fridge by first using the Plate as "
        "a transfer point."
    )
    return draft


def cross_zone_handoff(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Relay items from a source zone across the room to a target in the other zone."""
    items, transfer, target = cross_zone_places(scene, item_count(agents), rng)
    suffix = "" if agents == 2 else "_fan"
    name = f"{scene.room}_cross_zone_handoff_relay{suffix}"
    draft = _relay_draft(
        name, items, ("transfer", transfer), ("target", target), agents, fan_prefix="Agent-"
    )
    distance = math.hypot(items[0].x - target.x, items[0].z - target.z)
    draft.notes.insert(1, f"Source zone and target zone are {distance:.1f} m apart.")
    draft.instruction = (
        f"Relay the {series([i.type for i in items])} across room zones so they end up on the "
        f"{target.type}."
    )
    return draft


DIM = PRODUCER_CONSUMER  # what every task type here exercises
D4_TYPES = (
    TaskType("relay_items", "Relay Items", "C", DIM, ("living_room", "bedroom", "bathroom"),
             "C_D4", relay_items),
    TaskType("indirect_relay", "Indirect Relay", "C", DIM, ("kitchen",), "C_D4",
             indirect_relay),
    TaskType("cross_zone_handoff", "Cross-Zone Handoff", "J", DIM, ("living_room", "bedroom"),
             "J_D4", cross_zone_handoff),
)

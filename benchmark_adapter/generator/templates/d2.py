"""D2 sequential ordering: Stock Cabinet (A_D2), Load in Order (C_D2), Fill Drawers in Order
(H_D2).

One closed container must be opened before any placement and closed only after the last one;
the team shares all skills, so the order is the coordination signal. The config alias of the
container is `container`, which the D2 construct recognises as a chain-operation target.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import (
    LOADER_SKILLS,
    Draft,
    TaskType,
    Ungroundable,
    on_goals,
    pick_furniture,
    pick_loose,
    role_names,
    series,
    team,
)
from benchmark_adapter.vocabulary import PRECEDENCE

KITCHEN_STOCK = ("Apple", "Tomato", "Lettuce", "Potato", "Bread", "Bowl", "Mug", "Cup",
                 "SaltShaker", "PepperShaker")
CHAIN_NOTE = (
    "Engine-enforced precedence: a closed container rejects Put, so Open must precede every "
    "Put; closing before all items are in would block the remaining Puts."
)


def _loading_draft(
    task_name: str,
    container: SceneObject,
    items: Sequence[SceneObject],
    agents: int,
    carrier_note: str,
) -> Draft:
    """The shared shape of the three ordered-loading task types."""
    objects = {f"item_{i}": item for i, item in enumerate(items, 1)} | {"container": container}
    kind = container.type
    return Draft(
        task_name=task_name,
        objects=objects,
        goals=[
            *on_goals((f"item_{i}", "container") for i in range(1, len(items) + 1)),
            {"predicate": "closed", "object": "container"},
        ],
        constraints={
            "precedence": [
                ["Open(container)", "Put(item, container)"],
                ["Put(item, container)", "Close(container)"],
            ],
            "role_constraints": [
                "All agents share all skills; the ordering open -> load(all) -> close is the "
                "coordination signal."
            ],
            "legal_plan": "Open before any placement; close only after all items are inside.",
        },
        agents=team(role_names("Agent", agents), [LOADER_SKILLS] * agents),
        instruction=(
            f"Put the {series([i.type for i in items])} in the {kind}, then close the {kind} "
            "after all of them are inside."
        ),
        notes=[
            CHAIN_NOTE,
            f"agent_1 opens and loads the first item; the others load the rest; the last "
            f"loader closes -> a cross-agent ordering chain over {len(items)} items. "
            f"{carrier_note}",
        ],
        object_count=len(items),
        stocked=["container"],
        closed=["container"],
    )


def stock_cabinet(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Load kitchen items into a cabinet, then close it."""
    cabinet = pick_furniture(scene, rng, ("Cabinet",))[0]
    items = pick_loose(scene, rng, agents, KITCHEN_STOCK)
    return _loading_draft(
        "kitchen_ordered_cabinet_loading", cabinet, items, agents, "Kitchen Cabinet carrier."
    )


def load_in_order(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Load personal objects into a box, then close it."""
    boxes = scene.loose("Box")
    if not boxes:
        raise Ungroundable("no Box in plain sight")
    box = rng.choice(boxes)
    items = pick_loose(scene, rng, agents, exclude=("Box",))
    return _loading_draft("ordered_container_loading", box, items, agents, "Box-type container.")


def fill_drawers_in_order(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Place personal objects into one drawer, then close it."""
    drawer = pick_furniture(scene, rng, ("Drawer",))[0]
    items = pick_loose(scene, rng, agents)
    return _loading_draft(
        f"{scene.room}_ordered_drawer_loading", drawer, items, agents, "Drawer carrier."
    )


DIM = PRECEDENCE  # what every task type here exercises
D2_TYPES = (
    TaskType("stock_cabinet", "Stock Cabinet", "A", DIM, ("kitchen",), "A_D2", stock_cabinet),
    TaskType("load_in_order", "Load in Order", "C", DIM, ("living_room", "bedroom"),
             "C_D2", load_in_order),
    TaskType("fill_drawers_in_order", "Fill Drawers in Order", "H", DIM,
             ("living_room", "bedroom", "bathroom"), "H_D2", fill_drawers_in_order),
)

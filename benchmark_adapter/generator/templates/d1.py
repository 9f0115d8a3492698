"""D1 task allocation: Store Groceries (A_D1), Sort & Store (G_D1), Tidy Drawers (H_D1).

Each agent gets an independent line of work of (nearly) equal length, so the oracle's
makespan is the balanced optimum; the builder writes it as `optimal_makespan`.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import (
    FOODS,
    GROCER_SKILLS,
    SORTER_SKILLS,
    TIDIER_SKILLS,
    Draft,
    TaskType,
    Ungroundable,
    accepts,
    numbered_names,
    on_goals,
    only,
    pick_furniture,
    pick_loose,
    role_names,
    series,
    team,
)
from benchmark_adapter.vocabulary import LOAD_BALANCING

# Open surfaces that make sense as a destination in each room.
SORT_TARGETS = {
    "living_room": ("Sofa", "ArmChair", "CoffeeTable", "SideTable", "Shelf", "TVStand",
                    "Dresser", "DiningTable", "Ottoman"),
    "bedroom": ("Bed", "Desk", "Dresser", "SideTable", "Shelf", "ArmChair", "Chair"),
    "bathroom": ("CounterTop", "Shelf", "Toilet", "TowelHolder", "ToiletPaperHanger",
                 "SideTable", "Dresser", "Bathtub"),
}


def _paired(
    items: Sequence[SceneObject], places: Sequence[SceneObject], place_alias: str
) -> dict[str, SceneObject]:
    """`item_k` and `<place_alias>_k` for each item and its place, pair by pair (config order)."""
    objects = {}
    for i, (item, place) in enumerate(zip(items, places), 1):
        objects[f"item_{i}"], objects[f"{place_alias}_{i}"] = item, place
    return objects


def store_groceries(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """agent_1 opens the fridge and stores a food, agent_2 switches the light off and stores
    one, every further agent stores one more."""
    foods = pick_loose(scene, rng, agents, FOODS)
    fridge, light = only(scene, "Fridge"), only(scene, "LightSwitch")
    objects = {f"food_{i}": f for i, f in enumerate(foods, 1)} | {"fridge": fridge, "light": light}
    names = series([f.type for f in foods])
    return Draft(
        task_name="store_groceries_and_lights_off",
        objects=objects,
        goals=[
            *on_goals((f"food_{i}", "fridge") for i in range(1, agents + 1)),
            {"predicate": "toggled", "object": "light", "value": False},
        ],
        constraints={
            "precedence": [["Open(fridge)", "Put(food, fridge)"]],
            "legal_plan": "The storage lines and the light line are independent; Open must "
            "precede Put within the storage lines.",
            "engine_note": "A loaded fridge cannot be closed (AI2-THOR 5.0), so the fridge is "
            "not required closed at the end.",
        },
        agents=team(role_names("Agent-Tidy", agents), [GROCER_SKILLS] * agents),
        instruction=f"Put the {names} in the Fridge, and turn off the LightSwitch.",
        notes=[
            "D1 has no cross-dependency: storing food and switching the light off run in "
            "parallel lines.",
            f"Oracle split: agent_1 opens the fridge and stores the {foods[0].type}; agent_2 "
            "switches the light off and stores one food; further agents store one food each.",
        ],
        object_count=agents,
        setup=[
            {
                "action": "ensure_toggle_state",
                "objectId": light.id,
                "isToggled": True,
                "note": "The light starts on; the goal is to turn it off.",
            }
        ],
    )


def sort_and_store(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Each agent moves one item onto its own destination surface."""
    items = pick_loose(scene, rng, agents)
    targets, used_types = [], set()
    for item in items:
        options = [
            t
            for t in scene.of_type(*SORT_TARGETS[scene.room])
            if t.furniture and t.type not in used_types and t.id != item.parent and accepts(t, item)
        ]
        if not options:
            raise Ungroundable(f"no free destination surface left for the {item.type}")
        target = rng.choice(options)
        targets.append(target)
        used_types.add(target.type)
    objects = _paired(items, targets, "target")
    pairs = [f"the {i.type} on the {t.type}" for i, t in zip(items, targets)]
    return Draft(
        task_name=f"{scene.room}_parallel_sorting",
        objects=objects,
        goals=on_goals((f"item_{i}", f"target_{i}") for i in range(1, agents + 1)),
        constraints={
            "independent_subtasks": [
                [f"PickUp(item_{i})", f"Put(item_{i}, target_{i})"] for i in range(1, agents + 1)
            ],
            "legal_plan": "The placement lines are independent and may run in any order or in "
            "parallel.",
        },
        agents=team(role_names("Sorter", agents), [SORTER_SKILLS] * agents),
        instruction=f"Put {series(pairs)}.",
        notes=[
            f"D1 independent parallelism: each of {agents} agents moves one item to a distinct "
            "receptacle surface.",
            "Only non-openable receptacles are used so the task stays about allocation.",
        ],
        object_count=agents,
        stocked=[f"target_{i}" for i in range(1, agents + 1)],
    )


def tidy_drawers(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Each agent opens its own drawer and stores its own item."""
    drawers = sorted(pick_furniture(scene, rng, ("Drawer",), agents), key=lambda d: d.id)
    items = pick_loose(scene, rng, agents)
    objects = _paired(items, drawers, "drawer")
    drawer_names = numbered_names(drawers)
    pairs = [f"the {i.type} in {d}" for i, d in zip(items, drawer_names)]
    aliases = [f"drawer_{i}" for i in range(1, agents + 1)]
    return Draft(
        task_name=f"{scene.room}_personal_drawer_storage",
        objects=objects,
        goals=on_goals((f"item_{i}", f"drawer_{i}") for i in range(1, agents + 1)),
        constraints={
            "independent_subtasks": [
                [f"Open(drawer_{i})", f"PickUp(item_{i})", f"Put(item_{i}, drawer_{i})"]
                for i in range(1, agents + 1)
            ],
            "legal_plan": "Each agent opens its own drawer and stores its own item; the lines "
            "are independent and may run in parallel.",
        },
        agents=team(role_names("Tidier", agents), [TIDIER_SKILLS] * agents),
        instruction=f"Put {series(pairs)}.",
        notes=[
            f"D1 independent parallelism: each of {agents} agents owns one drawer and stores "
            "one item; the lines share no object.",
            "Action counts are symmetric per agent, so the balanced schedule is the makespan "
            "optimum.",
        ],
        object_count=agents,
        stocked=aliases,
        closed=aliases,
    )


DIM = LOAD_BALANCING  # what every task type here exercises
D1_TYPES = (
    TaskType("store_groceries", "Store Groceries", "A", DIM, ("kitchen",),
             "store_groceries", store_groceries),
    TaskType("sort_and_store", "Sort & Store", "G", DIM,
             ("living_room", "bedroom", "bathroom"), "G_D1", sort_and_store),
    TaskType("tidy_drawers", "Tidy Drawers", "H", DIM,
             ("living_room", "bedroom", "bathroom"), "H_D1", tidy_drawers),
)

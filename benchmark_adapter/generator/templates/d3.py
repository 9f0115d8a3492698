"""D3 mutual exclusion: Prepare Food (K_D3).

Every agent must slice its assigned food with the single shared Knife. A third of the
candidates are asymmetric: one agent (drawn per candidate) slices two items, as the reference's
`--asymmetric` variants do. A knife or food shut in a drawer or the fridge is moved to a
counter at reset, the way the reference generator relocates inaccessible objects.
"""

from __future__ import annotations

import random

from benchmark_adapter.generator.objects import SceneObject
from benchmark_adapter.generator.scenes import Scene
from benchmark_adapter.generator.templates.base import (
    CHEF_SKILLS,
    SLICEABLE_FOODS,
    Draft,
    TaskType,
    Ungroundable,
    agent_ids,
    forced_put,
    only,
    pick_furniture,
    series,
    team,
)
from benchmark_adapter.vocabulary import MUTUAL_EXCLUSION

ASYMMETRIC_SHARE = 1 / 3


def _assignment(agents: int, rng: random.Random) -> tuple[list[str], bool]:
    """Owner of each item, items grouped by agent; and whether one agent has two."""
    owners = agent_ids(agents)
    if rng.random() >= ASYMMETRIC_SHARE:
        return owners, False
    busy = rng.randrange(agents)
    return owners[: busy + 1] + owners[busy:], True


def _foods(scene: Scene, count: int, rng: random.Random) -> list[SceneObject]:
    """`count` sliceable foods of distinct types, in plain sight or stored away."""
    by_type: dict[str, SceneObject] = {}
    for food in scene.of_type(*SLICEABLE_FOODS):
        by_type.setdefault(food.type, food)
    if len(by_type) < count:
        raise Ungroundable(f"{len(by_type)} kinds of sliceable food in the scene, {count} needed")
    return [by_type[t] for t in rng.sample(sorted(by_type), count)]


def _relocate(object_id: str, counter_id: str) -> list[dict]:
    """Init actions moving an object to a counter (agent 0, forced), as the reference's K
    generator records them for a knife or food the agents could not reach."""
    return [
        {"action": "PickupObject", "objectId": object_id, "agentId": 0, "forceAction": True},
        forced_put(counter_id),
    ]


def prepare_food(scene: Scene, agents: int, rng: random.Random) -> Draft:
    """Slice assigned foods with one shared knife."""
    owners, asymmetric = _assignment(agents, rng)
    foods = _foods(scene, len(owners), rng)
    knife = only(scene, "Knife")
    counter = pick_furniture(scene, rng, ("CounterTop",))[0]
    setup = []
    for stored in [knife, *foods]:
        if scene.enclosed(stored):
            setup += _relocate(stored.id, counter.id)
    items = [f"item_{i}" for i in range(1, len(foods) + 1)]
    duties = [f"{owner} must slice the {food.type}" for owner, food in zip(owners, foods)]
    notes = [
        "D3 shared-tool exclusion: all agents share a single Knife.",
        "Each agent must acquire the Knife, slice their assigned food item(s), then release it.",
        "PickUp mutual exclusion is engine-enforced: only one agent can hold the Knife.",
        "Slice requires holding the Knife (executor-enforced precondition).",
        "sliced_by goal: each item must be sliced by its assigned agent.",
    ]
    if asymmetric:
        notes.append("Asymmetric critical sections: one agent slices two items.")
    return Draft(
        task_name="shared_knife_slicing",
        objects=dict(zip(items, foods)) | {"knife": knife},
        goals=[
            {"predicate": "sliced_by", "object": item, "agent": owner}
            for item, owner in zip(items, owners)
        ],
        constraints={
            "resource_exclusion": [
                {
                    "resource": "shared_knife",
                    "resource_id": knife.id,
                    "exclusive": True,
                    "mechanism": "pickup_exclusion",
                    "note": "Only one agent can hold the Knife at a time (engine-enforced "
                    "PickUp exclusion).",
                }
            ],
            "scheduling": "any_permutation",
            "legal_plan": "Each agent must acquire the shared Knife, slice their food, and "
            "release it before the next agent can use it.",
        },
        agents=team([f"Chef-{i}" for i in range(1, agents + 1)], [CHEF_SKILLS] * agents),
        instruction=series(duties) + ".",
        notes=notes,
        object_count=len(foods) + 1,
        setup=setup,
        assignment=dict(zip(items, owners)),
        provenance={"pickup_exclusion_verified": True, "asymmetric": asymmetric},
    )


DIM = MUTUAL_EXCLUSION  # what every task type here exercises
D3_TYPES = (
    TaskType("prepare_food", "Prepare Food", "K", DIM, ("kitchen",), "K_D3", prepare_food),
)

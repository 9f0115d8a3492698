"""Each gate rejects what it should, and names itself."""

from __future__ import annotations

import copy
import random
from typing import Any

from benchmark_adapter.generator import TASK_TYPES, Scene, judge
from benchmark_adapter.generator.pipeline import make_candidate
from benchmark_adapter.generator.scenes import embedded_scene

Samples = dict[tuple[str, int], dict[str, Any]]
HANGER = "TowelHolder|+00.00|+01.05|+00.00"  # capacity 1


def _copy(samples: Samples, slug: str, agents: int) -> dict[str, Any]:
    return copy.deepcopy(samples[slug, agents])


def test_placement_rejects_a_full_receptacle(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "sort_and_store", 3)
    config["init_state"]["objects"]["target_1"] = HANGER
    for goal in config["goal_predicates"]:
        goal["receptacle"] = "target_1"
    verdict = judge(config)
    assert verdict.gate == "placement" and "room for 1 more object(s), 3 needed" in verdict.reason


def test_placement_rejects_an_object_nobody_can_see(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "tidy_drawers", 2)
    objects = config["init_state"]["objects"]
    item, drawer = objects["item_1"], objects["drawer_2"]
    config["init_state"]["init_actions"] += [
        {"action": "OpenObject", "objectId": drawer, "forceAction": True},
        {"action": "PickupObject", "objectId": item, "agentId": 0, "forceAction": True},
        {"action": "PutObject", "objectId": drawer, "agentId": 0, "forceAction": True},
        {"action": "CloseObject", "objectId": drawer, "forceAction": True},
    ]
    verdict = judge(config)
    assert verdict.gate == "placement" and "item_1" in verdict.reason
    assert "no interactable pose" in verdict.reason


def test_placement_rejects_missing_affordances_and_failed_set_up(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "sort_and_store", 2)
    config["init_state"]["objects"]["item_1"] = "Sofa|+00.00|+00.00|+00.00"
    assert "is not pickupable" in judge(config).reason
    config = _copy(sample_configs, "sort_and_store", 2)
    item = config["init_state"]["objects"]["item_1"]
    config["init_state"]["init_actions"].append(
        {"action": "OpenObject", "objectId": item, "forceAction": True}
    )
    verdict = judge(config)
    assert verdict.gate == "placement" and "init OpenObject failed" in verdict.reason


def test_placement_checks_the_shared_tool(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "prepare_food", 2)
    config["task_constraints"]["resource_exclusion"][0]["resource_id"] = (
        config["init_state"]["objects"]["item_1"]
    )
    assert "is not a knife" in judge(config).reason


def test_oracle_gate_rejects_an_unreachable_goal(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "sort_and_store", 2)
    first, second = config["goal_predicates"]
    first["receptacle"], second["receptacle"] = second["receptacle"], first["receptacle"]
    verdict = judge(config)
    assert verdict.gate == "oracle" and "goal not reached" in verdict.reason


def test_metric_gate_rejects_a_weak_construct_signal(sample_configs: Samples) -> None:
    config = _copy(sample_configs, "sort_and_store", 2)
    config["task_constraints"]["optimal_makespan"] = 2  # oracle's makespan is 4: C_D1 = 0.5
    verdict = judge(config)
    assert verdict.gate == "metric" and "0.50 < 0.95" in verdict.reason


def test_a_scene_without_the_needed_objects_is_a_placement_rejection() -> None:
    scene = embedded_scene("bedroom", 1, 0)
    bare = Scene(scene.scene_id, scene.room, 0, tuple(o for o in scene.objects if o.type != "Box"))
    candidate = make_candidate(TASK_TYPES["load_in_order"], bare, 2, 0)
    assert candidate.config is None and candidate.problem == "placement: no Box in plain sight"


def test_grounding_is_seeded_per_candidate() -> None:
    scene = embedded_scene("kitchen", 3, 1)
    first = make_candidate(TASK_TYPES["prepare_food"], scene, 3, 1)
    again = make_candidate(TASK_TYPES["prepare_food"], scene, 3, 1)
    assert first == again
    random.seed(0)  # global random state plays no part
    assert make_candidate(TASK_TYPES["prepare_food"], scene, 3, 1) == first

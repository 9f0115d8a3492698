"""Construct scores C_D1..C_D4 and their gating (reference §7.4).

Every expected score is hand-computed in the comments from the step list.
"""

from __future__ import annotations

import dataclasses
import json

import pytest

from benchmark_adapter.metrics import (
    ConstructScore,
    TrajectoryError,
    construct_evidence,
    construct_score,
    cross_construct_scores,
)
from tests.paths import SHARED_TASKS

from .builders import (
    APPLE,
    BOX,
    CARD,
    CLOSED,
    FRIDGE,
    HELD,
    K_SKILLS,
    KEYCHAIN,
    KNIFE,
    NO_ROOM,
    PLATE,
    POTATO,
    SOFA,
    TOMATO,
    make_config,
    make_traj,
    placed,
    step,
    stop,
)

# ---- gating ------------------------------------------------------------------------


def test_no_actions_is_na_no_actions_for_every_dim():
    traj = make_traj(make_config("D3", "K"), [stop("parse_error")])
    assert construct_score(traj) == ConstructScore("D3", None, "na_no_actions", 0, {})
    assert {d: s.status for d, s in cross_construct_scores(traj).items()} == {
        "D1": "na_no_actions",
        "D2": "na_no_actions",
        "D3": "na_no_actions",
        "D4": "na_no_actions",
    }


def k_config(**top_level) -> dict:
    return make_config(
        "D3",
        "K",
        skills=K_SKILLS,
        objects={"item_1": POTATO, "item_2": APPLE, "knife": KNIFE},
        constraints={"resource_exclusion": [{"resource": "shared_knife", "resource_id": KNIFE}]},
        **top_level,
    )


def test_not_engaged_when_the_mechanism_is_never_touched():
    traj = make_traj(k_config(), [step("agent_1", "Find", KNIFE), step("agent_1", "PickUp", APPLE)])
    assert construct_score(traj) == ConstructScore("D3", None, "not_engaged", 0, {})


def test_low_signal_below_two_events():
    traj = make_traj(k_config(), [step("agent_1", "Find", KNIFE), step("agent_1", "PickUp", KNIFE)])
    assert construct_score(traj) == ConstructScore("D3", None, "low_signal", 1, {})


def test_na_when_engaged_but_the_formula_has_no_signal():
    # One-agent D1: 2 steps pass the gate, but n < 2 makes the formula NA.
    traj = make_traj(make_config("D1", n_agents=1), [step("agent_1", "Find", BOX)] * 2)
    result = construct_score(traj)
    assert (result.score, result.status, result.sample) == (None, "na", 2)
    assert result.evidence["n_agents"] == 1


def test_unknown_dimension_is_na():
    traj = make_traj(make_config("D9"), [step("agent_1", "PickUp", BOX)] * 2)
    assert construct_score(traj) == ConstructScore("D9", None, "na", 2, {})


def test_construct_score_needs_the_dimension():
    config = make_config()
    del config["coordination_dim"]
    with pytest.raises(TrajectoryError) as info:
        construct_score(make_traj(config, [step("agent_1", "Find", BOX)]))
    assert info.value.field == "task_config.coordination_dim"


def test_construct_score_is_frozen():
    result = ConstructScore("D1", 1.0, "scored", 2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.score = 0.0


# ---- D1 ------------------------------------------------------------------------------


def test_d1_unbalanced_agents_with_declared_makespan():
    config = make_config("D1", "G", constraints={"optimal_makespan": 4})
    steps = [step("agent_1", "Find", KEYCHAIN)] * 6 + [step("agent_2", "Find", CARD)] * 2
    result = construct_score(make_traj(config, steps))
    # M = max(6, 2) = 6, M* = 4 -> 4/6
    assert (result.status, result.sample) == ("scored", 8)
    assert result.score == pytest.approx(2 / 3)
    assert result.evidence["reference_source"] == "task_constraints"


def test_d1_reference_makespan_falls_back_to_ceil_total_over_n():
    steps = [step("agent_1", "Find", KEYCHAIN)] * 5 + [step("agent_2", "Find", CARD)] * 2
    result = construct_score(make_traj(make_config("D1", "G"), steps))
    # total 7, n 2 -> M* = ceil(3.5) = 4; M = 5 -> 4/5
    assert result.score == pytest.approx(0.8)
    assert result.evidence == {
        "n_agents": 2,
        "total_steps": 7,
        "makespan": 5,
        "reference_makespan": 4,
        "reference_source": "ceil_total_over_n",
    }


def test_d1_counts_idle_agents_in_n():
    steps = [step("agent_1", "Find", KEYCHAIN)] * 3
    result = construct_score(make_traj(make_config("D1", "H", n_agents=3), steps))
    # n = 3 from the config -> M* = ceil(3/3) = 1; M = 3 -> 1/3
    assert result.score == pytest.approx(1 / 3)


# ---- D2 ------------------------------------------------------------------------------


def d2_config(objects=None) -> dict:
    objects = objects or {"item_1": KEYCHAIN, "item_2": CARD, "container": BOX}
    return make_config(
        "D2",
        "C",
        objects=objects,
        constraints={
            "precedence": [
                ["Open(container)", "Put(item, container)"],
                ["Put(item, container)", "Close(container)"],
            ]
        },
    )


def premature_close_steps() -> list:
    return [
        step("agent_1", "Find", BOX),  # not a chain op
        step("agent_1", "Open", BOX),  # c1
        step("agent_1", "PickUp", KEYCHAIN),
        step("agent_1", "Put", KEYCHAIN, to=BOX),  # c2
        step("agent_2", "Close", BOX),  # c3 (premature)
        step("agent_2", "PickUp", CARD),
        step("agent_2", "Put", CARD, to=BOX, ok=False, error=CLOSED),  # v1
        step("agent_2", "Open", BOX),  # c4
        step("agent_2", "Put", CARD, to=BOX),  # c5
        step("agent_1", "Close", BOX),  # c6
        step("agent_1", "Close", BOX, ok=False, error="Box is already closed"),  # no-op: ignored
        step(
            "agent_2", "Put", CARD, to=BOX, ok=False, error="Agent is not holding any object"
        ),  # intrinsic: ignored
        step("agent_1", "Put", KEYCHAIN, to=SOFA, ok=False, error="x"),  # not the container
    ]


def test_d2_premature_close_then_refused_put_is_a_violation_and_halves():
    result = construct_score(make_traj(d2_config(), premature_close_steps()))
    # v = 1, c = 6 -> 1 - 1/7 = 6/7; the refused Puts are precondition violations,
    # so the plan is illegal -> x 0.5 = 3/7.
    assert result.status == "scored"
    assert result.sample == 8  # successful interactions: Open, PickUp, Put, Close, PickUp,
    #                            Open, Put, Close
    assert result.score == pytest.approx(3 / 7)
    assert result.evidence == {
        "container_ids": [BOX],
        "correct": 6,
        "violations": 1,
        "legal_plan": False,
        "legality_factor": 0.5,
    }


def test_d2_legal_plan_is_not_halved():
    steps = [
        step("agent_1", "Open", BOX),  # c1
        step("agent_1", "PickUp", KEYCHAIN),
        step("agent_1", "Put", KEYCHAIN, to=BOX, ok=False, error=NO_ROOM),  # v1 (affordance)
        step("agent_1", "Put", KEYCHAIN, to=BOX),  # c2
        step("agent_2", "PickUp", CARD),
        step("agent_2", "Put", CARD, to=BOX),  # c3
        step("agent_2", "Close", BOX),  # c4
    ]
    result = construct_score(make_traj(d2_config(), steps))
    # The affordance miss is no precondition violation, so the plan stays legal:
    # 1 - 1/(4 + 1) = 0.8, factor 1.
    assert (result.score, result.sample) == (pytest.approx(0.8), 6)
    assert result.evidence["legality_factor"] == 1.0


def test_d2_without_container_aliases_counts_every_chain_op():
    config = d2_config({"item_1": KEYCHAIN, "target": SOFA, "fridge": FRIDGE})
    steps = [
        step("agent_1", "Open", FRIDGE),  # c1
        step("agent_1", "Put", KEYCHAIN, to=SOFA),  # c2
        step("agent_1", "Close", FRIDGE, ok=False, error="Fridge is stuck"),
    ]  # v1
    result = construct_score(make_traj(config, steps))
    # 1 - 1/3 = 2/3; the failed Close is a precondition violation -> x 0.5 = 1/3
    assert result.score == pytest.approx(1 / 3)
    assert result.evidence["container_ids"] == []


def test_d2_needs_precedence_and_chain_ops():
    no_precedence = make_config("D2", "C", objects={"container": BOX})
    steps = [step("agent_1", "Open", BOX)] * 2
    assert construct_score(make_traj(no_precedence, steps)).status == "na"
    only_pickups = [step("agent_1", "PickUp", KEYCHAIN)] * 2
    result = construct_score(make_traj(d2_config(), only_pickups))
    assert (result.status, result.sample) == ("na", 2)


# ---- D3 ------------------------------------------------------------------------------


def knife_steps() -> list:
    return [
        step("agent_1", "Find", KNIFE),
        step("agent_1", "PickUp", KNIFE),  # a1
        step("agent_2", "PickUp", KNIFE, ok=False, error=HELD),  # a2, c1
        step("agent_1", "Find", POTATO),
        step("agent_1", "Slice", POTATO),
        step("agent_2", "PickUp", KNIFE, ok=False, error=HELD.upper()),  # a3, c2
        step("agent_1", "Drop"),
        step("agent_2", "Find", KNIFE),
        step("agent_2", "PickUp", KNIFE),  # a4
        step("agent_2", "Slice", APPLE),
    ]


def test_d3_refused_knife_pickups_with_top_level_makespan():
    result = construct_score(make_traj(k_config(optimal_makespan=5), knife_steps()))
    # contention = 1 - 2/4 = 0.5; efficiency = min(1, 5/10 steps) = 0.5 -> 0.25
    assert (result.status, result.sample) == ("scored", 4)
    assert result.score == pytest.approx(0.25)
    assert result.evidence == {
        "mode": "shared_tool",
        "resource_ids": [KNIFE],
        "accesses": 4,
        "collisions": 2,
        "contention": 0.5,
        "reference_makespan": 5,
        "landed_steps": 10,
        "efficiency": 0.5,
    }


def test_d3_efficiency_is_clipped_and_defaults_to_one():
    # M* = 27 > L = 10 -> efficiency 1; contention 0.5 -> 0.5
    assert construct_score(make_traj(k_config(optimal_makespan=27), knife_steps())).score == 0.5
    # no top-level optimal_makespan (task_constraints' one is not read) -> efficiency 1
    config = k_config()
    config["task_constraints"]["optimal_makespan"] = 1
    assert construct_score(make_traj(config, knife_steps())).score == 0.5


def test_d3_other_knife_failures_are_accesses_but_not_collisions():
    steps = [
        step("agent_1", "PickUp", KNIFE),
        step("agent_1", "PickUp", KNIFE, ok=False, error="hand has something in it already"),
    ]
    # a = 2, c = 0 -> 1.0
    assert construct_score(make_traj(k_config(), steps)).score == 1.0


def test_d3_station_mode():
    config = make_config("D3", "F", constraints={"exclusive_resources": ["Sink"]})
    steps = [
        step("agent_1", "CleanObject", APPLE),  # a1
        step("agent_2", "CleanObject", TOMATO, ok=False, error="Sink busy"),  # a2 denied
        step("agent_1", "CleanObject", APPLE, ok=False, error="already clean"),  # a3 no-op
        step("agent_2", "FillObjectWithLiquid", POTATO),  # a4
        step("agent_2", "PickUp", POTATO),
    ]  # not a use
    result = construct_score(make_traj(config, steps))
    # 1 - 1/4 = 0.75; no top-level makespan -> efficiency 1
    assert (result.score, result.sample) == (0.75, 4)
    assert result.evidence["lock_skills"] == [
        "CleanObject",
        "EmptyLiquidFromObject",
        "FillObjectWithLiquid",
    ]
    config["task_constraints"] = {
        "resource_exclusion": [{"skills_requiring_lock": ["CleanObject"]}]
    }
    # only the 3 CleanObject steps count: 1 - 1/3 = 2/3
    assert construct_score(make_traj(config, steps)).score == pytest.approx(2 / 3)


def test_d3_competitive_mode_counts_duplicate_pickup_targets():
    steps = [
        step("agent_1", "PickUp", APPLE),
        step("agent_2", "PickUp", APPLE, ok=False, error=f"{APPLE} is already held"),
        step("agent_1", "PickUp", TOMATO),
        step("agent_2", "PickUp", POTATO),
    ]
    result = construct_score(make_traj(make_config("D3", "E"), steps))
    # targets [Apple, Apple, Tomato, Potato]: 4 accesses, 1 duplicate -> 0.75
    assert (result.score, result.sample, result.evidence["mode"]) == (0.75, 4, "competitive")


# ---- D4 ------------------------------------------------------------------------------

RELAY = {"item_1": APPLE, "item_2": TOMATO, "item_3": POTATO, "transfer": PLATE, "target": FRIDGE}


def d4_config(buffers=True) -> dict:
    constraints = {
        "precedence": [["Source.Put", "Target.PickUp"]],
        "producer_consumer": {
            "producer": "agent_1",
            "consumer": "agent_2",
            "buffer": PLATE,
            "targets": [FRIDGE],
        },
    }
    if buffers:
        constraints["buffer_stations"] = [{"objectId": PLATE, "capacity": 1}]
    return make_config(
        "D4",
        "C",
        skills=["Find", "Explore", "PickUp", "Put", "Wait"],
        objects=RELAY,
        constraints=constraints,
    )


def on_plate(*aliases):
    return placed(RELAY, list(aliases))


def test_d4_overflow_and_starved_wait():
    steps = [
        step("agent_1", "PickUp", APPLE, objects=on_plate()),  # occ 0
        step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1")),  # occ 1, h1
        step("agent_2", "Wait", objects=on_plate("item_1")),  # not starved
        step("agent_1", "PickUp", TOMATO, objects=on_plate("item_1")),  # occ 1
        step(
            "agent_1", "Put", TOMATO, to=PLATE, objects=on_plate("item_1", "item_2")
        ),  # occ 2: o1, h2
        step("agent_2", "PickUp", APPLE, objects=on_plate("item_2")),  # occ 1
        step("agent_2", "Put", APPLE, to=FRIDGE, objects=on_plate("item_2")),  # occ 1
        step("agent_2", "PickUp", TOMATO, objects=on_plate()),  # occ 0
        step("agent_2", "Put", TOMATO, to=FRIDGE, objects=on_plate()),  # occ 0
        step("agent_2", "Wait", objects=on_plate()),  # starved: w1
        step("agent_1", "PickUp", POTATO, objects=on_plate()),  # occ 0
        step("agent_1", "Put", POTATO, to=PLATE, objects=on_plate("item_3")),  # occ 1, h3
        step("agent_2", "PickUp", POTATO, objects=on_plate()),
        step("agent_2", "Put", POTATO, to=FRIDGE, objects=on_plate()),
    ]
    result = construct_score(make_traj(d4_config(), steps))
    # h = 3, o = 1, w = 1 -> 1 - 2/3 = 1/3
    assert (result.status, result.sample) == ("scored", 3)
    assert result.score == pytest.approx(1 / 3)
    assert result.evidence == {
        "mode": "buffer",
        "buffer_ids": [PLATE],
        "capacity": 1,
        "handoffs": 3,
        "overflows": 1,
        "occupancy_overflows": 1,
        "refused_put_overflows": 0,
        "starved_waits": 1,
    }


def test_d4_refused_put_and_overflow_counted_once_per_rise():
    steps = [
        step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1")),  # occ 1, h1
        step(
            "agent_1", "Put", TOMATO, to=PLATE, ok=False, error=NO_ROOM, objects=on_plate("item_1")
        ),  # refused: o1
        step(
            "agent_1", "Put", TOMATO, to=PLATE, objects=on_plate("item_1", "item_2")
        ),  # occ 2: o2, h2
        step("agent_2", "Find", PLATE, objects=on_plate("item_1", "item_2")),  # still 2: no
        step(
            "agent_1", "Put", POTATO, to=PLATE, objects=on_plate("item_1", "item_2", "item_3")
        ),  # occ 3: o3, h3
        step("agent_2", "PickUp", APPLE, objects=on_plate("item_2", "item_3")),  # falls
        step(
            "agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1", "item_2", "item_3")
        ),  # occ 3: o4, h4
    ]
    result = construct_score(make_traj(d4_config(), steps))
    # h = 4, o = 3 rises + 1 refused = 4 -> 1 - 4/4 = 0
    assert result.score == 0.0
    assert (result.evidence["occupancy_overflows"], result.evidence["refused_put_overflows"]) == (
        3,
        1,
    )


def test_d4_without_buffer_stations_falls_back():
    steps = [
        step("agent_1", "PickUp", APPLE),  # t1
        step("agent_1", "Put", APPLE, to=PLATE, ok=False, error=NO_ROOM),  # t2, miss
        step("agent_2", "Wait"),  # wait
        step("agent_1", "Put", APPLE, to=PLATE),  # t3
        step("agent_2", "PickUp", APPLE),
    ]  # t4
    result = construct_score(make_traj(d4_config(buffers=False), steps))
    # 1 - (1 miss + 1 wait) / 4 transfers = 0.5
    assert (result.score, result.sample, result.evidence["mode"]) == (0.5, 4, "no_buffer")


def test_d4_gating_on_handoffs():
    no_handoff = [step("agent_1", "PickUp", APPLE, objects=on_plate())] * 2
    assert construct_score(make_traj(d4_config(), no_handoff)).status == "not_engaged"
    one = [step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1"))]
    assert construct_score(make_traj(d4_config(), one)).status == "low_signal"


def test_d4_needs_recorded_object_state():
    steps = [
        step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1")),
        step("agent_1", "Put", TOMATO, to=PLATE),
    ]
    traj = make_traj(d4_config(), steps)
    del traj["trajectory"][2]["state"]
    with pytest.raises(TrajectoryError) as info:
        construct_score(traj)
    assert info.value.field == "trajectory[2].state.objects"


def test_d4_capacity_must_be_a_number():
    config = d4_config()
    config["task_constraints"]["buffer_stations"][0]["capacity"] = "two"
    steps = [step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1"))] * 2
    with pytest.raises(TrajectoryError, match="capacity"):
        construct_score(make_traj(config, steps))


# ---- cross-construct -------------------------------------------------------------------


def test_cross_construct_applies_all_four_with_their_own_gating():
    traj = make_traj(k_config(optimal_makespan=5), knife_steps())
    scores = cross_construct_scores(traj)
    assert list(scores) == ["D1", "D2", "D3", "D4"]
    # D1: agent_1 5 steps, agent_2 5 steps; no declared M* -> ceil(10/2) = 5; 5/5 = 1
    assert (scores["D1"].score, scores["D1"].sample) == (1.0, 10)
    # D2: no precedence -> NA; sample = 5 successful interactions (PickUp, Slice, Drop,
    # PickUp, Slice)
    assert (scores["D2"].status, scores["D2"].sample) == ("na", 5)
    assert scores["D3"] == construct_score(traj)
    # D4: no buffers -> 4 PickUps are transfers, no misses, no waits -> 1.0
    assert (scores["D4"].score, scores["D4"].sample) == (1.0, 4)


# ---- evidence over time (what the viewer draws) --------------------------------------------


def test_evidence_after_each_step_ends_with_the_scored_evidence():
    traj = make_traj(k_config(optimal_makespan=5), knife_steps())
    evidence = construct_evidence(traj)
    assert (evidence.dim, evidence.exclusion_mode) == ("D3", "shared_tool")
    assert evidence.exclusion_keys == {KNIFE}
    assert len(evidence.history) == 10 and evidence.history[0] == {}  # a Find: no access yet
    # the collisions as the knife pickups land: a1, a2 (c1), a3 (c2), a4
    assert [h.get("collisions") for h in evidence.history] == [None, 0, 1, 1, 1, 2, 2, 2, 2, 2]
    assert evidence.history[-1] == construct_score(traj).evidence


def test_evidence_of_d2_names_its_containers():
    evidence = construct_evidence(make_traj(d2_config(), premature_close_steps()))
    assert evidence.containers == (BOX,) and evidence.buffer_occupancy == ()


def test_evidence_of_d4_tracks_the_buffer_after_each_step():
    steps = [
        step("agent_1", "Put", APPLE, to=PLATE, objects=on_plate("item_1")),
        step("agent_1", "Put", TOMATO, to=PLATE, objects=on_plate("item_1", "item_2")),
        step("agent_2", "PickUp", APPLE, objects=on_plate("item_2")),
        step("agent_2", "Wait", objects=on_plate("item_2")),
    ]
    evidence = construct_evidence(make_traj(d4_config(), steps))
    assert (evidence.buffer_ids, evidence.buffer_capacity) == ((PLATE,), 1)
    assert evidence.buffer_occupancy == (1, 2, 1, 1)
    assert [h["occupancy_overflows"] for h in evidence.history] == [0, 1, 1, 1]
    no_buffer = construct_evidence(make_traj(d4_config(buffers=False), steps))
    assert (no_buffer.buffer_capacity, no_buffer.buffer_occupancy) == (None, ())


def test_evidence_needs_one_of_the_four_dimensions():
    with pytest.raises(TrajectoryError, match="'D9' is not one of D1, D2, D3, D4"):
        construct_evidence(make_traj(make_config("D9"), [step("agent_1", "PickUp", BOX)]))


# ---- oracle-shaped trajectories on real released configs ---------------------------------

DATA = SHARED_TASKS


def real_config(name: str) -> dict:
    path = DATA / f"{name}.json"
    if not path.exists():
        pytest.skip(f"real CoCoBench task configs not found at {DATA}")
    return json.loads(path.read_text())


def vacate(agent: str, moves: int) -> list:
    return [step(agent, "Explore") for _ in range(moves)]


def test_real_g_d1_oracle_is_balanced():
    config = real_config("G_D1__FloorPlan201__seed1")
    obj = config["init_state"]["objects"]
    steps = []
    for i in (1, 2):  # plan_g_d1: agent_i Find item_i, PickUp, Find target_i, Put
        a, item, target = f"agent_{i}", obj[f"item_{i}"], obj[f"target_{i}"]
        steps += [
            step(a, "Find", item),
            step(a, "PickUp", item),
            step(a, "Find", target),
            step(a, "Put", item, to=target),
        ]
    result = construct_score(make_traj(config, steps))
    # M = 4 per agent, declared M* = 4 -> 1.0
    assert (result.score, result.status, result.sample) == (1.0, "scored", 8)


def test_real_k_d3_oracle_has_no_contention_and_optimal_length():
    config = real_config("K_D3__FloorPlan13__seed0")
    obj, steps = config["init_state"]["objects"], []
    for item, agent in sorted(config["assignment"].items()):
        steps += [
            step(agent, "Find", obj["knife"]),
            step(agent, "PickUp", obj["knife"]),
            step(agent, "Find", obj[item]),
            step(agent, "Slice", obj[item]),
            step(agent, "Drop"),
            *vacate(agent, 4),
        ]
    result = construct_score(make_traj(config, steps))
    # a = 2 knife PickUps, c = 0; L = 2 x 9 = 18 = top-level M* (2 x (7 + 2 x 1)) -> 1.0
    assert config["optimal_makespan"] == 18
    assert (result.score, result.sample) == (1.0, 2)


def test_real_c_d2_oracle_is_in_order():
    config = real_config("C_D2__FloorPlan201__livingroom_seed2")
    obj = config["init_state"]["objects"]
    box, i1, i2 = obj["container"], obj["item_1"], obj["item_2"]
    steps = [step("agent_1", "Find", box), step("agent_1", "Open", box)]
    for agent, item in (("agent_1", i1), ("agent_2", i2)):
        steps += [
            step(agent, "Find", item),
            step(agent, "PickUp", item),
            step(agent, "Find", box),
            step(agent, "Put", item, to=box),
            *vacate(agent, 2),
        ]
    steps += [step("agent_2", "Find", box), step("agent_2", "Close", box)]
    result = construct_score(make_traj(config, steps))
    # chain ops Open, Put, Put, Close all succeed: v = 0, c = 4 -> 1.0, legal
    # sample: Open, PickUp, Put, PickUp, Put, Close = 6
    assert (result.score, result.sample) == (1.0, 6)


def test_real_c_d4_kitchen_oracle_never_overflows():
    config = real_config("C_D4__FloorPlan1__seed0")
    obj = config["init_state"]["objects"]
    plate, fridge = obj["transfer_plate"], obj["fridge"]

    def state(on_plate: list) -> dict:
        return placed(obj, on_plate, buffer=plate)

    steps = [
        step("agent_2", "Find", fridge, objects=state([])),
        step("agent_2", "Open", fridge, objects=state([])),
    ]
    for food in ("food_1", "food_2", "food_3"):
        steps += [
            step("agent_1", "Find", obj[food], objects=state([])),
            step("agent_1", "PickUp", obj[food], objects=state([])),
            step("agent_1", "Find", plate, objects=state([])),
            step("agent_1", "Put", obj[food], to=plate, objects=state([food])),
            step("agent_2", "PickUp", obj[food], objects=state([])),
            step("agent_2", "Put", obj[food], to=fridge, objects=state([])),
        ]
    result = construct_score(make_traj(config, steps))
    # h = 3 buffer Puts, occupancy never above capacity 1, no Waits -> 1.0
    assert (result.score, result.sample) == (1.0, 3)
    assert result.evidence["buffer_ids"] == [plate]

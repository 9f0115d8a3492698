"""Step extraction, step classification (reference §7.2) and field validation."""

from __future__ import annotations

import pytest

from benchmark_adapter.metrics import (
    STEP_CATEGORIES,
    TrajectoryError,
    allowed_skills_by_agent,
    classify_step,
    classify_steps,
    extract_steps,
    step_taxonomy,
)

from .builders import (
    BOX,
    CLOSED,
    FRIDGE,
    HELD,
    KEYCHAIN,
    KNIFE,
    NO_ROOM,
    make_config,
    make_traj,
    step,
    stop,
)

ALLOWED = {"agent_1": frozenset({"Find", "Explore", "Wait", "PickUp", "Put", "Open"})}

# One step per category, each reaching its branch of the classifier.
CATEGORY_CASES = [
    ("illegal_skill", step("agent_1", "Slice", KEYCHAIN)),
    ("idle_wait", step("agent_1", "Wait")),
    ("idle_wait", step("agent_1", "Wait", ok=False, error="Pass failed")),
    ("progress", step("agent_1", "PickUp", KEYCHAIN)),
    ("redundant_noop", step("agent_1", "Open", BOX, ok=False, error="Box is ALREADY OPEN")),
    (
        "occupancy_conflict",
        step(
            "agent_1",
            "Find",
            BOX,
            ok=False,
            error="Could not navigate to a visible, unoccupied pose for Box",
        ),
    ),
    ("affordance_miss", step("agent_1", "Put", KEYCHAIN, to=BOX, ok=False, error=NO_ROOM)),
    ("concurrency_conflict", step("agent_1", "PickUp", KNIFE, ok=False, error=HELD)),
    (
        "concurrency_conflict",
        step("agent_1", "PickUp", KNIFE, ok=False, error="Knife was Already Picked Up By agent_2"),
    ),
    (
        "precondition_violation",
        step("agent_1", "Put", KEYCHAIN, to=BOX, ok=False, error=CLOSED),
    ),
    ("action_failure", step("agent_1", "Explore", ok=False, error="MoveAhead blocked")),
    ("action_failure", step("agent_1", "Find", BOX, ok=False, error="Object not found")),
]


@pytest.mark.parametrize(("expected", "item"), CATEGORY_CASES)
def test_each_category(expected, item):
    assert classify_step(item, ALLOWED) == expected


@pytest.mark.parametrize(
    ("expected", "item"),
    [
        # illegal beats every other test, even a no-op marker on a failed step
        ("illegal_skill", step("agent_1", "Drop", ok=False, error="x is already open")),
        # no-op beats occupancy; occupancy beats affordance; affordance beats concurrency
        (
            "redundant_noop",
            step(
                "agent_1",
                "Find",
                BOX,
                ok=False,
                error="already satisfied; could not navigate to a visible pose",
            ),
        ),
        (
            "occupancy_conflict",
            step(
                "agent_1",
                "Put",
                KEYCHAIN,
                to=BOX,
                ok=False,
                error="unoccupied pose missing; no valid positions",
            ),
        ),
        (
            "affordance_miss",
            step(
                "agent_1",
                "PickUp",
                KNIFE,
                ok=False,
                error="no valid positions; is already held by another agent",
            ),
        ),
    ],
)
def test_first_matching_category_wins(expected, item):
    assert classify_step(item, ALLOWED) == expected


def test_illegal_beats_wait():
    no_wait = {"agent_1": frozenset({"Find"})}
    assert classify_step(step("agent_1", "Wait"), no_wait) == "illegal_skill"


def test_agent_missing_from_allowed_map_is_never_illegal():
    assert classify_step(step("agent_9", "Slice", KEYCHAIN), ALLOWED) == "progress"


def test_explicit_empty_set_makes_every_skill_illegal():
    assert classify_step(step("agent_1", "Find", BOX), {"agent_1": frozenset()}) == "illegal_skill"


def test_classify_accepts_a_bare_skill_result():
    result = step("agent_1", "Put", KEYCHAIN, to=BOX, ok=False, error="is closed")["skill_result"]
    assert classify_step(result, ALLOWED) == "precondition_violation"


def test_allowed_skills_fall_back_to_task_level_then_unrestricted():
    config = make_config(skills=["Find"], n_agents=3)
    config["agents"][0]["allowed_skills"] = ["PickUp", "Put"]
    del config["agents"][1]["allowed_skills"]  # -> task-level ["Find"]
    config["agents"][2]["allowed_skills"] = []  # -> task-level ["Find"]
    assert allowed_skills_by_agent(config) == {
        "agent_1": frozenset({"PickUp", "Put"}),
        "agent_2": frozenset({"Find"}),
        "agent_3": frozenset({"Find"}),
    }
    del config["allowed_skills"]
    config["agents"][2]["allowed_skills"] = []
    assert "agent_3" not in allowed_skills_by_agent(config)


def test_extract_steps_skips_init_and_stop_items():
    config = make_config()
    traj = make_traj(
        config,
        [
            step("agent_1", "Put", KEYCHAIN, to=BOX, round_index=1, message="hi"),
            step("agent_2", "Open", FRIDGE),
            stop("done"),
        ],
    )
    steps = extract_steps(traj)
    assert [(s.index, s.skill, s.agent) for s in steps] == [
        (1, "Put", "agent_1"),
        (2, "Open", "agent_2"),
    ]
    assert steps[0].target_id == BOX  # receptacle for Put
    assert steps[1].target_id == FRIDGE
    assert (steps[0].round_index, steps[0].message) == (1, "hi")
    assert steps[1].round_index is None


def test_step_taxonomy_all_categories_in_reference_order():
    config = make_config(skills=sorted(ALLOWED["agent_1"]))
    traj = make_traj(config, [item for _, item in CATEGORY_CASES])
    taxonomy = step_taxonomy(traj)
    assert list(taxonomy) == list(STEP_CATEGORIES)
    # 12 cases: idle_wait, concurrency_conflict and action_failure appear twice each.
    assert taxonomy == {
        "illegal_skill": 1,
        "idle_wait": 2,
        "progress": 1,
        "redundant_noop": 1,
        "occupancy_conflict": 1,
        "affordance_miss": 1,
        "concurrency_conflict": 2,
        "precondition_violation": 1,
        "action_failure": 2,
    }
    assert classify_steps(traj)[0] == "illegal_skill"


def test_step_taxonomy_keeps_zero_counts():
    traj = make_traj(make_config(), [step("agent_1", "Find", BOX)])
    assert step_taxonomy(traj) == {
        name: (1 if name == "progress" else 0) for name in STEP_CATEGORIES
    }


def _broken(mutate):
    traj = make_traj(make_config(), [step("agent_1", "Find", BOX), step("agent_2", "Wait")])
    mutate(traj)
    return traj


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda t: t.pop("trajectory"), "trajectory"),
        (lambda t: t.__setitem__("trajectory", {"0": {}}), "trajectory"),
        (lambda t: t.pop("task_config"), "task_config"),
        (lambda t: t["trajectory"].__setitem__(1, "oops"), "trajectory[1]"),
        (
            lambda t: t["trajectory"][2]["skill_result"].pop("skill"),
            "trajectory[2].skill_result.skill",
        ),
        (
            lambda t: t["trajectory"][1]["skill_result"].pop("agent"),
            "trajectory[1].skill_result.agent",
        ),
        (
            lambda t: t["trajectory"][1]["skill_result"].pop("success"),
            "trajectory[1].skill_result.success",
        ),
        (
            lambda t: t["trajectory"][1].__setitem__("skill_result", ["Find"]),
            "trajectory[1].skill_result",
        ),
    ],
)
def test_missing_fields_raise_naming_the_field(mutate, field):
    with pytest.raises(TrajectoryError) as info:
        step_taxonomy(_broken(mutate))
    assert info.value.field == field
    assert isinstance(info.value, ValueError)


def test_optional_fields_may_be_missing():
    traj = _broken(lambda t: [t["trajectory"][1].pop(k) for k in ("state", "eval", "image")])
    del traj["trajectory"][1]["skill_result"]["errorMessage"]
    del traj["trajectory"][1]["skill_result"]["args"]
    assert step_taxonomy(traj)["progress"] == 1
    assert extract_steps(traj)[0].objects is None


@pytest.mark.parametrize("fn", [extract_steps, step_taxonomy])
def test_non_object_trajectory_raises(fn):
    with pytest.raises(TrajectoryError) as info:
        fn(["not", "a", "dict"])
    assert info.value.field == "<root>"


def test_agent_entries_without_id_are_ignored():
    config = make_config()
    config["agents"].append({"role": "ghost", "allowed_skills": ["Find"]})
    config["agents"].append("agent_3")
    assert sorted(allowed_skills_by_agent(config)) == ["agent_1", "agent_2"]

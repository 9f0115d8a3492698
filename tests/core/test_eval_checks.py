"""Goal checks keep the reference's form (reference §7.1): the predicate as the config states
it, the resolved objectId, passed, and the reference's `detail` wording, character for
character, so tooling written for the reference's trajectory.json reads ours."""

from __future__ import annotations

import pytest

from benchmark_adapter import goals
from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.sim.embedded.world import make_object
from benchmark_adapter.tasks import load_tasks

from .worlds import DRAWER_A, GHOST, LIGHT, MUG, PLATE, TOMATO, Sim, make_config, touch


def _check(sim: Sim, goal: dict, steps: list | None = None) -> dict:
    config = make_config(goals=[goal])
    [check] = goals.evaluate(config, sim.md(0)["objects"], steps or [])["checks"]
    assert check["predicate"] == goal  # as stated: aliases unresolved, arguments kept
    return check


def _set(sim: Sim, object_id: str, **state) -> None:
    for key, value in state.items():
        setattr(sim.world.objects[object_id], key, value)
    touch(sim.world)


def _put_on(sim: Sim, object_id: str, receptacle: str) -> None:
    sim.world.objects[object_id].parent = receptacle
    sim.world.objects[receptacle].contents.append(object_id)
    touch(sim.world)


def test_on_names_the_parents_and_the_expected_receptacle(kitchen: Sim) -> None:
    goal = {"predicate": "on", "object": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal) == {
        "predicate": goal, "objectId": TOMATO, "passed": False,
        "detail": f"parentReceptacles=[] expected={PLATE}",
    }
    _put_on(kitchen, TOMATO, PLATE)
    assert _check(kitchen, goal)["detail"] == f"parentReceptacles=['{PLATE}'] expected={PLATE}"


@pytest.mark.parametrize(("goal", "object_id", "state", "detail"), [
    ({"predicate": "closed", "object": "drawer"}, DRAWER_A, {"is_open": True}, "isOpen=True"),
    ({"predicate": "open", "object": "drawer"}, DRAWER_A, {"is_open": True}, "isOpen=True"),
    ({"predicate": "toggled", "object": "light", "value": False}, LIGHT,
     {"is_toggled": False}, "isToggled=False"),
    ({"predicate": "sliced", "object": "tomato"}, TOMATO, {"is_sliced": True}, "isSliced=True"),
    ({"predicate": "cooked", "object": "tomato"}, TOMATO, {}, "isCooked=False"),
    ({"predicate": "clean", "object": "mug"}, MUG, {"is_dirty": True}, "isDirty=True"),
    ({"predicate": "empty", "object": "mug"}, MUG, {"is_filled": True},
     "isFilledWithLiquid=True"),
    ({"predicate": "filled", "object": "mug", "liquid": "coffee"}, MUG,
     {"is_filled": True, "fill_liquid": "water"}, "isFilledWithLiquid=True fillLiquid=water"),
])
def test_state_predicates_print_the_field_they_read(kitchen: Sim, goal: dict, object_id: str,
                                                    state: dict, detail: str) -> None:
    _set(kitchen, object_id, **state)
    check = _check(kitchen, goal)
    assert (check["objectId"], check["detail"]) == (object_id, detail)


def test_sliced_by_names_the_required_agent_and_whether_a_step_matched(kitchen: Sim) -> None:
    goal = {"predicate": "sliced_by", "object": "tomato", "agent": "agent_2"}
    _set(kitchen, TOMATO, is_sliced=True)
    step = {"skill": "Slice", "agent": "agent_2", "args": {"objectId": TOMATO}, "success": True}
    assert _check(kitchen, goal)["detail"] == "isSliced=True required_agent=agent_2 matched=False"
    check = _check(kitchen, goal, [step])
    assert (check["passed"], check["detail"]) == (
        True, "isSliced=True required_agent=agent_2 matched=True")


def test_on_sliced_piece_counts_pieces_and_pieces_on_the_receptacle(kitchen: Sim) -> None:
    goal = {"predicate": "on_sliced_piece", "source": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal) == {
        "predicate": goal, "objectId": TOMATO, "passed": False,
        "detail": f"sliced_pieces=0 on_{PLATE}=0",
    }
    pieces = [make_object(f"{TOMATO}|TomatoSliced_{i}") for i in (1, 2)]
    for piece in pieces:
        kitchen.world.objects[piece.id] = piece
    _put_on(kitchen, pieces[1].id, PLATE)
    check = _check(kitchen, goal)
    assert (check["passed"], check["detail"]) == (True, f"sliced_pieces=2 on_{PLATE}=1")


def test_on_sliced_piece_does_not_need_the_source_any_more(kitchen: Sim) -> None:
    piece = make_object(f"{TOMATO}|TomatoSliced_1")
    kitchen.world.objects[piece.id] = piece
    _put_on(kitchen, piece.id, PLATE)
    del kitchen.world.objects[TOMATO]
    touch(kitchen.world)
    goal = {"predicate": "on_sliced_piece", "source": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal)["passed"] is True


def test_a_missing_object_is_reported_before_an_unknown_predicate(kitchen: Sim) -> None:
    assert _check(kitchen, {"predicate": "levitating", "object": GHOST}) == {
        "predicate": {"predicate": "levitating", "object": GHOST}, "objectId": GHOST,
        "passed": False, "detail": f"object not found: {GHOST}",
    }
    check = _check(kitchen, {"predicate": "levitating", "object": "tomato"})
    assert (check["passed"], check["detail"]) == (False, "unsupported predicate: levitating")


@pytest.mark.parametrize("config", load_tasks("demo"), ids=lambda t: t.cell)
def test_recorded_trajectories_carry_the_reference_form(config) -> None:
    document = run_oracle(config)
    stated = [g.model_dump(mode="json", exclude_unset=True) for g in config.goal_predicates]
    for item in document["trajectory"]:
        assert [c["predicate"] for c in item["eval"]["checks"]] == stated
    final = document["final_eval"]
    assert final["success"] is True
    # The reference's wording of on / closed / sliced_by after a successful plan.
    assert all(c["detail"].startswith(("parentReceptacles=[", "isOpen=False",
                                       "isSliced=True required_agent="))
               for c in final["checks"]), final["checks"]

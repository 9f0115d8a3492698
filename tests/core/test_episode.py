"""Episodes: determinism, the trajectory format (reference §9.1), goal predicates (§7.1),
frames, goal text and progress block (§6.1)."""

from __future__ import annotations

import io

import pytest
from PIL import Image

from benchmark_adapter import goals
from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.sim.embedded.world import make_object
from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.trajectory import dumps

from .worlds import (
    DRAWER_A,
    FRIDGE,
    GHOST,
    KNIFE,
    LIGHT,
    MUG,
    PLATE,
    TOMATO,
    Sim,
    make_config,
    make_sim,
    touch,
)

DEMO = {t.cell: t for t in load_tasks("demo")}


# -- determinism ---------------------------------------------------------------------------

@pytest.mark.parametrize("cell", sorted(DEMO))
def test_same_oracle_twice_gives_identical_trajectory_text(cell: str) -> None:
    first = dumps(run_oracle(DEMO[cell]))
    second = dumps(run_oracle(DEMO[cell]))
    assert first == second
    assert first.endswith("\n")


def test_written_trajectory_is_the_canonical_text(tmp_path) -> None:
    config = DEMO["K_D3"]
    ep = Episode(config)
    ep.reset()
    ep.step("Wait(agent_1)")
    document = ep.finish(tmp_path / "run" / "trajectory.json")
    text = (tmp_path / "run" / "trajectory.json").read_text(encoding="utf-8")
    assert text == dumps(document)


# -- trajectory shape ------------------------------------------------------------------------

STATE_OBJECT_KEYS = {"objectId", "visible", "isDirty", "isFilledWithLiquid", "fillLiquid",
                     "isToggled", "parentReceptacles"}


def test_trajectory_shape() -> None:
    config = DEMO["J_D4"]
    doc = run_oracle(config)
    assert {"task_id", "task_config", "init_trace", "final_eval", "trajectory"} <= set(doc)
    assert doc["task_id"] == "J_D4__DemoBedroom2__seed0"
    assert doc["task_config"]["task_id"] == "J_D4__DemoBedroom2__seed0"
    assert doc["task_config"]["init_state"]["objects"]["transfer"] == (
        "SideTable|+00.00|+00.00|+00.00")
    items = doc["trajectory"]

    init = items[0]
    assert (init["step_index"], init["label"]) == (0, "init")
    assert init["native_trace"] == doc["init_trace"]
    assert len(doc["init_trace"]) == 5
    assert all(set(t) == {"action", "lastActionSuccess", "errorMessage"}
               for t in doc["init_trace"])
    assert "skill_result" not in init

    steps = items[1:-1]
    assert [s["step_index"] for s in steps] == list(range(1, len(steps) + 1))
    for item in steps:
        result = item["skill_result"]
        assert set(result) == {"skill", "agent", "args", "success", "errorMessage",
                               "native_trace"}
        assert item["label"].startswith(f"{result['skill']}({result['agent']}")
        assert set(item["eval"]) == {"success", "checks"}
        assert "native_trace" not in item
    for item in items:
        assert "image" in item
        assert set(item["state"]) == {"objects", "agents"}
        assert set(item["state"]["objects"]) == {"item_1", "item_2", "item_3", "transfer",
                                                 "target"}
        for record in item["state"]["objects"].values():
            assert set(record) >= STATE_OBJECT_KEYS
        assert [a["agent"] for a in item["state"]["agents"]] == ["agent_1", "agent_2"]
        for agent in item["state"]["agents"]:
            assert set(agent) == {"agent", "inventory", "lastActionSuccess", "errorMessage"}

    put = next(s for s in steps if s["skill_result"]["skill"] == "Put")
    assert put["skill_result"]["args"] == {"objectId": "KeyChain|+01.40|+00.70|-01.60",
                                           "receptacleId": "SideTable|+00.00|+00.00|+00.00"}
    assert put["label"] == "Put(agent_1, SideTable|+00.00|+00.00|+00.00)"

    last = items[-1]
    assert last["label"] == "policy_stop"
    assert last["step_index"] == len(steps)
    assert last["policy_decision"]["terminal_reason"] == "done"
    assert "skill_result" not in last
    assert doc["final_eval"] == last["eval"]
    assert doc["final_eval"]["success"] is True
    assert [c["passed"] for c in doc["final_eval"]["checks"]] == [True, True, True]


def test_step_records_round_message_and_decision() -> None:
    ep = Episode(DEMO["G_D1"])
    ep.reset()
    ep.step("Wait(agent_2)", round_index=3, message="hi", decision={"policy": "test"})
    ep.stop({"policy": "test", "terminal_reason": "done"})
    step, stop = ep.items[1], ep.items[2]
    assert (step["round_index"], step["message"]) == (3, "hi")
    assert step["policy_decision"] == {"policy": "test"}
    # G_D1 agents have no Wait skill: the menu never offers it, but the executor runs it
    assert step["skill_result"]["success"] is True
    assert step["skill_result"]["native_trace"][0]["action"] == {"action": "Pass",
                                                                 "agentId": 1}
    assert (stop["label"], stop["step_index"]) == ("policy_stop", 1)


def test_failed_step_is_recorded_and_counted() -> None:
    ep = Episode(DEMO["K_D3"])
    ep.reset()
    result = ep.step("Put(agent_1, Knife|+00.80|+00.92|-00.70)")
    assert result.success is False
    assert ep.step_index == 1
    item = ep.items[-1]
    assert item["skill_result"]["errorMessage"] == "Agent is not holding any object"
    assert item["state"]["agents"][0]["inventory"] == []


# -- goal predicates on hand-set world states ------------------------------------------------

def _check(sim: Sim, goal: dict, steps: list | None = None) -> dict:
    config = make_config(goals=[goal])
    evaluation = goals.evaluate(config, sim.md(0)["objects"], steps or [])
    [check] = evaluation["checks"]
    assert evaluation["success"] is check["passed"]
    assert set(check) == {"predicate", "objectId", "passed", "detail"}
    return check


def _set(sim: Sim, object_id: str, **state) -> None:
    obj = sim.world.objects[object_id]
    for key, value in state.items():
        setattr(obj, key, value)
    touch(sim.world)


def _put_on(sim: Sim, object_id: str, receptacle: str) -> None:
    sim.world.objects[object_id].parent = receptacle
    sim.world.objects[receptacle].contents.append(object_id)
    touch(sim.world)


def test_on(kitchen: Sim) -> None:
    goal = {"predicate": "on", "object": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal)["passed"] is False
    _put_on(kitchen, TOMATO, PLATE)
    check = _check(kitchen, goal)
    assert check["passed"] is True and check["objectId"] == TOMATO
    assert _check(kitchen, {"predicate": "on", "object": "tomato",
                            "receptacle": "fridge"})["passed"] is False


def test_on_with_nested_receptacles(kitchen: Sim) -> None:
    _put_on(kitchen, PLATE, FRIDGE)
    _put_on(kitchen, TOMATO, PLATE)
    assert _check(kitchen, {"predicate": "on", "object": "tomato",
                            "receptacle": "fridge"})["passed"] is True


@pytest.mark.parametrize(("predicate", "is_open", "expected"), [
    ("closed", False, True), ("closed", True, False), ("open", True, True), ("open", False, False),
])
def test_open_and_closed(kitchen: Sim, predicate: str, is_open: bool, expected: bool) -> None:
    _set(kitchen, DRAWER_A, is_open=is_open)
    assert _check(kitchen, {"predicate": predicate, "object": "drawer"})["passed"] is expected


@pytest.mark.parametrize(("value", "is_toggled", "expected"), [
    (True, True, True), (True, False, False), (False, False, True), (False, True, False),
])
def test_toggled(kitchen: Sim, value: bool, is_toggled: bool, expected: bool) -> None:
    _set(kitchen, LIGHT, is_toggled=is_toggled)
    goal = {"predicate": "toggled", "object": "light", "value": value}
    assert _check(kitchen, goal)["passed"] is expected


@pytest.mark.parametrize(("predicate", "attribute"), [
    ("sliced", "is_sliced"), ("cooked", "is_cooked"),
])
def test_sliced_and_cooked(kitchen: Sim, predicate: str, attribute: str) -> None:
    goal = {"predicate": predicate, "object": "tomato"}
    assert _check(kitchen, goal)["passed"] is False
    _set(kitchen, TOMATO, **{attribute: True})
    assert _check(kitchen, goal)["passed"] is True


def _slice_step(agent: str, object_id: str = TOMATO, success: bool = True) -> dict:
    return {"skill": "Slice", "agent": agent, "args": {"objectId": object_id},
            "success": success, "errorMessage": "", "native_trace": []}


def test_sliced_by_requires_the_right_agent(kitchen: Sim) -> None:
    goal = {"predicate": "sliced_by", "object": "tomato", "agent": "agent_1"}
    _set(kitchen, TOMATO, is_sliced=True)
    assert _check(kitchen, goal, [_slice_step("agent_1")])["passed"] is True
    assert _check(kitchen, goal, [_slice_step("agent_2")])["passed"] is False
    assert _check(kitchen, goal, [_slice_step("agent_1", success=False)])["passed"] is False
    assert _check(kitchen, goal, [_slice_step("agent_1", KNIFE)])["passed"] is False
    assert _check(kitchen, goal, [])["passed"] is False


def test_sliced_by_needs_the_object_sliced(kitchen: Sim) -> None:
    goal = {"predicate": "sliced_by", "object": "tomato", "agent": "agent_1"}
    assert _check(kitchen, goal, [_slice_step("agent_1")])["passed"] is False


def test_sliced_by_through_an_episode() -> None:
    config = make_config(goals=[{"predicate": "sliced_by", "object": "tomato",
                                 "agent": "agent_2"}])
    ep = Episode(config)
    ep.reset()
    for call in [f"PickUp(agent_2, {KNIFE})", f"Find(agent_2, {TOMATO})"]:
        assert ep.step(call).success
    assert ep.items[-1]["eval"]["success"] is False
    assert ep.step(f"Slice(agent_2, {TOMATO})").success
    assert ep.items[-1]["eval"]["success"] is True  # the step's own eval includes it
    assert ep.evaluate()["success"] is True


def test_on_sliced_piece(kitchen: Sim) -> None:
    goal = {"predicate": "on_sliced_piece", "source": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal)["passed"] is False
    _set(kitchen, TOMATO, is_sliced=True)
    piece = make_object(f"{TOMATO}|TomatoSliced_1")
    kitchen.world.objects[piece.id] = piece
    touch(kitchen.world)
    assert _check(kitchen, goal)["passed"] is False  # a piece, but not on the plate
    _put_on(kitchen, piece.id, PLATE)
    check = _check(kitchen, goal)
    assert check["passed"] is True and check["objectId"] == TOMATO


def test_on_sliced_piece_ignores_the_source_itself(kitchen: Sim) -> None:
    _put_on(kitchen, TOMATO, PLATE)
    goal = {"predicate": "on_sliced_piece", "source": "tomato", "receptacle": "plate"}
    assert _check(kitchen, goal)["passed"] is False


def test_clean(kitchen: Sim) -> None:
    goal = {"predicate": "clean", "object": "mug"}
    _set(kitchen, MUG, is_dirty=True)
    assert _check(kitchen, goal)["passed"] is False
    _set(kitchen, MUG, is_dirty=False)
    assert _check(kitchen, goal)["passed"] is True


@pytest.mark.parametrize(("liquid", "filled", "fill_liquid", "expected"), [
    ("coffee", True, "coffee", True),
    ("coffee", True, "water", False),
    ("coffee", False, None, False),
    (None, True, "wine", True),
])
def test_filled(kitchen: Sim, liquid, filled, fill_liquid, expected) -> None:
    _set(kitchen, MUG, is_filled=filled, fill_liquid=fill_liquid)
    goal = {"predicate": "filled", "object": "mug"}
    if liquid:
        goal["liquid"] = liquid
    assert _check(kitchen, goal)["passed"] is expected


def test_filled_without_a_recorded_liquid(kitchen: Sim) -> None:
    _set(kitchen, MUG, is_filled=True, fill_liquid=None)
    goal = {"predicate": "filled", "object": "mug", "liquid": "water"}
    assert _check(kitchen, goal)["passed"] is True


def test_empty(kitchen: Sim) -> None:
    goal = {"predicate": "empty", "object": "mug"}
    assert _check(kitchen, goal)["passed"] is True
    _set(kitchen, MUG, is_filled=True, fill_liquid="water")
    assert _check(kitchen, goal)["passed"] is False


@pytest.mark.parametrize("goal", [
    {"predicate": "on", "object": GHOST, "receptacle": "plate"},
    {"predicate": "closed", "object": GHOST},
    {"predicate": "empty", "object": GHOST},
    {"predicate": "clean", "object": GHOST},
    {"predicate": "toggled", "object": GHOST, "value": False},
])
def test_missing_object_fails(kitchen: Sim, goal: dict) -> None:
    check = _check(kitchen, goal)
    assert check["passed"] is False
    assert check["objectId"] == GHOST


def test_unknown_predicate_fails(kitchen: Sim) -> None:
    assert _check(kitchen, {"predicate": "levitating", "object": "tomato"})["passed"] is False


def test_no_predicates_is_success(kitchen: Sim) -> None:
    assert goals.evaluate(make_config(), kitchen.md(0)["objects"], []) == {
        "success": True, "checks": []}


# -- frames ----------------------------------------------------------------------------------

@pytest.mark.parametrize("size", [300, 120])
def test_frames_one_png_per_agent(size: int) -> None:
    config = make_config(agents=3)
    obs = Episode(config, frames=True, frame_size=size).reset()
    assert list(obs.frames) == ["agent_1", "agent_2", "agent_3"]
    for png in obs.frames.values():
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        width, height = Image.open(io.BytesIO(png)).size
        assert width >= 300 and height >= 300


def test_no_frames_unless_asked() -> None:
    assert Episode(make_config()).reset().frames == {}


# -- goal text and progress ----------------------------------------------------------------

GOALS = [
    {"predicate": "on", "object": "tomato", "receptacle": "plate"},
    {"predicate": "toggled", "object": "light", "value": False},
    {"predicate": "sliced_by", "object": "tomato", "agent": "agent_2"},
    {"predicate": "closed", "object": "drawer"},
]


def test_goal_text_and_progress_block() -> None:
    config = make_config(goals=GOALS, task_name="store_TV_remote")
    sim = make_sim(config)
    sim.place(0, -2.5, -2.5, 180.0)  # agent 0 sees nothing: Drawer|+01.50 is "Drawer"
    ep = Episode(config, sim.ctl)
    ep.controller.reset = lambda: None  # keep the hand-placed agent (reset would regrow it)
    obs = ep.reset()
    assert obs.goal_text == (  # capitalised like str.capitalize, as the reference does
        "Store tv remote:\n"
        "  1. Put the Tomato in the Plate\n"
        "  2. Turn off the LightSwitch\n"
        "  3. agent_2 must slice the Tomato\n"
        "  4. Close the Drawer 2")
    assert obs.progress_text == (
        "  [✗] Put the Tomato in the Plate\n"
        "  [✓] Turn off the LightSwitch\n"
        "  [✗] agent_2 must slice the Tomato\n"
        "  [✓] Close the Drawer 2\n"
        "  2/4 objectives complete.")


def test_progress_updates_after_steps() -> None:
    config = make_config(goals=GOALS[:2])
    ep = Episode(config)
    ep.reset()
    for call in [f"PickUp(agent_1, {TOMATO})", f"Put(agent_1, {PLATE})"]:
        assert ep.step(call).success
    assert ep.observe().progress_text.splitlines()[-1] == "  2/2 objectives complete."
    assert ep.observe().progress_text.splitlines()[0] == "  [✓] Put the Tomato in the Plate"


def test_goal_phrases_of_every_predicate() -> None:
    config = make_config(goals=[
        {"predicate": "open", "object": "fridge"},
        {"predicate": "toggled", "object": "light", "value": True},
        {"predicate": "sliced", "object": "tomato"},
        {"predicate": "on_sliced_piece", "source": "tomato", "receptacle": "plate"},
        {"predicate": "filled", "object": "mug", "liquid": "coffee"},
        {"predicate": "filled", "object": "mug"},
        {"predicate": "empty", "object": "mug"},
        {"predicate": "clean", "object": "knife"},
        {"predicate": "cooked", "object": "tomato"},
    ])
    assert goals.goal_phrases(config, {}) == [
        "Open the Fridge", "Turn on the LightSwitch", "Slice the Tomato",
        "Place a slice of Tomato on the Plate", "Fill the Mug with coffee",
        "Fill the Mug with liquid", "Empty the Mug", "Clean the Knife", "Cook the Tomato"]


def test_no_goal_predicates_progress() -> None:
    obs = Episode(make_config(task_name="idle")).reset()
    assert obs.progress_text == "  (no goal predicates)"
    assert obs.goal_text.startswith("Idle:")

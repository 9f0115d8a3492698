"""The action menu (reference §5.1–5.3): aliases, entry order, global ids, line formats,
allowed-skill and important-object filtering, D4 role gating."""

from __future__ import annotations

from typing import Any

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.menu import ActionSpace, MenuEntry, compact, menu_line, menu_lines
from benchmark_adapter.tasks import load_task, load_tasks

from .worlds import (
    DRAWER_A,
    DRAWER_B,
    KNIFE,
    MUG,
    PLATE,
    TASKS,
    TOMATO,
    Sim,
    make_config,
    make_sim,
    needs_data,
)

FLAGS = ("pickupable", "receptacle", "openable", "toggleable", "sliceable", "dirtyable",
         "canFillWithLiquid", "breakable", "moveable")


def obj(object_id: str, *flags: str, visible: bool = False, **extra: Any) -> dict[str, Any]:
    """A minimal object record as agent 0's metadata would give it."""
    record = {"objectId": object_id, "objectType": object_id.split("|")[0], "visible": visible,
              "parentReceptacles": None, **{f: f in flags for f in FLAGS}}
    record.update(extra)
    return record


# -- aliases --------------------------------------------------------------------------------

def test_aliases_number_by_type_visible_first_then_by_id() -> None:
    objects = [obj("Drawer|a", "receptacle", "openable"),
               obj("Drawer|b", "receptacle", "openable"),
               obj("Drawer|c", "receptacle", "openable", visible=True),
               obj("Apple|z", "pickupable"),
               obj("Floor|0")]  # no affordance: never an action target
    space = ActionSpace.build(["agent_1"], objects)
    assert dict(space.alias_of) == {"Apple|z": "Apple", "Drawer|c": "Drawer",
                                    "Drawer|a": "Drawer_2", "Drawer|b": "Drawer_3"}
    finds = [e.name for e in space.entries if e.skill == "Find"]
    assert finds == ["agent_1: find a Apple", "agent_1: find a Drawer",
                     "agent_1: find a Drawer_2", "agent_1: find a Drawer_3"]


def test_sliced_sources_give_way_to_their_pieces() -> None:
    objects = [obj("Tomato|1", "pickupable", "sliceable"),
               obj("Tomato|1|TomatoSliced_0", "pickupable", objectType="TomatoSliced"),
               obj("Tomato|1|TomatoSliced_1", "pickupable", objectType="TomatoSliced")]
    space = ActionSpace.build(["agent_1"], objects)
    assert dict(space.alias_of) == {"Tomato|1|TomatoSliced_0": "TomatoSliced",
                                    "Tomato|1|TomatoSliced_1": "TomatoSliced_2"}
    assert all("Tomato|1" not in e.args for e in space.entries)


def test_aliases_follow_agent_0_visibility_in_the_simulator() -> None:
    sim = make_sim()
    sim.place(0, -2.5, -2.5, 180.0)  # agent_1 sees nothing
    assert sim.run(f"Find(agent_2, {DRAWER_A})").success  # agent_2's view must not matter
    space = ActionSpace.build(["agent_1", "agent_2"], sim.md(0)["objects"])
    assert (space.alias_of[DRAWER_B], space.alias_of[DRAWER_A]) == ("Drawer", "Drawer_2")

    assert sim.run(f"Find(agent_1, {DRAWER_A})").success
    assert sim.obj(DRAWER_A)["visible"] and not sim.obj(DRAWER_B)["visible"]
    space = ActionSpace.build(["agent_1", "agent_2"], sim.md(0)["objects"])
    assert (space.alias_of[DRAWER_A], space.alias_of[DRAWER_B]) == ("Drawer", "Drawer_2")


# -- entry order and global ids ----------------------------------------------------------------

KITCHEN_BLOCK = [
    "find a CounterTop", "find a Drawer", "find a Drawer_2", "find a Fridge", "find a Knife",
    "find a LightSwitch", "find a Mug", "find a Plate", "find a Tomato",
    "explore forward", "explore back", "explore left", "explore right", "explore turn_left",
    "explore turn_right", "explore look_up", "explore look_down",
    "wait",
    "pick up the Knife", "pick up the Mug", "pick up the Plate", "pick up the Tomato",
    "put object in hand on the CounterTop", "put object in hand on the Drawer",
    "put object in hand on the Drawer_2", "put object in hand on the Fridge",
    "put object in hand on the Mug", "put object in hand on the Plate",
    "drop object in hand",
    "open the Drawer", "close the Drawer", "open the Drawer_2", "close the Drawer_2",
    "open the Fridge", "close the Fridge",
    "turn on the LightSwitch", "turn off the LightSwitch",
    "slice the Tomato",
    "clean the Knife", "clean the Mug", "clean the Plate", "clean the Tomato",
    "fill the Mug with water", "empty liquid from the Mug",
    "fill the Plate with water", "empty liquid from the Plate",
    "push the Knife", "pull the Knife", "push the Mug", "pull the Mug",
    "push the Plate", "pull the Plate", "push the Tomato", "pull the Tomato",
    "break the Mug", "break the Plate",
]


@pytest.fixture
def blind_kitchen() -> Sim:
    sim = make_sim()
    sim.place(0, -2.5, -2.5, 180.0)
    return sim


def test_agent_block_order(blind_kitchen: Sim) -> None:
    space = ActionSpace.build(["agent_1", "agent_2"], blind_kitchen.md(0)["objects"])
    assert [e.name for e in space.entries if e.agent == "agent_1"] == [
        f"agent_1: {p}" for p in KITCHEN_BLOCK]
    assert [e.name for e in space.entries if e.agent == "agent_2"] == [
        f"agent_2: {p}" for p in KITCHEN_BLOCK]


def test_action_ids_are_global_indices(blind_kitchen: Sim) -> None:
    space = ActionSpace.build(["agent_1", "agent_2"], blind_kitchen.md(0)["objects"])
    assert [e.action_id for e in space.entries] == list(range(112))
    second = [e for e in space.entries if e.agent == "agent_2"]
    assert (second[0].action_id, second[0].name) == (56, "agent_2: find a CounterTop")


def test_entry_calls(blind_kitchen: Sim) -> None:
    space = ActionSpace.build(["agent_1", "agent_2"], blind_kitchen.md(0)["objects"])
    by_name = {e.name: e for e in space.entries}
    assert by_name["agent_2: pick up the Knife"].call == f"PickUp(agent_2, {KNIFE})"
    assert by_name["agent_1: fill the Mug with water"].call == (
        f"FillObjectWithLiquid(agent_1, {MUG}, water)")
    assert by_name["agent_1: explore look_up"].call == "Explore(agent_1, look_up)"
    assert by_name["agent_1: wait"].call == "Wait(agent_1)"
    assert by_name["agent_1: drop object in hand"].call == "Drop(agent_1)"
    assert by_name["agent_1: put object in hand on the Drawer"].call == (
        f"Put(agent_1, {DRAWER_B})")
    assert by_name["agent_1: find a Plate"].to_dict() == {
        "action_id": 7, "agent": "agent_1", "name": "agent_1: find a Plate",
        "call": f"Find(agent_1, {PLATE})"}


# -- line formats ------------------------------------------------------------------------------

ENTRY = MenuEntry(183, "agent_2", "agent_2: pick up the KeyChain", "PickUp",
                  ("KeyChain|-02.39|+00.73|+06.30",))


def test_centralized_line() -> None:
    assert menu_line(ENTRY, centralized=True) == (
        "  183: agent_2: pick up the KeyChain [agent_2]")


def test_distributed_line() -> None:
    assert menu_line(ENTRY, centralized=False) == "  183: agent_2: pick up the KeyChain"


def test_menu_lines_and_empty_menu() -> None:
    other = MenuEntry(7, "agent_1", "agent_1: wait", "Wait")
    assert menu_lines([other, ENTRY], centralized=True) == [
        "  7: agent_1: wait [agent_1]", "  183: agent_2: pick up the KeyChain [agent_2]"]
    assert menu_lines([other], centralized=False) == ["  7: agent_1: wait"]
    assert menu_lines([], centralized=True) == ["  (no actions available)"]
    assert menu_lines([], centralized=False) == ["  (no actions available)"]


# -- per-agent filtering -----------------------------------------------------------------------

def _menu(config, sim: Sim | None = None) -> list[MenuEntry]:
    sim = sim or make_sim(config)
    objects = sim.md(0)["objects"]
    return compact(ActionSpace.build(config.agent_ids, objects), config, objects)


def test_allowed_skills_per_agent_with_task_level_fallback() -> None:
    config = make_config(skills=["Wait", "Drop"],
                         agent_skills={"agent_1": ["Find", "PickUp"]})
    menu = _menu(config)
    assert {e.skill for e in menu if e.agent == "agent_1"} == {"Find", "PickUp"}
    assert [e.name for e in menu if e.agent == "agent_2"] == [
        "agent_2: wait", "agent_2: drop object in hand"]


def test_no_skill_lists_keep_everything() -> None:
    config = make_config(skills=[])
    menu = _menu(config)
    assert len(menu) == 112
    assert {e.skill for e in menu} == {
        "Find", "Explore", "Wait", "PickUp", "Put", "Drop", "Open", "Close", "ToggleOn",
        "ToggleOff", "Slice", "CleanObject", "FillObjectWithLiquid", "EmptyLiquidFromObject",
        "PushObject", "PullObject", "BreakObject"}


def test_only_important_objects_are_targets() -> None:
    # The Mug exists (an init action names it) but is not an important object.
    config = make_config({"tomato": TOMATO, "plate": PLATE, "knife": KNIFE},
                         init_actions=[{"action": "assert_present", "objectId": MUG}])
    sim = make_sim(config)
    assert MUG in sim.world.objects
    menu = _menu(config, sim)
    assert all(MUG not in e.args for e in menu)
    targets = {e.args[0] for e in menu if e.skill not in ("Explore", "Wait", "Drop")}
    assert targets == {TOMATO, PLATE, KNIFE}
    agent_1 = [e.name for e in menu if e.agent == "agent_1"]
    assert agent_1[:3] == ["agent_1: find a Knife", "agent_1: find a Plate",
                           "agent_1: find a Tomato"]
    assert "agent_1: explore forward" in agent_1 and "agent_1: drop object in hand" in agent_1


def test_sliced_pieces_never_reach_the_compact_menu() -> None:
    config = make_config({"tomato": TOMATO, "knife": KNIFE})
    sim = make_sim(config)
    assert sim.run(f"PickUp(agent_1, {KNIFE})").success
    assert sim.run(f"Find(agent_1, {TOMATO})").success
    assert sim.run(f"Slice(agent_1, {TOMATO})").success
    objects = sim.md(0)["objects"]
    space = ActionSpace.build(config.agent_ids, objects)
    assert f"{TOMATO}|TomatoSliced_0" in space.alias_of  # in Γ …
    menu = compact(space, config, objects)
    assert all("Sliced" not in arg for e in menu for arg in e.args)  # … not in the menu
    assert all(TOMATO not in e.args for e in menu)  # and the sliced source is gone


# -- D4 role gating ----------------------------------------------------------------------------

def _demo_j_d4():
    return next(t for t in load_tasks("demo") if t.cell == "J_D4")


def _by_agent(menu: list[MenuEntry], agent: str, skill: str) -> list[str]:
    return [e.args[0] for e in menu if e.agent == agent and e.skill == skill]


def test_d4_gating_on_the_demo_relay() -> None:
    config = _demo_j_d4()
    o = config.init_state.objects
    ep = Episode(config)
    menu = ep.reset().action_menu
    skills_1 = {e.skill for e in menu if e.agent == "agent_1"}
    skills_2 = {e.skill for e in menu if e.agent == "agent_2"}
    assert "Drop" not in skills_1 and "Drop" not in skills_2  # agent_1 may Drop, but not here
    assert _by_agent(menu, "agent_1", "Put") == [o["transfer"]]  # producer: buffer only
    assert sorted(_by_agent(menu, "agent_1", "PickUp")) == sorted(
        [o["item_1"], o["item_2"], o["item_3"]])  # producers pick up anything
    assert _by_agent(menu, "agent_2", "Put") == [o["target"]]  # consumer: targets only
    assert _by_agent(menu, "agent_2", "PickUp") == []  # nothing on the buffer yet
    assert len(_by_agent(menu, "agent_2", "Find")) == 5  # other skills unrestricted

    for call in [f"Find(agent_1, {o['item_1']})", f"PickUp(agent_1, {o['item_1']})",
                 f"Find(agent_1, {o['transfer']})"]:
        assert ep.step(call).success, call
    assert _by_agent(ep.observe().action_menu, "agent_2", "PickUp") == []
    assert ep.step(f"Put(agent_1, {o['transfer']})").success

    menu = ep.observe().action_menu
    pickups = [e for e in menu if e.agent == "agent_2" and e.skill == "PickUp"]
    assert [e.call for e in pickups] == [f"PickUp(agent_2, {o['item_1']})"]
    assert pickups[0].name == "agent_2: pick up the KeyChain"

    assert ep.step(pickups[0].call).success  # once taken off the buffer, the entry goes
    assert _by_agent(ep.observe().action_menu, "agent_2", "PickUp") == []


def test_d4_gating_ignores_agents_outside_the_roles() -> None:
    config = make_config(agents=3, constraints={"producer_consumer": {
        "producer": "agent_1", "consumer": "agent_2", "buffer": PLATE, "targets": [DRAWER_A]}})
    menu = _menu(config)
    assert _by_agent(menu, "agent_1", "Put") == [PLATE]
    assert _by_agent(menu, "agent_2", "Put") == [DRAWER_A]
    assert not any(e.skill == "Drop" for e in menu if e.agent in ("agent_1", "agent_2"))
    assert any(e.skill == "Drop" for e in menu if e.agent == "agent_3")
    assert len(_by_agent(menu, "agent_3", "Put")) == 6


@needs_data
@pytest.mark.parametrize("name", ["J_D4__FloorPlan202__living_room_4agent_seed2.json",
                                  "C_D4__FloorPlan1__seed0.json"])
def test_d4_gating_on_real_configs(name: str) -> None:
    config = load_task(TASKS / name)
    pc = config.producer_consumer
    menu = Episode(config).reset().action_menu
    for agent in config.agent_ids:
        assert not any(e.skill == "Drop" for e in menu if e.agent == agent), agent
    for agent in config.producers():
        assert _by_agent(menu, agent, "Put") == [pc["buffer"]]
        assert _by_agent(menu, agent, "PickUp"), agent
    for agent in config.consumers():
        assert _by_agent(menu, agent, "Put") == pc["targets"]
        assert _by_agent(menu, agent, "PickUp") == []


@needs_data
def test_real_4_agent_roles() -> None:
    config = load_task(TASKS / "J_D4__FloorPlan202__living_room_4agent_seed2.json")
    assert (config.producers(), config.consumers()) == (
        ["agent_1", "agent_2"], ["agent_3", "agent_4"])


@needs_data
def test_kitchen_relay_consumer_keeps_open_and_close() -> None:
    config = load_task(TASKS / "C_D4__FloorPlan1__seed0.json")
    fridge = config.init_state.objects["fridge"]
    menu = Episode(config).reset().action_menu
    assert [e.skill for e in menu if e.agent == "agent_2" and fridge in e.args
            and e.skill in ("Open", "Close")] == ["Open", "Close"]
    assert not any(e.skill in ("Open", "Close") for e in menu if e.agent == "agent_1")

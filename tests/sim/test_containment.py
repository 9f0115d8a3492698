"""Containment in the embedded world stays a forest (issue 24): nothing can be put inside
itself or inside what it contains; every walk over parents is bounded and raises on a cycle
instead of looping; random play of every containment-changing action keeps the invariant."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmark_adapter.metrics.steps import classify_step
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.metadata import object_record
from benchmark_adapter.sim.embedded.vision import enclosed, visible
from benchmark_adapter.sim.embedded.world import ContainmentError, World
from benchmark_adapter.skills.executor import SkillExecutor
from benchmark_adapter.tasks import TaskConfig

MUG = "Mug|-00.50|+00.95|-00.50"
BOWL = "Bowl|+00.50|+00.95|-00.50"
PLATE = "Plate|+00.00|+00.95|+01.00"
BOX = "Box|+01.00|+00.60|+01.00"  # openable, starts closed
DRAWER = "Drawer|-01.00|+00.60|-01.00"
TOMATO = "Tomato|+00.50|+00.95|+00.20"
KNIFE = "Knife|+00.20|+00.95|+00.60"
OBJECTS = (MUG, BOWL, PLATE, BOX, DRAWER, TOMATO, KNIFE)


def controller(agents: int = 2) -> EmbeddedController:
    config = TaskConfig.model_validate({
        "task_id": "X_D1__Nesting__seed0", "coordination_dim": "D1", "task_family": "X",
        "task_name": "nesting", "scene_id": "Nesting", "agent_count": agents,
        "agents": [{"id": f"agent_{i + 1}"} for i in range(agents)],
        "init_state": {"controller_init": {"scene": "Nesting", "agentCount": agents},
                       "objects": {oid.split("|")[0].lower(): oid for oid in OBJECTS}},
    })
    ctl = EmbeddedController(config)
    ctl.reset()
    return ctl


def act(ctl: EmbeddedController, action: str, agent: int = 0, **kwargs) -> dict:
    """A forced native action of `agent`; its own metadata."""
    return ctl.step(action, agentId=agent, forceAction=True, **kwargs)[agent]


def put_into(ctl: EmbeddedController, inner: str, outer: str, agent: int = 0) -> None:
    """Pick `inner` up and put it into `outer`; both must succeed."""
    assert act(ctl, "PickupObject", agent, objectId=inner)["lastActionSuccess"]
    md = act(ctl, "PutObject", agent, objectId=outer)
    assert md["lastActionSuccess"], md["errorMessage"]


def record(md, object_id: str) -> dict:
    return next(o for o in md["objects"] if o["objectId"] == object_id)


def refusal(inner: str, outer: str) -> str:
    return f"{outer} cannot be placed in {inner}, which lies inside {outer}"


# -- the executor refuses ---------------------------------------------------------------------

def test_a_held_receptacle_cannot_go_into_what_it_contains() -> None:
    ctl = controller()
    put_into(ctl, MUG, PLATE)
    assert act(ctl, "PickupObject", objectId=PLATE)["lastActionSuccess"]
    md = act(ctl, "PutObject", objectId=MUG)
    # Checked before `objects` is read: on a world that allowed the cycle, reading it hangs.
    assert md["lastActionSuccess"] is False
    assert md["errorMessage"] == refusal(MUG, PLATE)
    assert [o["objectId"] for o in md["inventoryObjects"]] == [PLATE]
    assert record(md, MUG)["parentReceptacles"] == [PLATE]
    assert record(md, PLATE)["parentReceptacles"] is None
    ctl.world.check_containment()


def test_the_refusal_holds_at_any_depth() -> None:
    ctl = controller()
    put_into(ctl, MUG, BOWL)
    put_into(ctl, BOWL, PLATE)
    assert act(ctl, "PickupObject", objectId=PLATE)["lastActionSuccess"]
    for inner in (BOWL, MUG):
        md = act(ctl, "PutObject", objectId=inner)
        assert md["lastActionSuccess"] is False
        assert md["errorMessage"] == refusal(inner, PLATE)
    assert record(md, MUG)["parentReceptacles"] == [BOWL, PLATE]
    ctl.world.check_containment()


def test_putting_an_object_in_itself_is_refused() -> None:
    ctl = controller()
    act(ctl, "PickupObject", objectId=PLATE)
    md = act(ctl, "PutObject", objectId=PLATE)
    assert md["lastActionSuccess"] is False
    assert md["errorMessage"] == f"Cannot place {PLATE} in itself"


def test_nesting_that_makes_no_cycle_still_works() -> None:
    ctl = controller()
    act(ctl, "OpenObject", objectId=DRAWER)
    put_into(ctl, MUG, BOWL)
    put_into(ctl, BOWL, PLATE)
    put_into(ctl, PLATE, DRAWER)
    md = ctl.last_metadata()[0]
    assert record(md, MUG)["parentReceptacles"] == [BOWL, PLATE, DRAWER]
    put_into(ctl, MUG, PLATE, agent=1)  # taking the inner one out and up is fine
    assert record(ctl.last_metadata()[0], MUG)["parentReceptacles"] == [PLATE, DRAWER]
    ctl.world.check_containment()


def test_the_put_skill_reports_the_refusal_as_a_precondition_violation() -> None:
    ctl = controller()
    put_into(ctl, MUG, PLATE)
    executor = SkillExecutor(ctl)
    assert executor.execute(f"PickUp(agent_1, {PLATE})").success
    result = executor.execute(f"Put(agent_1, {MUG})")
    assert result.success is False
    assert result.errorMessage == refusal(MUG, PLATE)
    step = {"skill": "Put", "agent": "agent_1", "success": False,
            "errorMessage": result.errorMessage}
    assert classify_step(step, {}) == "precondition_violation"


# -- bounded walks --------------------------------------------------------------------------

def planted_cycle() -> World:
    """A world whose containment was corrupted behind the executor's back: MUG in PLATE,
    PLATE in MUG."""
    world = controller().world
    mug, plate = world.objects[MUG], world.objects[PLATE]
    mug.parent, plate.contents = PLATE, [MUG]
    plate.parent, mug.contents = MUG, [PLATE]
    return world


def test_every_walk_over_parents_raises_on_a_cycle_instead_of_looping() -> None:
    world = planted_cycle()
    mug, agent = world.objects[MUG], world.agents[0]
    walks = (
        lambda: world.ancestors(mug),
        lambda: world.lies_within(world.objects[PLATE], mug),
        lambda: enclosed(world, mug),
        lambda: visible(world, agent, mug),
        lambda: object_record(world, mug),
        world.check_containment,
    )
    cycles = {f"{a} -> {b} -> {a}" for a, b in ((MUG, PLATE), (PLATE, MUG))}
    for walk in walks:
        with pytest.raises(ContainmentError, match="containment cycle: ") as caught:
            walk()
        assert str(caught.value).removeprefix("containment cycle: ") in cycles


def test_a_three_object_cycle_is_named_in_full() -> None:
    world = controller().world
    chain = (MUG, BOWL, PLATE)
    for inner, outer in zip(chain, (*chain[1:], chain[0])):
        world.objects[inner].parent = outer
        world.objects[outer].contents.append(inner)
    with pytest.raises(ContainmentError, match=re.escape(f"{MUG} -> {BOWL} -> {PLATE} -> {MUG}")):
        world.ancestors(world.objects[MUG])


def _one_sided_parent(world: World) -> None:
    world.objects[MUG].parent = PLATE


def _one_sided_contents(world: World) -> None:
    world.objects[PLATE].contents.append(MUG)


def _listed_twice(world: World) -> None:
    world.objects[MUG].parent = PLATE
    world.objects[PLATE].contents.extend([MUG, MUG])


def _held_and_inside(world: World) -> None:
    _listed_twice(world)
    world.objects[PLATE].contents.pop()
    world.objects[MUG].held_by = 0


def _unknown_parent(world: World) -> None:
    world.objects[MUG].parent = "Nowhere|+00.00|+00.00|+00.00"


@pytest.mark.parametrize(("corrupt", "message"), [
    (_one_sided_parent, "names .* as its parent, which does not list it"),
    (_one_sided_contents, "whose parent is not"),
    (_listed_twice, "lists an object twice"),
    (_held_and_inside, "is held and lies in"),
    (_unknown_parent, "does not list it"),
])
def test_check_containment_names_each_kind_of_breach(corrupt, message: str) -> None:
    world = controller().world
    world.check_containment()
    corrupt(world)
    with pytest.raises(ContainmentError, match=message):
        world.check_containment()


def test_a_walk_from_an_unknown_parent_raises() -> None:
    world = controller().world
    _unknown_parent(world)
    with pytest.raises(ContainmentError, match="which is not an object"):
        world.ancestors(world.objects[MUG])


# -- no sequence of actions breaks the forest -----------------------------------------------

# "Move": pick the target up with an empty hand, else put what the hand holds into it, so
# that random plans nest receptacles often (picking up what they were put into, and back).
VERBS = ("Move", "Move", "Move", "Move", "DropHandObject", "OpenObject", "CloseObject",
         "SliceObject")
# Mostly the portable receptacles, where cycles could form.
TARGETS = (MUG, BOWL, PLATE, BOX, MUG, BOWL, PLATE, BOX, DRAWER, TOMATO)


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(VERBS), st.integers(0, 1), st.sampled_from(TARGETS)),
                max_size=30))
def test_containment_stays_a_forest_under_any_actions(plan) -> None:
    ctl = controller()
    for verb, agent, target in plan:
        action = verb
        if verb == "Move":
            action = "PutObject" if ctl.world.agents[agent].held else "PickupObject"
        ctl.step(action, agentId=agent, objectId=target, forceAction=True)
        ctl.world.check_containment()
        for obj in ctl.last_metadata()[agent]["objects"]:
            assert obj["objectId"] not in (obj["parentReceptacles"] or [])

"""`ThorCompatController`: code written for ai2thor's `Controller` runs on the embedded world.

`thor_client.py` is that code: a stdlib-only client written against ai2thor's API. It runs
every shared config's oracle plan here, and — when ai2thor is installed — gives the same
answers on ai2thor's own `Controller` (driven over the fake Unity of tests/thor).
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.sim.embedded import ThorCompatController
from benchmark_adapter.sim.embedded.thor_events import Event, MultiAgentEvent
from benchmark_adapter.tasks import load_task
from tests.core.worlds import KNIFE, TOMATO, make_config
from tests.paths import SHARED_TASKS

from .thor_client import ThirdPartyEnv, agent_meta

SHARED_FILES = sorted(SHARED_TASKS.glob("*.json")) if SHARED_TASKS.is_dir() else []
needs_data = pytest.mark.skipif(not SHARED_FILES, reason=f"no shared configs at {SHARED_TASKS}")
REPO = Path(__file__).resolve().parents[2]


def _raw(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text())


def _oracle_run(path: Path) -> tuple[list[bool], list[dict[str, Any]]]:
    """The config's oracle plan as an Episode records it: each init action's success, and
    each step (label and outcome)."""
    document = run_oracle(load_task(path))
    assert document["final_eval"]["success"] is True
    init = [entry["lastActionSuccess"] for entry in document["init_trace"]]
    return init, [item for item in document["trajectory"] if item.get("skill_result")]


@pytest.fixture
def kitchen() -> ThorCompatController:
    return ThorCompatController(make_config())


# -- a third-party client runs whole plans ------------------------------------------------

@needs_data
@pytest.mark.parametrize("path", SHARED_FILES, ids=lambda p: p.stem)
def test_a_third_party_client_runs_the_oracle_plan(path: Path) -> None:
    env = ThirdPartyEnv(_raw(path), ThorCompatController(_raw(path)))
    init, steps = _oracle_run(path)
    assert [entry["ok"] for entry in env.reset()] == init
    for step in steps:
        outcome = env.run(step["label"])
        assert outcome["success"] == step["skill_result"]["success"], (step["label"], outcome)
    assert env.goals_met() and all(env.goals_met())


# -- the same answers as ai2thor's own Controller ------------------------------------------

PARITY = ["A_D1__FloorPlan1__seed0.json", "C_D2__FloorPlan202__livingroom_3agent_seed1.json",
          "K_D3__FloorPlan13__seed0.json"]


def _ai2thor_controller(path: Path) -> Any:
    """ai2thor 5.0's real `Controller` over the fake Unity, built with the reference's kwargs."""
    from benchmark_adapter.sim.thor.launch import controller_kwargs
    from benchmark_adapter.sim.thor.options import ThorOptions
    from tests.thor.fake_unity import FakeUnityController, SceneLibrary

    config = load_task(path)
    library = SceneLibrary()
    library.add(config)
    init = config.init_state.controller_init
    kwargs = controller_kwargs(ThorOptions(), init.scene, {
        "agentMode": "default", "agentCount": init.agentCount, "gridSize": init.gridSize,
        "visibilityDistance": init.visibilityDistance, "renderImage": True,
    }, "CloudRendering")
    return FakeUnityController(library, **kwargs), kwargs


@needs_data
@pytest.mark.needs_thor
@pytest.mark.parametrize("name", PARITY)
def test_the_client_gets_ai2thors_answers(name: str) -> None:
    path = SHARED_TASKS / name
    real, kwargs = _ai2thor_controller(path)
    compat = ThorCompatController(_raw(path), **kwargs)  # ai2thor's constructor arguments
    ours, theirs = ThirdPartyEnv(_raw(path), compat), ThirdPartyEnv(_raw(path), real)
    assert ours.reset() == theirs.reset()
    for step in _oracle_run(path)[1]:
        assert ours.run(step["label"]) == theirs.run(step["label"])
    assert ours.native_log == theirs.native_log
    ours_md = [e.metadata for e in compat.last_event.events]
    assert ours_md == [e.metadata for e in real.last_event.events]
    assert type(compat.last_event).__name__ == type(real.last_event).__name__
    # An invalid action: ValueError from both, with the reply stored in last_event.
    for controller in (compat, real):
        with pytest.raises(ValueError, match="Invalid action: Levitate"):
            controller.step(action="Levitate", agentId=1)
    assert compat.last_event.metadata == real.last_event.metadata
    assert compat.last_event.metadata["errorCode"] == "InvalidAction"


# Deprecated aliases that only warn in ai2thor.
DEPRECATED = {"image_data", "class_segmentation_frame", "pose", "pose_discrete"}


def _public_attributes(obj: Any) -> dict[str, type]:
    """Data attributes by type; subclasses of builtins (ai2thor's MetadataWrapper is a dict)
    count as their builtin."""
    names = [n for n in dir(obj) if not n.startswith(("_", "add_")) and n not in DEPRECATED]
    values = [(n, getattr(obj, n)) for n in names]
    return {n: next(t for t in type(v).__mro__ if t.__module__ in ("builtins", "numpy"))
            for n, v in values if not callable(v)}


@needs_data
@pytest.mark.needs_thor
def test_events_have_ai2thors_attributes_and_types() -> None:
    import ai2thor.server

    path = SHARED_TASKS / PARITY[0]
    real, kwargs = _ai2thor_controller(path)
    compat = ThorCompatController(_raw(path), **kwargs)
    theirs, ours = real.step(action="Pass", agentId=1), compat.step(action="Pass", agentId=1)
    assert isinstance(theirs, ai2thor.server.MultiAgentEvent)
    assert isinstance(ours, MultiAgentEvent)
    for mine, real_one in [(ours, theirs), (ours.events[1], theirs.events[1])]:
        expected, got = _public_attributes(real_one), _public_attributes(mine)
        assert {k: got.get(k) for k in expected} == expected
    assert ours.events[1].frame.shape == theirs.events[1].frame.shape
    assert ours.events[1].frame.dtype == theirs.events[1].frame.dtype
    assert bool(ours) is bool(theirs) is True
    # ai2thor's own Event accepts our metadata as Unity's.
    rebuilt = ai2thor.server.Event(ours.events[0].metadata)
    assert rebuilt.objects_by_type("Fridge") == ours.events[0].objects_by_type("Fridge")


# -- the API surface -----------------------------------------------------------------------

def test_the_constructor_initialises_the_scene(kitchen: ThorCompatController) -> None:
    event = kitchen.last_event
    assert isinstance(event, MultiAgentEvent) and len(event.events) == 2
    assert [e.metadata["agentId"] for e in event.events] == [0, 1]
    assert event.metadata["lastAction"] == "Initialize" and bool(event)
    assert event.metadata["screenWidth"] == event.screen_width == 300


def test_step_takes_a_dict_or_keywords_alike(kitchen: ThorCompatController) -> None:
    action = {"action": "PickupObject", "objectId": KNIFE, "forceAction": True, "agentId": 1}
    by_dict = kitchen.step(action)
    assert action == {"action": "PickupObject", "objectId": KNIFE, "forceAction": True,
                      "agentId": 1}  # not changed
    other = ThorCompatController(make_config())
    by_keywords = other.step(action="PickupObject", objectId=KNIFE, forceAction=True, agentId=1)
    assert [e.metadata for e in by_dict.events] == [e.metadata for e in by_keywords.events]
    assert by_dict.metadata["agentId"] == 1  # a MultiAgentEvent's metadata: the acting agent's
    assert [o["objectId"] for o in agent_meta(by_dict, 1)["inventoryObjects"]] == [KNIFE]
    assert kitchen.last_event is by_dict and kitchen.last_action == action


def test_a_bare_rotation_becomes_ai2thors_rotation_dict(kitchen: ThorCompatController) -> None:
    pose = agent_meta(kitchen.last_event, 0)["agent"]["position"]
    kitchen.step(action="TeleportFull", x=pose["x"], y=pose["y"], z=pose["z"], rotation=270,
                 horizon=0, standing=True, agentId=0)
    assert kitchen.last_action["rotation"] == {"y": 270}
    assert agent_meta(kitchen.last_event, 0)["agent"]["rotation"]["y"] == 270


def test_a_single_agent_world_answers_with_an_event() -> None:
    controller = ThorCompatController(make_config(agents=1))
    event = controller.step("Pass")
    assert type(event) is Event and event.events == [event]
    assert event.metadata["lastAction"] == "Pass"


def test_events_are_snapshots(kitchen: ThorCompatController) -> None:
    before = kitchen.last_event
    kitchen.step(action="PickupObject", objectId=TOMATO, forceAction=True, agentId=0)
    assert agent_meta(before, 0)["inventoryObjects"] == []  # read after the change
    after = kitchen.last_event
    after.events[0].metadata["inventoryObjects"].clear()  # the client's copy, not the world's
    assert agent_meta(kitchen.step("Pass", agentId=0), 0)["inventoryObjects"] != []


def test_frames_are_rgb_arrays_of_the_moment(kitchen: ThorCompatController) -> None:
    first = kitchen.last_event
    fresh = ThorCompatController(make_config()).last_event
    kitchen.step(action="PickupObject", objectId=KNIFE, forceAction=True, agentId=0)
    frame = first.events[0].frame  # rendered now, from the moment it was returned
    assert frame.shape == (300, 300, 3) and frame.dtype == np.uint8
    assert np.array_equal(frame, fresh.events[0].frame)
    assert not np.array_equal(frame, kitchen.last_event.events[0].frame)
    assert np.array_equal(first.events[0].cv2img, frame[..., ::-1])


def test_width_height_and_render_image_parameters() -> None:
    controller = ThorCompatController(make_config(), width=400, height=320)
    assert controller.last_event.events[1].frame.shape == (320, 400, 3)
    event = controller.reset(renderImage=False)
    assert event.events[0].frame is None


# -- how it fails --------------------------------------------------------------------------

def test_invalid_actions_and_arguments_raise_after_storing_the_reply(
        kitchen: ThorCompatController) -> None:
    with pytest.raises(ValueError, match="Invalid action: Fly"):
        kitchen.step(action="Fly", agentId=1)
    md = kitchen.last_event.metadata
    assert (md["agentId"], md["lastActionSuccess"], md["errorCode"]) == (1, False, "InvalidAction")
    with pytest.raises(ValueError, match="Invalid arguments for TeleportFull"):
        kitchen.step(action="TeleportFull", x="here", z=0, standing=True, agentId=0)
    assert kitchen.last_event.metadata["errorCode"] == "InvalidArgument"


def test_an_ordinary_failure_is_returned_unless_raise_for_failure(
        kitchen: ThorCompatController) -> None:
    event = kitchen.step(action="PutObject", objectId=KNIFE, agentId=0)
    assert not event and event.metadata["errorMessage"] and event.metadata["errorCode"] == ""
    with pytest.raises(RuntimeError, match=event.metadata["errorMessage"][:20]):
        kitchen.step(action="PutObject", objectId=KNIFE, agentId=0, raise_for_failure=True)


def test_an_agent_id_out_of_range_is_refused(kitchen: ThorCompatController) -> None:
    before = kitchen.last_event
    with pytest.raises(ValueError, match="agentId 5 out of range for 2 agents"):
        kitchen.step(action="Pass", agentId=5)
    assert kitchen.last_event is before


def test_another_scene_is_not_in_the_build(kitchen: ThorCompatController) -> None:
    with pytest.raises(ValueError, match="Scene 'FloorPlan2' not contained in build"):
        kitchen.reset(scene="FloorPlan2")
    assert kitchen.reset(scene="TestKitchen").metadata["lastAction"] == "Initialize"


def test_floorplan_names_load_with_or_without_physics_suffix() -> None:
    config = make_config(scene="FloorPlan1")
    assert ThorCompatController(config, scene="FloorPlan1_physics").scene == "FloorPlan1"


@pytest.mark.parametrize(("params", "message"), [
    ({"agentCount": 3}, "agentCount=3: the embedded world of .* has agentCount=2"),
    ({"visibilityDistance": 5.0}, "visibilityDistance=5.0"),
    ({"renderDepthImage": True}, "renderDepthImage: the embedded world renders RGB frames only"),
    ({"continuousMode": True}, "unsupported initialization parameter 'continuousMode'"),
])
def test_parameters_the_world_cannot_honour_are_refused(params: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ThorCompatController(make_config(), **params)


def test_a_refused_reset_changes_nothing(kitchen: ThorCompatController) -> None:
    before = kitchen.last_event
    with pytest.raises(ValueError, match="agentCount=9"):
        kitchen.reset(width=500, renderImage=False, agentCount=9)
    assert (kitchen.width, kitchen.initialization_parameters["renderImage"]) == (300, True)
    assert kitchen.last_event is before


def test_a_bad_config_names_the_field() -> None:
    raw = make_config().to_json_dict()
    del raw["init_state"]
    with pytest.raises(ValueError, match="init_state"):
        ThorCompatController(raw)


def test_a_stopped_controller_refuses_work() -> None:
    with ThorCompatController(make_config()) as controller:
        controller.step("Pass")
    for call in (lambda: controller.step("Pass"), controller.reset):
        with pytest.raises(RuntimeError, match="was stopped"):
            call()


def test_it_works_without_ai2thor_installed() -> None:
    script = textwrap.dedent("""
        import sys

        class NoAi2thor:
            def find_spec(self, name, path=None, target=None):
                if name == "ai2thor" or name.startswith("ai2thor."):
                    raise ImportError("ai2thor is not installed")

        sys.meta_path.insert(0, NoAi2thor())
        from benchmark_adapter.sim.embedded import ThorCompatController
        from tests.core.worlds import make_config

        controller = ThorCompatController(make_config())
        event = controller.step(action="RotateLeft", agentId=1)
        assert event.events[1].frame.shape == (300, 300, 3)
        assert not any(m.startswith("ai2thor") for m in sys.modules)
        print(event.metadata["lastAction"], event.metadata["agentId"])
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         cwd=REPO)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["RotateLeft", "1"]

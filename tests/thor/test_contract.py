"""The thor adapter over ai2thor's own Controller/Event code, with a fake Unity (no Unity).

Covers `check_controller`, what crosses the wire to "Unity" (Initialize parameters, agentId,
scene reloads), the Open/Close last-event workaround, ai2thor's ValueError replies, plain
metadata, frames, and one AI2-THOR process reused across episodes.
"""

from __future__ import annotations

import io

import pytest
from PIL import Image

from benchmark_adapter.sim.conformance import check_controller
from benchmark_adapter.sim.embedded import EmbeddedController

from .conftest import needs_data, shared_config

pytestmark = [pytest.mark.needs_thor, needs_data]
FOUR_AGENTS = "G_D1__FloorPlan224__4agent_seed0.json"


def first(metadata, flag: str) -> str:
    return next(o["objectId"] for o in metadata[0]["objects"] if o.get(flag))


@pytest.mark.parametrize("name", ["A_D1__FloorPlan1__seed0.json", FOUR_AGENTS])
def test_check_controller_passes_over_the_fake_server(make_thor, name):
    config = shared_config(name)
    check_controller(lambda: make_thor(config))


def test_reset_reloads_the_scene_and_initializes_from_the_config(make_thor, library):
    config = shared_config(FOUR_AGENTS)
    ctl = make_thor(config)
    ctl.reset()
    ctl.reset()
    server = library.servers[0]
    names = [a["action"] for a in server.sent]
    # Controller() loads the scene once; every reset() reloads it before Initialize.
    assert names.count("Reset") == 3 and names.count("Initialize") == 3
    assert all(names[i + 1] == "Initialize" for i, n in enumerate(names) if n == "Reset")
    assert {a["sceneName"] for a in server.sent if a["action"] == "Reset"} == {
        "FloorPlan224_physics"
    }
    assert server.init_params[-1] == {
        "agentMode": "default",
        "agentCount": 4,
        "gridSize": 0.25,
        "visibilityDistance": 1.5,
        "renderImage": True,
    }


def test_controller_is_built_with_reference_arguments(make_thor, library):
    ctl = make_thor(shared_config(), width=128, height=640, quality="Low")
    ctl.reset()
    thor = ctl._session.controller
    assert (thor.width, thor.height) == (300, 640)  # never below 300 (reference env.py)
    assert thor.quality == "Low"
    assert thor.server_timeout == 100.0


def test_native_actions_carry_the_agent_id_over_the_wire(make_thor, library):
    config = shared_config()
    ctl = make_thor(config)
    md = ctl.reset()
    target = first(md, "receptacle")
    ctl.step("GetInteractablePoses", agentId=1, objectId=target)
    pose = ctl.last_metadata()[1]["actionReturn"][0]
    md = ctl.step("TeleportFull", agentId=1, **pose)
    wire = library.servers[0].sent[-1]
    assert wire["agentId"] == 1
    assert wire["rotation"] == {"y": pose["rotation"]}  # ai2thor's own float → dict conversion
    assert md[1]["lastActionSuccess"], md[1]["errorMessage"]
    assert md[1]["agent"]["position"]["x"] == pose["x"]


def test_open_and_close_see_the_acting_agents_event_first(make_thor):
    config = shared_config()
    ctl = make_thor(config)
    md = ctl.reset()
    openable = first(md, "openable")
    ctl.step("OpenObject", agentId=1, objectId=openable, forceAction=True)
    ctl.step("CloseObject", agentId=0, objectId=openable, forceAction=True)
    ctl.step("Pass", agentId=1)
    seen = ctl._session.controller.steps_seen[-3:]
    # (action, agentId of the controller's last_event when step() was called; None = multi)
    assert seen == [("OpenObject", 1), ("CloseObject", 0), ("Pass", None)]


def test_invalid_actions_fail_like_any_action_instead_of_raising(make_thor):
    ctl = make_thor(shared_config())
    ctl.reset()
    md = ctl.step("NoSuchAction", agentId=1)  # ai2thor raises ValueError on InvalidAction
    assert md[1]["lastActionSuccess"] is False
    assert md[1]["errorMessage"] == "Invalid action: NoSuchAction"
    md = ctl.step("TeleportFull", agentId=0, standing=True)  # InvalidArgument
    assert md[0]["lastActionSuccess"] is False and "Invalid arguments" in md[0]["errorMessage"]
    assert ctl.step("Pass", agentId=0)[0]["lastActionSuccess"] is True  # still alive


def test_agent_id_out_of_range_is_refused(make_thor):
    ctl = make_thor(shared_config())
    ctl.reset()
    with pytest.raises(ValueError, match="out of range"):
        ctl.step("Pass", agentId=2)


def test_metadata_is_plain_data_equal_to_the_embedded_worlds(make_thor):
    config = shared_config()
    ctl, sim = make_thor(config), EmbeddedController(config)
    thor_md, sim_md = ctl.reset(), sim.reset()

    def builtin_only(value) -> bool:
        if type(value) is dict:
            return all(type(k) is str and builtin_only(v) for k, v in value.items())
        if type(value) is list:
            return all(builtin_only(v) for v in value)
        return type(value) in (str, int, float, bool, type(None))

    assert all(type(md) is dict and builtin_only(md) for md in thor_md)
    keys = [k for k in sim_md[0] if k != "lastAction"]  # Unity's reply says "Initialize"
    for thor_agent, sim_agent in zip(thor_md, sim_md):
        assert {k: thor_agent[k] for k in keys} == {k: sim_agent[k] for k in keys}


def test_frames_are_pngs_of_the_agents_rgb_image(make_thor):
    ctl = make_thor(shared_config(), width=320, height=300)
    ctl.reset()
    image = Image.open(io.BytesIO(ctl.frame(1, 320, 300))).convert("RGBA")
    assert image.size == (320, 300)
    from .fake_unity import test_pattern  # needs ai2thor: imported once the test runs

    expected = Image.fromarray(test_pattern(1, 320, 300))
    assert image.tobytes() == expected.tobytes()  # right way up, agent 1's own frame
    small = Image.open(io.BytesIO(ctl.frame(0, 64, 48)))
    assert small.size == (64, 48)


def test_frames_match_the_embedded_renderer_through_the_wire(make_thor, library):
    library.render = True
    config = shared_config()
    ctl, sim = make_thor(config), EmbeddedController(config)
    ctl.reset()
    sim.reset()
    for agent in range(2):
        thor = Image.open(io.BytesIO(ctl.frame(agent))).convert("RGB")
        embedded = Image.open(io.BytesIO(sim.frame(agent, 300, 300))).convert("RGB")
        assert thor.tobytes() == embedded.tobytes()


def test_one_ai2thor_process_serves_consecutive_episodes(make_thor, library, pool):
    two, four = shared_config(), shared_config(FOUR_AGENTS)
    with make_thor(two) as ctl:
        assert len(ctl.reset()) == 2
    with make_thor(four) as ctl:
        assert len(ctl.reset()) == 4  # reconfigured by a reset: new scene, new agentCount
    assert len(library.servers) == 1 and len(pool) == 1
    assert library.servers[0].init_params[-1]["agentCount"] == 4
    assert library.servers[0].stops == 0


def test_without_reuse_stop_shuts_ai2thor_down(make_thor, library, pool):
    ctl = make_thor(shared_config(), reuse=False)
    ctl.reset()
    ctl.stop()
    ctl.stop()  # idempotent
    assert library.servers[0].stops == 1 and len(pool) == 0

"""A fake AI2-THOR server: ai2thor's own Python code with Unity replaced by the embedded world.

`FakeUnityController` is ai2thor 5.0's real `Controller` (its `__init__`, `start`, `reset`,
`step`, `stop`) with one seam changed: `_build_server` installs `EmbeddedUnityServer`, an
`ai2thor.server.Server` whose `send`/`receive` answer like Unity would. Replies cross a
wire: actions go through JSON (as the FIFO server sends them) and metadata through msgpack
(as Unity answers), then ai2thor's `Server.create_event` builds the `Event`s and the
`MultiAgentEvent`, including the RGB frames from raw, bottom-up pixel buffers.

Only importable when ai2thor is installed.
"""

from __future__ import annotations

import functools
import io
import json
from collections.abc import Callable, Mapping
from typing import Any

import msgpack
import numpy as np
from ai2thor.controller import Controller
from ai2thor.server import NumpyAwareEncoder, Server
from PIL import Image

from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.actions import HANDLERS
from benchmark_adapter.sim.thor.launch import controller_kwargs
from benchmark_adapter.sim.thor.options import ThorOptions
from benchmark_adapter.tasks import TaskConfig

# Keys of Unity's per-agent metadata that the embedded world does not produce.
UNITY_KEYS = {"thirdPartyCameras": None, "colors": [], "isSceneAtRest": True, "errorCode": ""}
META_ACTIONS = frozenset({"GetScenesInBuild", "Reset", "ChangeQuality", "ChangeResolution"})
WIRE_ONLY = ("action", "agentId", "sequenceId")


class SceneLibrary:
    """The scenes the fake Unity can load: ai2thor scene name → task config."""

    def __init__(self, render: bool = False) -> None:
        self.configs: dict[str, TaskConfig] = {}
        self.render = render  # frames from the embedded renderer (slow) or flat test patterns
        self.servers: list[EmbeddedUnityServer] = []

    def add(self, config: TaskConfig) -> TaskConfig:
        """Make `config`'s scene loadable (the last config added for a scene wins)."""
        scene = config.init_state.controller_init.scene or config.scene_id
        self.configs[Controller.normalize_scene(scene)] = config
        return config


class EmbeddedUnityServer(Server):
    """Answers ai2thor's messages with the embedded simulator, as Unity's FIFO server would."""

    server_type = "FIFO"

    def __init__(self, library: SceneLibrary, width: int, height: int) -> None:
        super().__init__(width=width, height=height, timeout=None)
        self.library, self.width, self.height = library, width, height
        self.sent: list[dict[str, Any]] = []  # every action, as it crossed the wire
        self.init_params: list[dict[str, Any]] = []
        self.fail_on: dict[str, BaseException] = {}  # action name → raised while "waiting"
        self.stops = 0
        self.scene: str | None = None
        self.sim: EmbeddedController | None = None
        self._pending: list[dict[str, Any]] = []

    # -- ai2thor's server interface -------------------------------------------------------

    def start(self) -> None:
        self.started = True

    def stop(self) -> None:
        self.stops += 1
        self.started = False

    def send(self, action: dict[str, Any]) -> None:
        # Sequence ids as ai2thor's FifoServer numbers them.
        if "sequenceId" in action:
            self.sequence_id = action["sequenceId"]
        else:
            self.sequence_id += 1
            action["sequenceId"] = self.sequence_id
        wire = json.loads(json.dumps(action, cls=NumpyAwareEncoder))
        self.sent.append(wire)
        self._pending.append(wire)

    def receive(self, timeout: float | None = None) -> Any:
        action = self._pending.pop(0) if self._pending else None  # None: Unity's first hello
        if action is not None and action["action"] in self.fail_on:
            raise self.fail_on.pop(action["action"])
        agents, active = self._answer(action)
        metadata = {
            "agents": agents,
            "activeAgentId": active,
            "sequenceId": self.sequence_id,
            "thirdPartyCameras": None,
        }
        metadata = msgpack.unpackb(msgpack.packb(metadata), raw=False, strict_map_key=False)
        files = {"image": [self._image(i) for i in range(len(agents))]}
        return self.create_event(metadata, files)

    # -- Unity's side ---------------------------------------------------------------------

    def _answer(self, action: Mapping[str, Any] | None) -> tuple[list[dict[str, Any]], int]:
        if action is None:
            return [self._idle_agent()], 0
        name, agent = action["action"], int(action.get("agentId", 0))
        if name == "Initialize":
            return self._initialize(action), 0
        if name in META_ACTIONS:
            return self._meta_action(name, action, agent), agent
        if self.sim is None:
            raise AssertionError(f"{name} sent before Initialize")
        args = {k: v for k, v in action.items() if k not in WIRE_ONLY}
        agents = [self._wire(md) for md in self.sim.step(name, agentId=agent, **args)]
        agents[agent]["errorCode"] = _error_code(name, agents[agent]["errorMessage"])
        return agents, agent

    def _initialize(self, action: Mapping[str, Any]) -> list[dict[str, Any]]:
        params = {k: v for k, v in action.items() if k not in WIRE_ONLY}
        self.init_params.append(params)
        config = self.library.configs[self.scene]
        self.sim = EmbeddedController(config)
        self.sim.agent_count = int(params.get("agentCount", 1))
        agents = [self._wire(md) for md in self.sim.reset()]
        for md in agents:
            md.update(lastAction="Initialize", actionReturn=None)
        return agents

    def _meta_action(self, name: str, action: Mapping[str, Any], agent: int) -> list[dict]:
        if name == "Reset":
            self.scene, self.sim = action["sceneName"], None
        agents = [self._idle_agent()] if self.sim is None else self._snapshot()
        result = sorted(self.library.configs) if name == "GetScenesInBuild" else None
        agents[min(agent, len(agents) - 1)].update(
            lastAction=name, lastActionSuccess=True, errorMessage="", actionReturn=result
        )
        return agents

    def _snapshot(self) -> list[dict[str, Any]]:
        assert self.sim is not None
        return [self._wire(md) for md in self.sim.last_metadata()]

    def _wire(self, md: Mapping[str, Any]) -> dict[str, Any]:
        return {
            **md,
            **UNITY_KEYS,
            "screenWidth": self.width,
            "screenHeight": self.height,
        }

    def _idle_agent(self) -> dict[str, Any]:
        pose = {"x": 0.0, "y": 0.9, "z": 0.0}
        return self._wire({
            "agentId": 0,
            "sceneName": self.scene or "",
            "agent": {
                "name": "agent",
                "position": pose,
                "rotation": {"x": 0.0, "y": 0.0, "z": 0.0},
                "cameraHorizon": 0.0,
                "isStanding": True,
            },
            "objects": [],
            "inventoryObjects": [],
            "lastAction": "",
            "lastActionSuccess": True,
            "errorMessage": "",
            "actionReturn": None,
        })

    def _image(self, agent: int) -> bytes:
        """RGBA pixels, bottom row first, as Unity's CloudRendering sends them."""
        if self.library.render and self.sim is not None:
            png = self.sim.frame(agent, self.width, self.height)
            rgba = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
            return _bottom_up(rgba)
        return _flat_frame(agent, self.width, self.height)


@functools.cache
def test_pattern(agent: int, width: int, height: int) -> np.ndarray:
    """A frame whose top half and bottom half differ (so a flipped frame is caught)."""
    rgba = np.full((height, width, 4), 255, dtype=np.uint8)
    rgba[: height // 2, :, :3] = (200, 40 * agent % 256, 10)
    rgba[height // 2 :, :, :3] = (10, 40 * agent % 256, 200)
    return rgba


@functools.cache
def _flat_frame(agent: int, width: int, height: int) -> bytes:
    return _bottom_up(test_pattern(agent, width, height))


def _bottom_up(rgba: np.ndarray) -> bytes:
    return np.flipud(rgba).tobytes()


test_pattern.__test__ = False  # type: ignore[attr-defined]  # not a pytest test


def _error_code(action: str, error: str) -> str:
    # Unity's error codes for the replies ai2thor turns into ValueError.
    if action not in HANDLERS:
        return "InvalidAction"
    if error.startswith("Invalid arguments"):
        return "InvalidArgument"
    return ""


class FakeUnityController(Controller):
    """ai2thor's `Controller`, started against `EmbeddedUnityServer` instead of Unity."""

    def __init__(self, library: SceneLibrary, **kwargs: Any) -> None:
        self._library = library
        self.steps_seen: list[tuple[str, Any]] = []  # (action, last_event's agentId) per step
        super().__init__(start_unity=False, **kwargs)

    def _build_server(self, host: str, port: int, width: int, height: int) -> None:
        if self.server is None:
            self.server = EmbeddedUnityServer(self._library, width, height)
            self._library.servers.append(self.server)

    def step(self, action: Any = None, **action_args: Any) -> Any:
        name = action.get("action") if isinstance(action, dict) else action
        focus = getattr(self.last_event, "metadata", {}).get("agentId")
        multi = hasattr(self.last_event, "_active_event")
        self.steps_seen.append((name, None if multi else focus))
        return super().step(action, **action_args)


def fake_factory(library: SceneLibrary) -> Callable[[ThorOptions, str, Mapping[str, Any]], Any]:
    """A `ThorController` factory: the production `controller_kwargs`, a fake Unity."""

    def factory(options: ThorOptions, scene: str, init: Mapping[str, Any]) -> Any:
        return FakeUnityController(
            library, **controller_kwargs(options, scene, init, "CloudRendering")
        )

    return factory

"""`ThorCompatController`: ai2thor 5.0's `Controller` API over the embedded world.

Code written against ai2thor (`reset(scene=…)`, `step(dict(action=…, agentId=…))` or
`step(action=…, …)`, `last_event`, `stop()`) runs offline on the world grounded from one task
config, without ai2thor installed. docs/embedded-simulator.md lists the covered subset.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Mapping, Sequence
from typing import Any

from benchmark_adapter.sim.embedded.actions import HANDLERS
from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.sim.embedded.thor_events import (
    Event,
    MultiAgentEvent,
    plain_copy,
    render_frame,
)
from benchmark_adapter.tasks.config import TaskConfig

# Error codes for which ai2thor's `step` raises ValueError (after storing `last_event`).
RAISING_ERROR_CODES = frozenset(
    {"InvalidAction", "MissingArguments", "AmbiguousAction", "InvalidArgument"}
)
# Keys of Unity's per-agent metadata the embedded world has no source for.
UNITY_KEYS = {"errorCode": "", "isSceneAtRest": True, "thirdPartyCameras": None, "colors": []}
# What Unity reports for every agent after `Initialize`.
INITIALIZED = {"lastAction": "Initialize", "lastActionSuccess": True, "errorMessage": "",
               "actionReturn": None}
# ai2thor `Controller` options that launch or tune Unity: meaningless for an in-process world.
LAUNCH_OPTIONS = frozenset({
    "quality", "fullscreen", "headless", "port", "start_unity", "local_executable_path",
    "local_build", "commit_id", "branch", "x_display", "host", "image_dir",
    "save_image_per_frame", "depth_format", "add_depth_noise", "download_only",
    "include_private_scenes", "server_class", "gpu_device", "platform", "server_timeout",
    "server_start_timeout", "fastActionEmit", "snapToGrid",
})
# Image kinds the embedded world cannot render: asking for one is an error, not a None frame.
UNRENDERED = ("renderDepthImage", "renderInstanceSegmentation", "renderSemanticSegmentation",
              "renderNormalsImage", "renderFlowImage", "renderClassImage", "renderObjectImage")


class ThorCompatController:
    """The embedded world of one task config behind `ai2thor.controller.Controller`'s API.

    As ai2thor's, the constructor initialises the scene (`last_event` is ready), `step`
    returns an `Event` (one agent) or `MultiAgentEvent` (several) and raises ValueError for
    an invalid action or argument, after storing the reply in `last_event`. The scene and
    the agents come from the config; initialization parameters that contradict it, or ask
    for images the world cannot render, raise ValueError.
    """

    def __init__(self, config: TaskConfig | Mapping[str, Any], **init_params: Any) -> None:
        self.config = (config if isinstance(config, TaskConfig)
                       else TaskConfig.model_validate(dict(config)))
        init = self.config.init_state.controller_init
        self.scene = init.scene or self.config.scene_id
        self.width = self.height = 300
        self.initialization_parameters: dict[str, Any] = {
            "agentMode": "default",
            "agentCount": init.agentCount or self.config.agent_count,
            "gridSize": init.gridSize,
            "visibilityDistance": init.visibilityDistance,
            "renderImage": True,
        }
        self.last_event: Event | MultiAgentEvent | None = None
        self.last_action: dict[str, Any] | None = None
        self._sim: EmbeddedController | None = EmbeddedController(self.config)
        self.reset(init_params.pop("scene", None), **init_params)

    def reset(self, scene: str | None = None, **init_params: Any) -> Event | MultiAgentEvent:
        """Reload the scene (the config's: another name raises ValueError) and initialise it."""
        sim = self._running()
        if scene is not None and _normalize(scene) != _normalize(self.scene):
            raise ValueError(
                f"Scene {scene!r} not contained in build: this ThorCompatController holds "
                f"only {self.config.task_id}'s scene {self.scene!r}"
            )
        self._initialize(init_params)
        self.last_event = self._event(sim.reset(), 0, INITIALIZED)
        return self.last_event

    def step(self, action: str | Mapping[str, Any] | None = None,
             **action_args: Any) -> Event | MultiAgentEvent:
        """Run one native action (`agentId` picks the agent); return every agent's event."""
        sim = self._running()
        payload = (copy.deepcopy(dict(action)) if isinstance(action, Mapping)
                   else {"action": action})
        raise_for_failure = action_args.pop("raise_for_failure", False)
        payload.update(copy.deepcopy(action_args))
        rotation = payload.get("rotation")
        if rotation is not None and not isinstance(rotation, Mapping):
            payload["rotation"] = {"y": rotation}  # as ai2thor converts a bare yaw
        self.last_action = payload
        name, agent = payload.get("action"), payload.get("agentId")
        arguments = {k: v for k, v in payload.items() if k not in ("action", "agentId")}
        metadata = sim.step(name, agentId=agent, **arguments)
        active = 0 if agent is None else int(agent)
        code = _error_code(name, metadata[active]["errorMessage"])
        self.last_event = self._event(metadata, active, {}, {active: code})
        outcome = metadata[active]
        if code in RAISING_ERROR_CODES:
            raise ValueError(outcome["errorMessage"])
        if raise_for_failure and not outcome["lastActionSuccess"]:
            raise RuntimeError(outcome["errorMessage"] or f"{payload} failed")
        return self.last_event

    def stop(self) -> None:
        """Release the world; any later `reset` or `step` raises RuntimeError."""
        if self._sim is not None:
            self._sim.stop()
        self._sim = None

    def __enter__(self) -> ThorCompatController:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.stop()

    # -- internals ------------------------------------------------------------------------

    def _running(self) -> EmbeddedController:
        if self._sim is None:
            raise RuntimeError("ThorCompatController was stopped; make a new one")
        return self._sim

    def _initialize(self, params: dict[str, Any]) -> None:
        """Check, then record, initialization parameters (ai2thor's `reset` merges them)."""
        params = dict(params)
        size = int(params.pop("width", self.width)), int(params.pop("height", self.height))
        render = bool(params.pop("renderImage", self.initialization_parameters["renderImage"]))
        for name, value in params.items():
            if name in LAUNCH_OPTIONS:
                continue
            if name in UNRENDERED:
                if value:
                    raise ValueError(f"{name}: the embedded world renders RGB frames only")
            elif name in self.initialization_parameters:
                fixed = self.initialization_parameters[name]
                if value != fixed:
                    raise ValueError(
                        f"{name}={value!r}: the embedded world of {self.config.task_id} has "
                        f"{name}={fixed!r} (from its task config)"
                    )
            else:
                raise ValueError(
                    f"unsupported initialization parameter {name!r} for ThorCompatController"
                )
        self.width, self.height = size
        self.initialization_parameters["renderImage"] = render

    def _event(self, metadata: Sequence[Mapping[str, Any]], active: int,
               overrides: Mapping[str, Any],
               codes: Mapping[int, str] | None = None) -> Event | MultiAgentEvent:
        w, h = self.width, self.height
        base = {**UNITY_KEYS, "screenWidth": w, "screenHeight": h, **overrides}
        params = self.initialization_parameters
        events = []
        for i, md in enumerate(metadata):
            extra = {**base, "errorCode": (codes or {}).get(i, "")}
            render = (functools.partial(render_frame, metadata, i, params["visibilityDistance"],
                                        w, h) if params["renderImage"] else None)
            events.append(Event(functools.partial(plain_copy, md, extra), render, w, h))
        return events[0] if len(events) == 1 else MultiAgentEvent(active, events)


def _normalize(scene: str) -> str:
    # ai2thor loads FloorPlanN as FloorPlanN_physics.
    return scene.removesuffix("_physics")


def _error_code(action: Any, error: str) -> str:
    """Unity's `errorCode` for the replies ai2thor turns into ValueError."""
    if action not in HANDLERS:
        return "InvalidAction"
    if error.startswith("Invalid arguments"):
        return "InvalidArgument"
    return ""

"""Events shaped like ai2thor 5.0's `Event` and `MultiAgentEvent`, without ai2thor.

`ThorCompatController` returns these. Attribute names and types follow `ai2thor.server`:
an `Event` per agent (`metadata` dict, `frame` HxWx3 uint8 array, `cv2img`, `events == [self]`,
truthy iff the action succeeded) and, with several agents, a `MultiAgentEvent` whose `metadata`
is the acting agent's and whose `events[i]` is agent i's. Depth, segmentation and third-party
camera attributes exist with ai2thor's empty values: the embedded world renders RGB only.

Both are snapshots: `metadata` is copied (as plain JSON data, like Unity's reply) and `frame`
rendered from the moment the action returned, on first access.
"""

from __future__ import annotations

import io
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import orjson

from benchmark_adapter.sim.embedded.world import AGENT_Y

FIELD_OF_VIEW = 90


class Event:
    """One agent's result of an action, as `ai2thor.server.Event`."""

    def __init__(self, metadata: Callable[[], dict[str, Any]], frame: Callable[[], Any] | None,
                 width: int, height: int) -> None:
        self._load_metadata: Callable[[], dict[str, Any]] | None = metadata
        self._metadata: dict[str, Any] | None = None
        self._render = frame
        self._frame: Any = None
        self.screen_width, self.screen_height = width, height
        self.depth_frame = self.normals_frame = self.flow_frame = None
        self.instance_segmentation_frame = self.semantic_segmentation_frame = None
        self.instance_detections2D = None
        self.instance_masks: dict[str, Any] = {}
        self.class_masks: dict[str, Any] = {}
        self.class_detections2D: dict[str, Any] = {}
        self.color_to_object_id: dict[Any, str] = {}
        self.object_id_to_color: dict[str, Any] = {}
        self.third_party_camera_frames: list[Any] = []
        self.third_party_depth_frames: list[Any] = []
        self.third_party_normals_frames: list[Any] = []
        self.third_party_flows_frames: list[Any] = []
        self.third_party_instance_segmentation_frames: list[Any] = []
        self.third_party_semantic_segmentation_frames: list[Any] = []
        self.third_party_instance_masks: list[Any] = []
        self.third_party_class_masks: list[Any] = []
        self.events = [self]  # as ai2thor: a single-agent event lists itself

    @property
    def metadata(self) -> dict[str, Any]:
        """This agent's metadata (a plain dict in AI2-THOR's schema)."""
        if self._metadata is None:
            assert self._load_metadata is not None
            self._metadata, self._load_metadata = self._load_metadata(), None
        return self._metadata

    @property
    def frame(self) -> Any:
        """RGB frame (height × width × 3, uint8), or None when `renderImage` is off."""
        if self._frame is None and self._render is not None:
            self._frame, self._render = self._render(), None
        return self._frame

    @property
    def cv2img(self) -> Any:
        """The frame in OpenCV's BGR channel order."""
        return self.frame[..., ::-1]

    def objects_by_type(self, object_type: str) -> list[dict[str, Any]]:
        """This agent's object records of one `objectType`."""
        return [o for o in self.metadata["objects"] if o["objectType"] == object_type]

    def __bool__(self) -> bool:
        return bool(self.metadata["lastActionSuccess"])

    def __repr__(self) -> str:
        md = self.metadata
        action_return = str(md["actionReturn"])
        if len(action_return) > 100:
            action_return = action_return[:100] + "..."
        error = str(md["errorMessage"]).replace("\n", " ")
        return (f"<{type(self).__module__}.Event at {hex(id(self))}\n"
                f'    .metadata["lastAction"] = {md["lastAction"]}\n'
                f'    .metadata["lastActionSuccess"] = {md["lastActionSuccess"]}\n'
                f'    .metadata["errorMessage"] = "{error}\n'
                f'    .metadata["actionReturn"] = {action_return}\n>')

    __str__ = __repr__


class MultiAgentEvent:
    """Every agent's result of one action, as `ai2thor.server.MultiAgentEvent`."""

    def __init__(self, active_agent_id: int, events: Sequence[Event]) -> None:
        self._active_event = events[active_agent_id]
        self.screen_width = self._active_event.screen_width
        self.screen_height = self._active_event.screen_height
        self.events = list(events)
        self.third_party_camera_frames: list[Any] = []

    @property
    def metadata(self) -> dict[str, Any]:
        """The acting agent's metadata."""
        return self._active_event.metadata

    @property
    def cv2img(self) -> Any:
        """The acting agent's frame, BGR."""
        return self._active_event.cv2img

    def __bool__(self) -> bool:
        return bool(self._active_event)


def plain_copy(metadata: Mapping[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of `metadata` in JSON types (as Unity's reply arrives), plus `extra`."""
    return {**orjson.loads(orjson.dumps(dict(metadata))), **extra}


def render_frame(metadata: Sequence[Mapping[str, Any]], agent: int, visibility_distance: float,
                 width: int, height: int) -> Any:
    """Agent `agent`'s frame as an RGB array, drawn from the metadata snapshot `metadata`."""
    # Imported on first use: most clients never read a frame.
    import numpy
    from PIL import Image

    from benchmark_adapter.sim.embedded.render import render_agent_frame

    own = metadata[agent]
    view = {
        "agent": own["agent"],
        "visibilityDistance": visibility_distance,
        "fieldOfView": FIELD_OF_VIEW,
        "objects": own["objects"],
        "inventoryObjects": own["inventoryObjects"],
        "otherAgents": [
            {"name": md["agent"]["name"],
             "position": {**md["agent"]["position"], "y": AGENT_Y},
             "rotation": md["agent"]["rotation"]}
            for i, md in enumerate(metadata) if i != agent
        ],
    }
    png = render_agent_frame(view, width, height)
    image = Image.open(io.BytesIO(png)).convert("RGB")
    if image.size != (width, height):  # the renderer draws at least 300×300
        image = image.resize((width, height), Image.Resampling.BILINEAR)
    return numpy.asarray(image)

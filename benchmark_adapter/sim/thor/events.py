"""Reading ai2thor events: per-agent metadata as plain dicts, frames as PNG.

Nothing returned here refers to an ai2thor object: metadata is copied into builtin types
(ai2thor hands out `MetadataWrapper` dicts and numpy scalars), frames are encoded to bytes.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from typing import Any


def agent_events(event: Any) -> list[Any]:
    """The per-agent events of a (multi-agent) event; a single-agent `Event` lists itself."""
    return list(getattr(event, "events", None) or [event])


def agent_metadata(event: Any) -> list[dict[str, Any]]:
    """Every agent's metadata, as plain data."""
    return [plain(e.metadata) for e in agent_events(event)]


def plain(value: Any) -> Any:
    """A deep copy of `value` made of dicts, lists, str, int, float, bool and None."""
    kind = type(value)
    if kind in _LEAVES:
        return value
    # Leaves are tested inline: metadata is mostly scalars, and this runs on every step.
    if isinstance(value, Mapping):
        return {str(k): v if type(v) in _LEAVES else plain(v) for k, v in value.items()}
    if kind is list or kind is tuple:
        return [v if type(v) in _LEAVES else plain(v) for v in value]
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return plain(value.tolist())
    for base in (bool, int, float, str):  # subclasses (an IntEnum, a str subclass) → base
        if isinstance(value, base):
            return base(value)
    return str(value)


_LEAVES = frozenset({str, int, float, bool, type(None)})


def frame_png(event: Any, agent: int, width: int, height: int) -> bytes:
    """PNG of agent `agent`'s RGB frame, resized to width×height when it differs."""
    from PIL import Image

    events = agent_events(event)
    if not 0 <= agent < len(events):
        raise ValueError(f"agent {agent} out of range for {len(events)} agents")
    frame = events[agent].frame
    if frame is None:
        raise RuntimeError("AI2-THOR returned no image (renderImage is off for this controller)")
    image = Image.fromarray(_contiguous(frame)).convert("RGB")
    if image.size != (width, height):
        image = image.resize((width, height), Image.Resampling.BILINEAR)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _contiguous(frame: Any) -> Any:
    # ai2thor's frames are flipped views of the message buffer; Pillow needs contiguous memory.
    import numpy

    return numpy.ascontiguousarray(frame)

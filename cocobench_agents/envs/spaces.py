"""The Gymnasium spaces of a seat, and its observation encoded in them.

A seat's action is a menu id (the id its prompt shows; ids start at 0) or `DONE` (-1):
``Discrete(max_menu + 2, start=-1)``. A seat that broadcasts (D1's robots, leader–worker's
robots and leader) acts with ``{"action": id, "message": text}``. The observation is a dict:
``prompt`` (the harness's prompt text), ``menu`` (its menu lines), ``action_mask`` (entry 0
for DONE, entry ``id + 1`` for each id on the menu: the mask ``Discrete(…, start=-1)``
samples with; for a broadcasting seat ``{"action": mask, "message": (length, characters)}``,
the message part being the mask Gymnasium's ``Text.sample`` takes: ``(0, zeros)`` when the
seat sends no message now), and under image conditions ``frame``: the seat's camera frame as
an RGB array (the team's seat and the leader: every robot's frame, ``(robots, H, W, 3)``).
"""

from __future__ import annotations

import io
import string
from typing import Any

import numpy as np
from gymnasium import spaces
from PIL import Image

from cocobench_agents.envs.seated import DONE, EnvError, SeatAction, SeatView
from cocobench_agents.graphs.registry import LEADER_SEAT, TEAM_SEAT
from cocobench_agents.prompts.parse import MESSAGE_LIMIT

#: The characters a sampled message is drawn from (any text is accepted).
MESSAGE_CHARS = string.ascii_letters + string.digits + " .,:;!?'-_()"
#: How long a message `Text.sample` draws under the mask is.
SAMPLE_LENGTH = 16
#: The longest prompt or menu an observation holds, in characters.
TEXT_LIMIT = 1_000_000
#: The longest instruction text the leader sends.
LEADER_LIMIT = 4_000


class AnyText(spaces.Text):
    """A `Text` space that contains any string up to its length (prompts hold characters
    outside any fixed charset); samples draw from `MESSAGE_CHARS`."""

    def __init__(self, max_length: int) -> None:
        super().__init__(max_length, min_length=0, charset=MESSAGE_CHARS)

    def contains(self, x: Any) -> bool:
        return isinstance(x, str) and len(x) <= self.max_length


class SeatSpaces:
    """The spaces of one seat and the encoding of its views."""

    def __init__(self, seat: str, *, max_menu: int, broadcasts: bool,
                 image_shape: tuple[int, ...] | None) -> None:
        self.seat, self.max_menu, self.broadcasts = seat, max_menu, broadcasts
        self.image_shape = image_shape
        size = max_menu + 2  # DONE, then ids 0..max_menu
        choice = spaces.Discrete(size, start=DONE)
        if broadcasts:
            limit = LEADER_LIMIT if seat == LEADER_SEAT else MESSAGE_LIMIT
            self.action = spaces.Dict({"action": choice, "message": AnyText(limit)})
            mask: spaces.Space = spaces.Dict({
                "action": spaces.MultiBinary(size),
                "message": spaces.Tuple((spaces.Discrete(SAMPLE_LENGTH + 1),
                                         spaces.MultiBinary(len(MESSAGE_CHARS))))})
        else:
            self.action = choice
            mask = spaces.MultiBinary(size)
        fields: dict[str, spaces.Space] = {"prompt": AnyText(TEXT_LIMIT),
                                           "menu": AnyText(TEXT_LIMIT), "action_mask": mask}
        if image_shape is not None:
            fields["frame"] = spaces.Box(0, 255, image_shape, np.uint8)
        self.observation = spaces.Dict(fields)

    def encode(self, view: SeatView, frames: list[bytes] | None) -> dict[str, Any]:
        """`view` as an observation of these spaces (`frames`: the PNGs under image
        conditions)."""
        ids = np.zeros(self.max_menu + 2, np.int8)
        ids[0] = 1  # DONE
        for option in view.menu:
            if option.action_id > self.max_menu:
                raise EnvError(f"menu id {option.action_id} of seat {self.seat!r} is above "
                               f"max_menu={self.max_menu}: build the environment with a "
                               "larger max_menu")
            ids[option.action_id - DONE] = 1
        mask: Any = ids
        if self.broadcasts:
            sends = view.acting and view.sends_message
            chars = np.full(len(MESSAGE_CHARS), int(sends), np.int8)
            mask = {"action": ids, "message": (SAMPLE_LENGTH if sends else 0, chars)}
        obs: dict[str, Any] = {"prompt": view.prompt, "menu": "\n".join(view.menu_lines),
                               "action_mask": mask}
        if self.image_shape is not None:
            obs["frame"] = self._image(frames or [])
        return obs

    def _image(self, frames: list[bytes]) -> np.ndarray:
        arrays = [np.asarray(Image.open(io.BytesIO(f)).convert("RGB")) for f in frames]
        if self.seat in (TEAM_SEAT, LEADER_SEAT):
            out = np.zeros(self.image_shape, np.uint8)
            for i, array in enumerate(arrays):
                out[i] = array
            return out
        return arrays[0] if arrays else np.zeros(self.image_shape, np.uint8)

    def decode(self, action: Any) -> SeatAction:
        """An action of this seat's space (an id, or for a broadcasting seat a dict with
        ``action`` and ``message``) as a `SeatAction`."""
        if isinstance(action, dict):
            if not self.broadcasts and action.get("message"):
                raise EnvError(f"seat {self.seat!r} sends no messages under this condition:"
                               f" its action is a menu id, not {action!r}")
            unknown = set(action) - {"action", "message"}
            if unknown:
                raise EnvError(f"the action of seat {self.seat!r} has unknown keys "
                               f"{sorted(unknown)}: use 'action' and 'message'")
            message = action.get("message") or ""
            if not isinstance(message, str):
                raise EnvError(f"the message of seat {self.seat!r} must be text, not "
                               f"{type(message).__name__}")
            return SeatAction(_menu_id(self.seat, action.get("action", DONE)), message)
        return SeatAction(_menu_id(self.seat, action))


def _menu_id(seat: str, value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise EnvError(f"the action of seat {seat!r} must be a menu id (an integer; DONE is "
                       f"-1), not {value!r}")
    return int(value)

"""The Gymnasium spaces of a seat, and its observation encoded in them.

A seat's action is a menu id (the id its prompt shows; ids start at 0) or `DONE` (-1):
``Discrete(max_menu + 2, start=-1)``. A seat that broadcasts (D1's robots, leader–worker's
robots and leader) acts with ``{"action": id, "message": text}`` (`SeatActionSpace`). Every
element of the action space is a valid action: an id off the menu is scored as a model's
invalid id, and a message where none is read now is not read (``off_menu="error"`` raises
instead). The observation is a dict: ``prompt`` (the harness's prompt text), ``menu`` (its
menu lines) — or under ``observation="numeric"`` the tables of `features.py` (``objects``,
``entries``, ``goal``, ``context``) in their place —, ``action_mask`` (a numpy int8 array,
PettingZoo's convention: entry 0 for DONE, entry ``id + 1`` for each id on the menu, the
mask ``Discrete(…, start=-1)`` samples with; `SeatActionSpace.sample` takes it too), for a
broadcasting seat ``sends_message`` (1 when a message is read from it now), and under image
conditions ``frame``: the seat's camera frame as an RGB array (the team's seat and the
leader: every robot's frame, ``(robots, H, W, 3)``).
"""

from __future__ import annotations

import multiprocessing
import string
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import shared_memory

from cocobench_agents.envs.features import WorldFeatures
from cocobench_agents.envs.seated import DONE, EnvError, SeatAction, SeatedEpisode, SeatView
from cocobench_agents.graphs.registry import LEADER_SEAT
from cocobench_agents.prompts.parse import MESSAGE_LIMIT

#: The characters a sampled message is drawn from (any text is accepted).
MESSAGE_CHARS = string.ascii_letters + string.digits + " .,:;!?'-_()"
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


# `AsyncVectorEnv` keeps observations in shared memory; Gymnasium's own layout for `Text`
# holds only its charset's characters (a prompt's newline was a `KeyError`), so an `AnyText`
# is held as its length, then its characters as Unicode code points. Gymnasium reads the
# memory once, expecting views that follow the workers' writes: `SharedTexts` is one.


class SharedTexts(Sequence[str]):
    """The texts of `n` environments in shared memory, read when indexed (a deep copy, as
    `AsyncVectorEnv` returns by default, is a tuple of the texts now)."""

    def __init__(self, memory: Any, n: int, max_length: int) -> None:
        self._rows = np.frombuffer(memory.get_obj(), np.uint32).reshape((n, max_length + 1))

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self)[index]
        row = self._rows[index]
        return row[1:1 + int(row[0])].tobytes().decode("utf-32-le")

    def __deepcopy__(self, memo: dict) -> tuple[str, ...]:
        return tuple(self)

    def __repr__(self) -> str:
        return repr(tuple(self))


@shared_memory.create_shared_memory.register(AnyText)
def _create_any_text_memory(space: AnyText, n: int = 1, ctx: Any = multiprocessing) -> Any:
    return ctx.Array(np.dtype(np.uint32).char, n * (space.max_length + 1))


@shared_memory.read_from_shared_memory.register(AnyText)
def _read_any_text(space: AnyText, memory: Any, n: int = 1) -> SharedTexts:
    return SharedTexts(memory, n, space.max_length)


@shared_memory.write_to_shared_memory.register(AnyText)
def _write_any_text(space: AnyText, index: int, value: str, memory: Any) -> None:
    points = np.frombuffer(value.encode("utf-32-le"), np.uint32)
    row = np.frombuffer(memory.get_obj(), np.uint32)[index * (space.max_length + 1):]
    row[0] = len(points)
    row[1:1 + len(points)] = points


class SeatActionSpace(spaces.Dict):
    """A broadcasting seat's action space, ``{"action": id, "message": text}``, whose `sample`
    also takes the observation's numpy ``action_mask`` (PettingZoo's checkers and most RL
    libraries pass it as it is): the id drawn under it, the message drawn freely."""

    def sample(self, mask: Any = None, probability: Any = None) -> dict[str, Any]:
        if isinstance(mask, np.ndarray):
            return {"action": self.spaces["action"].sample(mask=mask),
                    "message": self.spaces["message"].sample()}
        return super().sample(mask=mask, probability=probability)


class SeatSpaces:
    """The spaces of one seat and the encoding of its views."""

    def __init__(self, seat: str, *, max_menu: int, broadcasts: bool,
                 image_shape: tuple[int, ...] | None,
                 numeric: WorldFeatures | None = None) -> None:
        self.seat, self.max_menu, self.broadcasts = seat, max_menu, broadcasts
        self.image_shape, self.numeric = image_shape, numeric
        size = max_menu + 2  # DONE, then ids 0..max_menu
        choice = spaces.Discrete(size, start=DONE)
        self.message_limit = LEADER_LIMIT if seat == LEADER_SEAT else MESSAGE_LIMIT
        fields: dict[str, spaces.Space] = (
            numeric.layout.fields() if numeric is not None
            else {"prompt": AnyText(TEXT_LIMIT), "menu": AnyText(TEXT_LIMIT)})
        fields["action_mask"] = spaces.MultiBinary(size)
        if broadcasts:
            self.action: spaces.Space = SeatActionSpace(
                {"action": choice, "message": AnyText(self.message_limit)})
            fields["sends_message"] = spaces.Discrete(2)
        else:
            self.action = choice
        if image_shape is not None:
            fields["frame"] = spaces.Box(0, 255, image_shape, np.uint8)
        self.observation = spaces.Dict(fields)

    def encode(self, view: SeatView, frame: np.ndarray | None,
               episode: SeatedEpisode | None = None) -> dict[str, Any]:
        """`view` as an observation of these spaces (`frame`: under image conditions, the
        seat's frame, which the observation takes as it is; `episode`: the live episode,
        which the numeric tables read)."""
        ids = np.zeros(self.max_menu + 2, np.int8)
        ids[0] = 1  # DONE
        for option in view.menu:
            if option.action_id > self.max_menu:
                raise EnvError(f"menu id {option.action_id} of seat {self.seat!r} is above "
                               f"max_menu={self.max_menu}: build the environment with a "
                               "larger max_menu")
            ids[option.action_id - DONE] = 1
        obs: dict[str, Any] = (
            self.numeric.encode(episode, self.seat, view.menu) if self.numeric is not None
            else {"prompt": view.prompt, "menu": "\n".join(view.menu_lines)})
        obs["action_mask"] = ids
        if self.broadcasts:
            obs["sends_message"] = np.int64(view.acting and view.sends_message)
        if self.image_shape is not None:
            obs["frame"] = frame if frame is not None else np.zeros(self.image_shape, np.uint8)
        return obs

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
            self._check_message(message)
            return SeatAction(_menu_id(self.seat, action.get("action", DONE)), message)
        return SeatAction(_menu_id(self.seat, action))

    def _check_message(self, message: Any) -> None:
        """A message is text within the seat's limit (a robot's on one line): a longer one
        is refused rather than cut, as the harness would cut a model's."""
        if not isinstance(message, str):
            raise EnvError(f"the message of seat {self.seat!r} must be text, not "
                           f"{type(message).__name__}")
        if len(message) > self.message_limit:
            raise EnvError(f"the message of seat {self.seat!r} is {len(message)} characters: "
                           f"the limit is {self.message_limit}")
        if self.seat != LEADER_SEAT and "\n" in message:
            raise EnvError(f"the message of seat {self.seat!r} must be one line: it holds a "
                           "line break")


def _menu_id(seat: str, value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise EnvError(f"the action of seat {seat!r} must be a menu id (an integer; DONE is "
                       f"-1), not {value!r}")
    return int(value)

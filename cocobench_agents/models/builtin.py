"""Offline model clients: `greedy`, `random`, `scripted` and `replay` (baselines, tests, reruns).

Each answers instantly with zero tokens and cost, and has `name` = its spec string. Clients
keep state (a script position, a random stream), so one is made per episode and agent.
"""

from __future__ import annotations

import hashlib
import json
import random
from collections.abc import Sequence
from pathlib import Path

from .errors import ModelConfigError
from .human import HUMAN
from .protocol import TEAM_SEAT, MenuOption, ModelReply, ModelRequest
from .replay import ReplayClient, ReplaySource

__all__ = [
    "BUILTIN_MODELS",
    "GREEDY_SKILL_ORDER",
    "GreedyClient",
    "RandomClient",
    "ReplayClient",
    "ReplaySource",
    "Script",
    "ScriptedClient",
    "is_builtin",
    "split_spec",
]

#: The built-in model names; `scripted` and `replay` take a path (``scripted:FILE``).
#: `human` (a person at a `SeatDesk`) is one too: no endpoint, key or sampling setting
#: reaches it, and it costs nothing.
BUILTIN_MODELS = ("greedy", "random", "scripted", "replay", HUMAN)

#: The reference's greedy preference: the lowest-rank skill on the menu wins.
GREEDY_SKILL_ORDER = (
    "PickUp",
    "Put",
    "Open",
    "Close",
    "Slice",
    "ToggleOn",
    "ToggleOff",
    "CleanObject",
    "FillObjectWithLiquid",
    "EmptyLiquidFromObject",
    "PushObject",
    "PullObject",
    "Drop",
    "Find",
    "Explore",
    "Wait",
)
_GREEDY_RANK = {skill: rank for rank, skill in enumerate(GREEDY_SKILL_ORDER)}


def split_spec(spec: str) -> tuple[str, str | None]:
    """``"scripted:replies.json"`` → ``("scripted", "replies.json")``; ``"greedy"`` →
    ``("greedy", None)``."""
    name, sep, arg = spec.partition(":")
    return name, (arg if sep else None)


def is_builtin(spec: str) -> bool:
    """Whether `spec` names a built-in client (rather than a LiteLLM model)."""
    return split_spec(spec)[0] in BUILTIN_MODELS


def _reply(text: str) -> ModelReply:
    return ModelReply(text=text)


class GreedyClient:
    """Picks the menu entry whose skill ranks lowest in `GREEDY_SKILL_ORDER` (the first such
    entry in menu order; unknown skills rank last); replies ``ACTION: <id>``, or
    ``ACTION: DONE`` on an empty menu."""

    accepts_images = False  # built-ins never look at frames: don't render them

    def __init__(self, name: str = "greedy") -> None:
        self.name = name
        # An episode hands out the same menu tuple while its menu is unchanged (a tuple of
        # frozen options cannot change): the choice is taken once per menu.
        self._last: tuple[Sequence[MenuOption], MenuOption | None] = ((), None)

    async def complete(self, request: ModelRequest) -> ModelReply:
        """Answer with the greedy choice."""
        menu, (last_menu, choice) = request.menu, self._last
        if menu is not last_menu:
            choice = greedy_choice(menu)
            if isinstance(menu, tuple):
                self._last = (menu, choice)
        return _reply(f"ACTION: {'DONE' if choice is None else choice.action_id}")


def greedy_choice(menu: Sequence[MenuOption]) -> MenuOption | None:
    """The greedy entry of `menu`, or None when it is empty."""
    if not menu:
        return None
    last = len(GREEDY_SKILL_ORDER)
    return min(menu, key=lambda o: _GREEDY_RANK.get(o.skill, last))  # min keeps the first tie


class RandomClient:
    """A uniform, seeded choice from the menu, never DONE (``ACTION: DONE`` only when the
    menu is empty). The stream depends on the seed, the episode, the agent and the request's
    `sample_index`, so every agent of every episode and sample is reproducible on its own.

    Common random numbers: the episode's prompt-suite arm is not part of the stream
    (`stream_episode`), so arms that differ only in prompts (which `random` never reads) are
    compared on the same draws, and their paired difference is exactly 0."""

    accepts_images = False  # built-ins never look at frames: don't render them

    def __init__(
        self, name: str = "random", *, seed: int = 0, episode: str = "", agent: str | None = None
    ) -> None:
        self.name = name
        self.seed = seed
        self.episode = stream_episode(episode)
        self.agent = agent
        self._streams: dict[int, random.Random] = {}

    def _stream(self, sample_index: int) -> random.Random:
        stream = self._streams.get(sample_index)
        if stream is None:
            # sha256, not hash(): str hashes are salted per process.
            material = f"{self.seed}\x1f{self.episode}\x1f{self.agent}\x1f{sample_index}"
            digest = hashlib.sha256(material.encode("utf-8")).digest()
            stream = self._streams[sample_index] = random.Random(int.from_bytes(digest[:8], "big"))
        return stream

    async def complete(self, request: ModelRequest) -> ModelReply:
        """Answer with a random menu id."""
        if not request.menu:
            return _reply("ACTION: DONE")
        choice = self._stream(request.sample_index).choice(request.menu)
        return _reply(f"ACTION: {choice.action_id}")


def stream_episode(episode: str) -> str:
    """The part of an episode's key a random stream depends on: the key without its
    prompt-suite arm. A run's key is ``model/condition[/arm]/task[@eN]``
    (`runfolder.EpisodeKey.parts`); a key without an arm (or a bare task id) is kept as it
    is, so runs without arms draw what they always drew."""
    parts = episode.split("/")
    return "/".join([*parts[:2], parts[-1]]) if len(parts) == 4 else episode


class Script:
    """Replies read from a file: a JSON list (every agent gets the whole list), a JSON object
    seat → list (a robot's id; ``"team"``, `TEAM_SEAT`, for the team's model: a centralized
    planner's or a leader's; ``"*"`` for any seat not listed), or a text file of replies
    separated by lines holding only ``---``. Files written before the team's seat had one
    name key it ``"centralized"``: read as ``"team"`` where no ``"team"`` entry is given."""

    TEAM = TEAM_SEAT
    OLD_TEAM = "centralized"  # the team's key in files written before `TEAM_SEAT`
    ANY = "*"

    def __init__(self, path: str | Path, spec: str | None = None) -> None:
        self.path = Path(path)
        spec = spec or f"scripted:{path}"
        try:
            text = self.path.read_text(encoding="utf-8")
        except OSError as exc:
            raise ModelConfigError(spec, f"cannot read the script {path}: {exc.strerror}") from None
        self.replies = self._parse(text, spec)

    def _parse(self, text: str, spec: str) -> dict[str, list[str]]:
        stripped = text.strip()
        looks_json = self.path.suffix.lower() == ".json" or stripped[:1] in ("[", "{")
        if looks_json:
            try:
                data = json.loads(stripped)
            except ValueError as exc:
                if self.path.suffix.lower() == ".json":
                    raise ModelConfigError(spec, f"{self.path} is not valid JSON: {exc}") from None
            else:
                return self._from_json(data, spec)
        chunks: list[list[str]] = [[]]
        for line in text.splitlines():
            if line.strip() == "---":
                chunks.append([])
            else:
                chunks[-1].append(line)
        replies = ["\n".join(c).strip() for c in chunks]
        return {self.ANY: [r for r in replies if r]}

    def _from_json(self, data: object, spec: str) -> dict[str, list[str]]:
        def replies_of(value: object, where: str) -> list[str]:
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise ModelConfigError(spec, f"{where} in {self.path} must be a list of strings")
            return list(value)

        if isinstance(data, list):
            return {self.ANY: replies_of(data, "the script")}
        if isinstance(data, dict):
            return {str(k): replies_of(v, f"the entry {k!r}") for k, v in data.items()}
        raise ModelConfigError(spec, f"{self.path} must hold a list or an object of lists")

    def for_agent(self, agent: str | None) -> list[str]:
        """The replies one agent's client uses, in order."""
        if agent is None:
            replies = self.replies.get(self.TEAM, self.replies.get(self.OLD_TEAM))
            if replies is not None:
                return list(replies)
        return list(self.replies.get(agent or self.ANY, self.replies.get(self.ANY, [])))


class ScriptedClient:
    """Replies from a `Script`, in order; ``ACTION: DONE`` once they run out."""

    accepts_images = False  # built-ins never look at frames: don't render them

    def __init__(self, name: str, replies: Sequence[str]) -> None:
        self.name = name
        self._replies = list(replies)
        self._next = 0

    async def complete(self, request: ModelRequest) -> ModelReply:
        """The next scripted reply."""
        if self._next >= len(self._replies):
            return _reply("ACTION: DONE")
        self._next += 1
        return _reply(self._replies[self._next - 1])

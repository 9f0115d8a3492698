"""`human`: a person as a model. A human seat's client hands each decision to a `SeatDesk`
(the play page of `cocobench run`, or the `episode` graph's interrupts under a LangGraph
server) and turns the person's choice into the reply text the parser already reads, so a
human decision is recorded exactly like a model's (0 tokens, $0, latency = think time).

This module is the contract between the runner and whatever shows the person the decision;
it imports no web framework and no LangGraph.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from .grammar import wants_message
from .messages import image_data_url
from .protocol import TEAM_SEAT, EpisodeHalt, ModelError, ModelReply, ModelRequest, prompt_text

HUMAN = "human"


@dataclass(frozen=True)
class Decision:
    """What a person is asked: what the model would have been sent for this seat."""

    # Unique within a run, and the same when a resumed run asks it again:
    # "<episode>#<seat>#<n>", n counting this seat's asks in the episode.
    id: str
    # The episode's folder under the run's `episodes/` (model/condition[/arm]/task[@eN]);
    # the engine's EpisodeStarted / EpisodeRecorded events carry its key and result.
    episode: str
    seat: str  # the deciding agent, or TEAM_SEAT ("team") for the team's model
    prompt: str  # the full rendered prompt (content parts: as their JSON, as recorded)
    images: tuple[str, ...] = ()  # the frames as data URLs (image mode)
    menu: tuple[dict[str, Any], ...] = ()  # {"id": 3, "skill": "PickUp", "call": "PickUp(…)"}
    wants_message: bool = False  # D1: the seat may broadcast a message with its choice
    step_index: int = 0  # steps landed in the episode so far

    def on_menu(self, action_id: int) -> bool:
        return any(option["id"] == action_id for option in self.menu)

    def accepts(self, action_id: int | None) -> bool:
        """Whether `action_id` answers this decision: an id on its menu, or None (DONE)."""
        return action_id is None or self.on_menu(action_id)

    def call_of(self, action_id: int | None) -> str | None:
        """The call menu entry `action_id` stands for (None: not on the menu, or DONE)."""
        return next((o["call"] for o in self.menu if o["id"] == action_id), None)

    def as_dict(self) -> dict[str, Any]:
        """The decision as plain JSON values (what a page or a LangGraph interrupt shows)."""
        return {**dataclasses.asdict(self), "images": list(self.images),
                "menu": [dict(option) for option in self.menu]}


@dataclass(frozen=True)
class Answer:
    """A person's choice: a menu id (None: DONE, as the prompt offers a model: every goal is
    satisfied), an optional reason and (D1) message."""

    action_id: int | None
    reason: str = ""
    message: str = ""
    think_s: float = 0.0  # from the decision shown to the answer

    def reply_text(self, wants_message: bool) -> str:
        """The reply a model would have written, built so that the models' own parser
        (`prompts.parse_reply`, `parse_message`: the first ``ACTION:`` and the first ``MSG:``
        anywhere) reads back exactly the click and the message, whatever the person typed:
        the ACTION line comes first, then the MSG line, then the reason, whose own ``MSG:``
        is defused (with no message, the parser would broadcast it)."""
        action = "DONE" if self.action_id is None else self.action_id
        lines = [f"ACTION: {action}"]
        if wants_message and self.message.strip():
            lines.append(f"MSG: {_one_line(self.message)}")
        reason = _one_line(self.reason).replace(MESSAGE_TAG, "MSG :")
        lines.append(f"REASON: {reason or 'chosen by a person'}")
        return "\n".join(lines)


class SeatDesk(Protocol):
    """Where human seats' decisions go and their answers come from. The runner asks one
    decision at a time (several human seats of one team wait their turn), in the order the
    planners ask for them."""

    async def ask(self, decision: Decision) -> Answer:
        """The person's answer to `decision` (waits for it)."""
        ...


#: Records a person's answer to a decision for good (the run's answer log: a whole, fsync'd
#: line) and returns the answer as recorded; raises when it cannot.
Recorder = Callable[[Decision, Answer], Answer]


@runtime_checkable
class RecordingDesk(SeatDesk, Protocol):
    """A desk that tells the person their answer was taken (the play page's 200): it must
    record the answer first, so that nothing a person was told was taken is lost."""

    async def ask_recorded(self, decision: Decision, record: Recorder) -> Answer:
        """`ask`, with `record` called on the answer before the person is told it was taken;
        the answer returned is `record`'s. A failing `record`: the answer is not taken, and
        its error is raised here."""
        ...


class HumanTurn(EpisodeHalt):
    """Raised by a desk that cannot wait here for the person: it ends the episode at
    `decision`, to be asked elsewhere (the `episode` graph asks through a LangGraph
    interrupt, then plays the episode again with the answer). No planner records it as a
    model failure."""

    def __init__(self, decision: Decision) -> None:
        super().__init__(f"waiting for a person's answer to {decision.id}")
        self.decision = decision


@dataclass
class HumanClient:
    """The client of one human seat in one episode: each request becomes a `Decision` on
    `desk`; the answer becomes the reply."""

    desk: SeatDesk
    episode: str  # the episode's folder under `episodes/` (see `Decision.episode`)
    agent: str | None = None
    name: str = HUMAN
    accepts_images: bool = True
    asked: int = 0  # decisions this seat was asked so far

    async def complete(self, request: ModelRequest) -> ModelReply:
        if not request.menu:  # the leader of leader-worker writes free text
            raise ModelError("bad_request", "a human seat chooses from a menu, and this "
                             "request offers none")
        decision = self.decision(request)
        self.asked += 1
        started = time.perf_counter()
        answer = await self.desk.ask(decision)
        think = answer.think_s or time.perf_counter() - started
        return ModelReply(text=answer.reply_text(decision.wants_message), latency_s=think)

    def decision(self, request: ModelRequest) -> Decision:
        seat = request.agent or TEAM_SEAT
        return Decision(
            id=f"{self.episode}#{seat}#{self.asked + 1}", episode=self.episode, seat=seat,
            prompt=prompt_text(request.prompt),
            images=tuple(image_data_url(png) for png in request.images),
            menu=tuple({"id": o.action_id, "skill": o.skill, "call": o.call}
                       for o in request.menu),
            wants_message=wants_message(request.prompt), step_index=request.step_index)


#: What `prompts.parse_message` takes for the start of a message.
MESSAGE_TAG = "MSG:"


def _one_line(text: str) -> str:
    return " ".join(text.split())

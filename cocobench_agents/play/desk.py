"""`PlayDesk`: the `SeatDesk` of `cocobench run` with human seats. The engine's thread asks
(`ask`, awaited on the engine's event loop) and reports its events (`on_event`); the play
server's thread reads what to show (`snapshot`) and hands in answers (`answer`). One lock
guards the shared state, and each side is woken on its own loop.

The runner asks one decision at a time (`SeatDesk`): several human seats of one team wait
their turn before they reach the desk.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cocobench_agents.engine import events
from cocobench_agents.models.human import Answer, Decision, Recorder
from cocobench_agents.models.protocol import TEAM_SEAT
from cocobench_agents.play.prompt_parts import (
    agent_label,
    menu_labels,
    numbered_history,
    prompt_parts,
)

#: The result line's fields an episode's outcome shows on the page.
OUTCOME_FIELDS = ("model", "condition", "arm", "task_id", "epoch", "dim", "task_success",
                  "task_progress", "construct_score", "construct_status", "terminal_reason",
                  "num_steps", "infra_error")


class AnswerRefused(ValueError):
    """An answer the desk does not take (nothing is recorded)."""


class NotPending(AnswerRefused):
    """The decision is not the one being asked now: answered already, withdrawn (its
    episode ended), or never asked."""


class NotOnMenu(AnswerRefused):
    """The choice is not on the decision's menu, or carries a message the seat cannot send."""


class NotRecorded(RuntimeError):
    """The answer could not be recorded (the run's answer log, on a full disk say): it is
    not taken, and the decision waits for an answer again."""


class AskedTwice(RuntimeError):
    """A second decision asked while one waits: the runner breaks `SeatDesk`'s contract."""


@dataclass
class _Asked:
    decision: Decision
    future: asyncio.Future[Answer]
    loop: asyncio.AbstractEventLoop  # the engine's loop, where `future` is awaited
    shown_at: float
    record: Recorder  # called on the answer, on the server's thread, before the 200
    recording: bool = False  # an answer is being recorded: another is refused meanwhile


class PlayDesk:
    """Human seats' decisions, one at a time, for the play page."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._asked: _Asked | None = None
        self._version = 0
        self._run: dict[str, Any] = {}
        self._episode: dict[str, Any] | None = None
        # The episode's landed steps (agent, step number, call): the page numbers a
        # prompt's recent actions with them.
        self._landed: list[tuple[str, int, str]] = []
        self._outcomes: list[dict[str, Any]] = []
        self._ended: str | None = None
        self._listeners: list[Callable[[], None]] = []
        self.end_shown = threading.Event()  # a page has been told that the run ended

    # -- the engine's side ------------------------------------------------------------------

    async def ask(self, decision: Decision) -> Answer:
        """Show `decision` and wait for its answer, recorded nowhere (`ask_recorded`)."""
        return await self.ask_recorded(decision, _kept_nowhere)

    async def ask_recorded(self, decision: Decision, record: Recorder) -> Answer:
        """Show `decision` and wait for its answer, which `answer` records with `record`
        before it tells the page the answer was taken; a cancelled wait (the episode timed
        out, the run was interrupted) withdraws it."""
        loop = asyncio.get_running_loop()
        asked = _Asked(decision, loop.create_future(), loop, time.monotonic(), record)
        with self._lock:
            if self._asked is not None:
                raise AskedTwice(f"{decision.id} asked while {self._asked.decision.id} waits")
            self._asked = asked
        self._changed()
        try:
            return await asked.future
        finally:
            with self._lock:
                withdrawn = self._asked is asked
                if withdrawn:
                    self._asked = None
            if withdrawn:
                self._changed()

    def on_event(self, event: events.Event) -> None:
        """Follow the run: its size, the episode being played, each recorded result."""
        with self._lock:
            if isinstance(event, events.RunStarted):
                self._run = {"total": event.total, "done": event.done,
                             "folder": str(event.folder)}
            elif isinstance(event, events.EpisodeStarted):
                self._episode = dict(event.key)
                self._landed = []
            elif isinstance(event, events.StepLanded):
                self._follow_step(event)
                return  # shown with the next decision
            elif isinstance(event, events.EpisodeRecorded):
                self._outcomes.append({k: event.record.get(k) for k in OUTCOME_FIELDS})
            else:
                return
        self._changed()

    def finish(self, note: str) -> None:
        """The run has ended (`note` says how); the page says so."""
        with self._lock:
            self._ended = note
            self._episode = None
        self._changed()

    # -- the server's side ------------------------------------------------------------------

    def answer(self, decision_id: str, action_id: int | None, *, reason: str = "",
               message: str = "") -> None:
        """Take the person's answer to the decision being asked now (`action_id` None:
        DONE), or refuse it (`NotPending`, `NotOnMenu`) without changing anything. Returns
        once the answer is recorded (the asker's `Recorder`; on this thread, so that the
        page hears "taken" only then); `NotRecorded` if it could not be."""
        with self._lock:
            asked = self._asked
            if asked is None or asked.decision.id != decision_id or asked.recording:
                now = asked.decision.id if asked else None
                raise NotPending(f"decision {decision_id!r} is not waiting for an answer "
                                 "(answered already, withdrawn, or not asked); asked now: "
                                 f"{now or 'none'}")
            if not asked.decision.accepts(action_id):
                raise NotOnMenu(f"action {action_id} is not on the menu of {decision_id!r}")
            if message.strip() and not asked.decision.wants_message:
                raise NotOnMenu(f"the seat of {decision_id!r} sends no messages")
            asked.recording = True
            answer = Answer(action_id, reason=reason, message=message,
                            think_s=time.monotonic() - asked.shown_at)
        try:
            answer = asked.record(asked.decision, answer)
        except Exception as exc:
            with self._lock:
                asked.recording = False  # still asked: the person may answer again
            raise NotRecorded(f"the answer could not be recorded ({exc}); nothing was "
                              "taken, answer again once the run folder can be written") \
                from exc
        with self._lock:
            if self._asked is asked:  # not withdrawn meanwhile
                self._asked = None
            asked.loop.call_soon_threadsafe(_settle, asked.future, answer)
        self._changed()

    @property
    def version(self) -> int:
        """Grows with every change of what the page shows."""
        return self._version

    def snapshot(self) -> dict[str, Any]:
        """What the page shows, as JSON-ready data."""
        with self._lock:
            asked = self._asked
            if self._ended is not None:
                self.end_shown.set()
            return {
                "version": self._version, "run": dict(self._run), "episode": self._episode,
                "decision": _shown(asked.decision, self._landed) if asked else None,
                "outcomes": list(self._outcomes), "ended": self._ended,
            }

    def subscribe(self, listener: Callable[[], None]) -> Callable[[], None]:
        """Call `listener` (from whichever thread made it) after every change; returns the
        function that unsubscribes it."""
        with self._lock:
            self._listeners.append(listener)
        return lambda: self._unsubscribe(listener)

    def _unsubscribe(self, listener: Callable[[], None]) -> None:
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def _follow_step(self, event: events.StepLanded) -> None:
        """Keep a step of the episode on the page (called with the lock held)."""
        if self._episode is None or any(self._episode.get(k) != v
                                        for k, v in event.key.items()):
            return  # a model-only episode, run after the person's
        step, result = event.step.get("step_index"), event.step.get("skill_result") or {}
        if isinstance(step, int):
            self._landed.append((str(result.get("agent")), step, str(event.step.get("label"))))

    def _changed(self) -> None:
        with self._lock:
            self._version += 1
            listeners = list(self._listeners)
        for listener in listeners:
            listener()


def _settle(future: asyncio.Future[Answer], answer: Answer) -> None:
    if not future.done():  # a wait cancelled meanwhile keeps its cancellation
        future.set_result(answer)


def _kept_nowhere(decision: Decision, answer: Answer) -> Answer:
    """The `Recorder` of a desk asked without one (a test, a front end of one's own)."""
    return answer


def _shown(decision: Decision, landed: list[tuple[str, int, str]]) -> dict[str, Any]:
    """A decision as the page draws it: each menu option gets the line the prompt shows it
    with, its agent apart (`agent`, `label`; else its call); the recent actions are numbered
    by the episode's steps, and the last of them is the seat's `last_action`."""
    shown = decision.as_dict()
    parts = prompt_parts(decision.prompt)
    labels = menu_labels(parts)
    for option in shown["menu"]:
        line = labels.get(option["id"], option["call"])
        agent, label = agent_label(line)
        if agent != _agent_of(option["call"]):  # a line of one's own wording: kept whole
            agent, label = None, line
        option["agent"], option["label"] = agent, label
    own = [(step, call) for agent, step, call in landed if decision.seat in (TEAM_SEAT, agent)]
    history = numbered_history(parts.get("history", ""), own)
    if history is not None:
        parts["history"] = "\n".join(history)
    shown["last_action"] = history[-1] if history else None
    shown["parts"] = {name: text for name, text in parts.items() if name != "menu"}
    return shown


def _agent_of(call: str) -> str:
    """The agent a call is for: its first argument (`PickUp(agent_1, Apple)` → agent_1)."""
    return call.partition("(")[2].split(",")[0].rstrip(")").strip()

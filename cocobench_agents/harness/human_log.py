"""Nothing a person did is lost: every answer of a human seat is logged in the run folder
the moment it is given, beside the episode's trajectory
(``episodes/<model>/<condition>/<task>/human_answers.jsonl``, one whole fsync'd line per
answer), and replayed when the episode is played again: a run resumed after a kill plays a
pending episode from its start, and the person is asked only what they had not answered.

The log stays after the episode (it documents the human play); it holds what the person
chose and wrote, nothing of the page that asked (no token).
"""

from __future__ import annotations

import asyncio
import dataclasses
import datetime as dt
import time
from typing import Any

from cocobench_agents.models.human import Answer, Decision, RecordingDesk, SeatDesk
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.tools import prompt_hash

HUMAN_ANSWERS = "human_answers.jsonl"


def answers_file(episode: str) -> str:
    """The answer log of `episode` (a `Decision.episode`), relative to the run folder."""
    return f"episodes/{episode}/{HUMAN_ANSWERS}"


class LoggedDesk:
    """A `SeatDesk` in front of `desk`: a decision answered before (same id, same prompt,
    the answer still on its menu) gets the logged answer without asking; any other is asked
    of `desk`, one at a time in the order asked, and its answer logged before it is used.

    Answers of the log (``human_answers.jsonl``) are ``{decision, seat, step_index,
    prompt_hash, action_id (null: DONE), call, reason, message, think_s, answered_at}``."""

    def __init__(self, desk: SeatDesk, folder: RunFolder) -> None:
        self.desk = desk
        self.folder = folder
        self._logs: dict[str, dict[str, dict[str, Any]]] = {}  # episode → id → latest line
        self._turn = asyncio.Lock()  # several human seats of a team are asked in turn

    async def ask(self, decision: Decision) -> Answer:
        log = self._log(decision.episode)
        logged = log.get(decision.id)
        if logged is not None and answers_again(logged, decision):
            return answer_of(logged)
        async with self._turn:
            shown = time.perf_counter()

            def record(decision: Decision, answer: Answer) -> Answer:
                return self._record(decision, answer, shown)

            if isinstance(self.desk, RecordingDesk):  # logged before the person is told
                return await self.desk.ask_recorded(decision, record)
            return record(decision, await self.desk.ask(decision))

    def _record(self, decision: Decision, answer: Answer, shown: float) -> Answer:
        """Log `answer` (a whole, fsync'd line) and return it as logged. A `RecordingDesk`
        calls it on its own thread while the run's loop awaits the answer."""
        if not answer.think_s:  # a desk that does not time the person: from shown to answer
            answer = dataclasses.replace(answer, think_s=time.perf_counter() - shown)
        line = log_line(decision, answer)
        self.folder.append_line(answers_file(decision.episode), line)
        self._log(decision.episode)[decision.id] = line
        return answer

    def _log(self, episode: str) -> dict[str, dict[str, Any]]:
        """The episode's logged answers by decision id (a later line for an id, asked again
        after the episode went another way, supersedes an earlier one)."""
        log = self._logs.get(episode)
        if log is None:
            lines = self.folder.read_lines(answers_file(episode))
            log = self._logs[episode] = {line["decision"]: line for line in lines
                                         if isinstance(line.get("decision"), str)}
        return log


def answers_again(line: dict[str, Any], decision: Decision) -> bool:
    """Whether a logged answer answers `decision`: the same prompt was shown (a teammate
    that chose otherwise this time changes it) and the choice is on its menu (or DONE). A
    line `log_line` did not write (its choice missing, a choice or think time of another
    type: a damaged or forged log) answers nothing: the person is asked again."""
    action, think_s = line.get("action_id", ""), line.get("think_s", 0.0)
    return (line.get("prompt_hash") == prompt_hash(decision.prompt)
            and (action is None or type(action) is int) and decision.accepts(action)
            and type(think_s) in (int, float))  # (`type`: a JSON true is no number here)


def answer_of(line: dict[str, Any]) -> Answer:
    """The answer a log line holds."""
    return Answer(action_id=line["action_id"], reason=str(line.get("reason") or ""),
                  message=str(line.get("message") or ""),
                  think_s=float(line.get("think_s") or 0.0))


def log_line(decision: Decision, answer: Answer) -> dict[str, Any]:
    """One answer as logged: which decision (id, seat, step, the prompt's hash as its
    decision record names it), the choice and its call, what the person wrote, when."""
    return {"decision": decision.id, "seat": decision.seat, "step_index": decision.step_index,
            "prompt_hash": prompt_hash(decision.prompt), "action_id": answer.action_id,
            "call": decision.call_of(answer.action_id), "reason": answer.reason,
            "message": answer.message, "think_s": round(answer.think_s, 4),
            "answered_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")}

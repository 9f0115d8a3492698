"""People played by code, in this process: desks that answer human seats' decisions."""

from __future__ import annotations

import json
from pathlib import Path

import cocobench_agents as cb
from cocobench_agents.models.human import Answer, Decision

TASK = "K_D3__DemoKitchen1__seed0"  # two agents, one shared knife: 18 oracle calls


def oracle_calls(folder: Path, task: str = TASK) -> list[str]:
    """The calls the oracle lands on `task` (a run of it into `folder`)."""
    results = cb.run(cb.RunRequest(out=folder, selection={"sources": ["demo"],
                                                          "task_ids": [task]},
                                   conditions=["OR_blind"]))
    document = json.loads((folder / results[0]["trajectory"]).read_text())
    return [item["label"] for item in document["trajectory"] if "skill_result" in item]


def number(decision: Decision) -> int:
    """Which of its seat's decisions this is, from 1 (the last part of its id)."""
    return int(decision.id.rpartition("#")[2])


class OracleDesk:
    """A person who plays `calls` in order: a seat's n-th decision gets the menu entry of
    the n-th call, DONE once they run out (or when it is not on the menu). A function of
    the decision alone, so a resumed run gets the same answers. Each answer carries
    `message` with n."""

    def __init__(self, calls: list[str], message: str = "") -> None:
        self.calls = calls
        self.message = message
        self.asked: list[Decision] = []

    async def ask(self, decision: Decision) -> Answer:
        self.asked.append(decision)
        return self.answer(decision)

    def answer(self, decision: Decision) -> Answer:
        n = number(decision)
        call = self.calls[n - 1] if n <= len(self.calls) else None
        chosen = next((o["id"] for o in decision.menu if o["call"] == call), None)
        message = self.message.format(n=n) if self.message else ""
        return Answer(chosen, reason=f"call {n}", message=message, think_s=0.5)

    def reply_texts(self) -> list[str]:
        """What a `scripted:` model would reply to make the same choices."""
        return [self.answer(d).reply_text(d.wants_message) for d in self.asked]

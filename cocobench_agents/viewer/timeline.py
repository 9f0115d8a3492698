"""An episode's step-by-step timeline: each model decision joined with the step it landed
(or the protocol failure that kept it from landing), classified by the benchmark's own
step taxonomy (`metrics.steps.classify_step`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.metrics.steps import (
    Step,
    allowed_skills_by_agent,
    classify_step,
    extract_steps,
)

NO_PROMPT = "prompt not stored in this run"
NO_REPLY = "reply not stored in this run"
#: Statuses of a strategy's own calls that got an answer (`graphs.model_calls`): an `ask`
#: without a menu, a call made with a client directly.
ANSWERED = ("reply", "direct")
#: The status of a leader's reply (leader–worker): its plan, an instruction to each robot.
PLAN = "plan"


@dataclass
class Decision:
    """One model call (or stop) as recorded: what it was asked, said, and what was parsed."""

    record: Mapping[str, Any]
    prompt: str | None

    @property
    def status(self) -> str:
        return str(self.record.get("status") or "")

    @property
    def model(self) -> str:
        """The model that made the decision (`human` for a person's); empty in records
        older than the field."""
        return str(self.record.get("model") or "")

    @property
    def reply(self) -> str | None:
        reply = self.record.get("raw_output", self.record.get("raw_reply"))
        return reply if isinstance(reply, str) else None

    @property
    def kind(self) -> str | None:
        """What a call that lands no step itself was (``ask · pricing``, ``direct call``,
        ``leader plan``); None for a decision of an action."""
        if self.status == PLAN:
            return "leader plan"
        if self.record.get("ask"):
            return f"ask · {self.record['ask']}"
        if self.record.get("policy") == "direct":
            return "direct call"
        return None

    @property
    def parsed(self) -> str:
        if self.status == PLAN:
            directives = self.record.get("directives")
            if isinstance(directives, Mapping) and directives:
                return "; ".join(f"{agent}: {text}" for agent, text in directives.items())
            return "no instruction to any robot"
        if self.kind is not None:
            answer = self.record.get("answer")
            return f"answer: {answer}" if isinstance(answer, str) else ""
        call = self.record.get("parsed_call")
        if call:
            return str(call)
        choice = self.record.get("parsed_action_id")
        return f"choice {choice}" if choice is not None else ""

    @property
    def failure(self) -> str | None:
        """The protocol or backend failure of a call that landed nothing."""
        if self.record.get("parsed_call") or self.status in ("action", PLAN, *ANSWERED):
            return None
        detail = self.record.get("error") or self.record.get("terminal_reason") or ""
        kind = self.record.get("error_kind")
        return " ".join(str(p) for p in (self.status, kind and f"({kind})", detail and
                                         f"— {detail}") if p)

    @property
    def usage(self) -> str:
        r = self.record
        parts = [f"{r[k]} {label}" for k, label in (("prompt_tokens", "in"),
                 ("completion_tokens", "out")) if r.get(k)]
        if r.get("latency_s"):
            parts.append(f"{r['latency_s']:.2f}s")
        if r.get("retries"):
            parts.append(f"{r['retries']} retries")
        parts += [flag for flag in ("cached", "replayed") if r.get(flag)]
        return ", ".join(parts)


@dataclass
class Entry:
    """One line of the timeline: a landed step (with the decision behind it, if any) or a
    decision that landed nothing."""

    decision: Decision | None = None
    step: Step | None = None
    ordinal: int | None = None  # 1-based landed-step number
    category: str | None = None
    progress: tuple[int, int] | None = None  # goal checks passed, of total, after the step
    message: str | None = None  # what the agent posted on the message board
    image: str | None = None  # a saved frame: a path inside the run folder or a data: URI
    agent: str | None = None
    round: int | None = None


@dataclass
class Timeline:
    entries: list[Entry] = field(default_factory=list)
    steps: list[Step] = field(default_factory=list)
    categories: list[str] = field(default_factory=list)
    prompts_stored: bool = False
    frames: int = 0

    @property
    def messages(self) -> list[Entry]:
        return [e for e in self.entries if e.message]

    @property
    def replies(self) -> list[str]:
        return [e.decision.reply for e in self.entries if e.decision and e.decision.reply]


def build_timeline(traj: Mapping[str, Any], prompts: Mapping[str, str]) -> Timeline:
    """Join the trajectory's steps with its `planner_decisions`, in the order they
    happened (a decision that landed nothing sits before the next landed one)."""
    config = traj.get("task_config") or {}
    steps = extract_steps(traj)
    allowed = allowed_skills_by_agent(config)
    categories = [classify_step(s, allowed) for s in steps]
    items = traj["trajectory"]
    pending = [Decision(d, _prompt(d, prompts)) for d in traj.get("planner_decisions") or []
               if isinstance(d, Mapping)]
    timeline = Timeline(steps=steps, categories=categories, prompts_stored=bool(prompts) or any(
        isinstance(d.record.get("prompt"), str) for d in pending))
    for ordinal, (step, category) in enumerate(zip(steps, categories), start=1):
        item = items[step.index]
        landed = item.get("policy_decision")
        decision = None
        if isinstance(landed, Mapping):
            match = next((i for i, d in enumerate(pending) if d.record == landed), None)
            if match is not None:
                timeline.entries += [_unlanded(d) for d in pending[:match]]
                decision, pending = pending[match], pending[match + 1:]
            else:
                decision = Decision(landed, _prompt(landed, prompts))
        timeline.entries.append(Entry(
            decision=decision, step=step, ordinal=ordinal, category=category,
            progress=_progress(item.get("eval")), message=_message(item, decision),
            image=item.get("image") if isinstance(item.get("image"), str) else None,
            agent=step.agent, round=step.round_index))
    timeline.entries += [_unlanded(d) for d in pending]
    timeline.frames = sum(1 for e in timeline.entries if e.image)
    return timeline


def _unlanded(decision: Decision) -> Entry:
    agent = decision.record.get("agent")
    return Entry(decision=decision, agent=str(agent) if agent else None,
                 message=_message({}, decision))


def _prompt(record: Mapping[str, Any], prompts: Mapping[str, str]) -> str | None:
    text = record.get("prompt")
    if isinstance(text, str):
        return text
    return prompts.get(str(record.get("prompt_hash") or ""))


def _message(item: Mapping[str, Any], decision: Decision | None) -> str | None:
    message = item.get("message") or (decision.record.get("message") if decision else None)
    return message if isinstance(message, str) and message.strip() else None


def _progress(evaluation: Any) -> tuple[int, int] | None:
    checks = evaluation.get("checks") if isinstance(evaluation, Mapping) else None
    if not isinstance(checks, list):
        return None
    return sum(1 for c in checks if isinstance(c, Mapping) and c.get("passed")), len(checks)

"""One episode's model decisions as dataset rows: the prompt each named (kept in the run
folder by its hash), the reply, the parsed action, whether it landed, and the frame the run
kept for the state it was asked in; the episode's outcome repeated on each.

Only decisions that called a model (their record names a `prompt_hash`) are rows: a stop
record (the step budget reached, an empty menu) sent nothing and got nothing back. Every
string read from the run folder goes through the harness's own redaction
(`models.secrets`), a second guard behind the one the harness applied when it wrote them.
"""

from __future__ import annotations

import base64
import binascii
import bisect
import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from cocobench_agents.export.columns import IMAGE_COLUMN
from cocobench_agents.models.protocol import TEAM_SEAT
from cocobench_agents.models.secrets import redact_obj, secret_values
from cocobench_agents.rewards import DEFAULT_WEIGHTS, end_reward
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.runfolder.infra import is_infra_failure

#: Decision statuses whose reply named an action on the menu, or DONE; and those whose reply
#: did not (`legal` is null for the others: no reply, a leader's plan for its workers).
LEGAL_STATUSES = ("action", "done")
ILLEGAL_STATUSES = ("parse_error", "invalid_action_id")
CENTRALIZED_SEAT = TEAM_SEAT


@dataclass
class EpisodeStats:
    """What an export met reading episodes, for its summary and card."""

    episodes: int = 0
    rows: int = 0
    without_prompt: int = 0  # decisions whose prompt the run did not keep (older runs)
    with_image: int = 0
    missing_trajectories: list[str] = field(default_factory=list)


class Redactor:
    """Redacts the secret values of this process's environment from what is exported."""

    def __init__(self) -> None:
        self.active = bool(secret_values())  # none set: nothing to scrub, row after row

    def __call__(self, value: Any) -> Any:
        return redact_obj(value) if self.active else value


def episode_rows(folder: RunFolder, run_name: str, line: Mapping[str, Any],
                 redact: Redactor, stats: EpisodeStats) -> Iterator[dict[str, Any]]:
    """The rows of the episode whose result line is `line`, in decision order."""
    document = folder.trajectory(line)
    if document is None:
        stats.missing_trajectories.append(str(line.get("trajectory") or line.get("task_id")))
        return
    stats.episodes += 1
    prompts = folder.prompts(line)
    items = [i for i in document.get("trajectory") or [] if isinstance(i, Mapping)]
    landed = _landed_successes(items)
    frames = _Frames(folder, items)
    outcome = _outcome(run_name, line)
    decisions = [d for d in document.get("planner_decisions") or []
                 if isinstance(d, Mapping) and d.get("prompt_hash")]
    rewards = _rewards(items, decisions, line)
    for index, decision in enumerate(decisions):
        prompt = prompts.get(str(decision["prompt_hash"]))
        stats.without_prompt += prompt is None
        row = {**outcome, **_decision_columns(decision, index, prompt, landed),
               "reward": rewards[index], IMAGE_COLUMN: frames.at(decision.get("step_index"))}
        stats.with_image += row[IMAGE_COLUMN] is not None
        stats.rows += 1
        yield redact(row)  # frame bytes are not text: redaction leaves them as they are


def _outcome(run_name: str, line: Mapping[str, Any]) -> dict[str, Any]:
    return {
        "run": run_name, "model": _text(line.get("model")),
        "condition": _text(line.get("condition")), "arm": _text(line.get("arm")) or "",
        "task_id": _text(line.get("task_id")), "cell": _text(line.get("cell")),
        "epoch": _integer(line.get("epoch")) or 0,
        "episode_success": _boolean(line.get("task_success")),
        "episode_progress": _number(line.get("task_progress")),
        "legal_plan": _boolean(line.get("legal_plan")),
        "construct_score": _number(line.get("construct_score")),
        "construct_status": _text(line.get("construct_status")),
        "failure_kind": _text(line.get("failure_kind")),
        "terminal_reason": _text(line.get("terminal_reason")),
        "infra_failure": is_infra_failure(line),
    }


def _decision_columns(decision: Mapping[str, Any], index: int, prompt: str | None,
                      landed: Mapping[object, bool]) -> dict[str, Any]:
    agent = decision.get("agent")
    return {
        "decision_index": index, "step": _integer(decision.get("step_index")),
        "seat": str(agent) if agent else CENTRALIZED_SEAT,
        "seat_model": _text(decision.get("model")),
        # The harness sends one user message holding the prompt (`models.messages`).
        "messages": None if prompt is None else [{"role": "user", "content": prompt}],
        "reply": _text(decision.get("raw_output")), "status": _text(decision.get("status")),
        "parsed_action_id": _text(decision.get("parsed_action_id")),
        "parsed_call": _text(decision.get("parsed_call")),
        "legal": _legality(decision.get("status")),
        "step_success": landed.get(_identity(decision)),
        "message": _text(decision.get("message")) or None,
        "prompt_tokens": _integer(decision.get("prompt_tokens")),
        "completion_tokens": _integer(decision.get("completion_tokens")),
    }


def _rewards(items: Sequence[Mapping[str, Any]], decisions: Sequence[Mapping[str, Any]],
             line: Mapping[str, Any]) -> list[float]:
    """Each decision's reward as the environments pay a seat under their default weights
    (`cocobench_agents.rewards`): the goal progress its landed call made, less the cost of a
    failed call or of a reply off the menu, and on each seat's last decision what the
    episode's end pays (success, the construct score of a success)."""
    landed: dict[object, tuple[float, bool]] = {}  # by decision: (progress made, failed)
    before = 0.0
    for item in items:
        now = _progress(item)
        decision, result = item.get("policy_decision"), item.get("skill_result")
        if isinstance(decision, Mapping) and isinstance(result, Mapping):
            landed[_identity(decision)] = (now - before if now is not None else 0.0,
                                           not result.get("success"))
        before = before if now is None else now
    seats = [str(d.get("agent") or CENTRALIZED_SEAT) for d in decisions]
    last = {seat: index for index, seat in enumerate(seats)}
    end = end_reward(DEFAULT_WEIGHTS, bool(_boolean(line.get("task_success"))),
                     _number(line.get("construct_score")))
    out = []
    for index, decision in enumerate(decisions):
        gain, failed = landed.get(_identity(decision), (0.0, False))
        costs = failed + (decision.get("status") in ILLEGAL_STATUSES)
        reward = DEFAULT_WEIGHTS["progress"] * gain - DEFAULT_WEIGHTS["legality"] * costs
        out.append(reward + (end if last[seats[index]] == index else 0.0))
    return out


def _progress(item: Mapping[str, Any]) -> float | None:
    """The fraction of goal checks passing after an item (None: no checks recorded)."""
    evaluation = item.get("eval")
    checks = evaluation.get("checks") if isinstance(evaluation, Mapping) else None
    if not isinstance(checks, list) or not checks:
        return None
    return sum(bool(isinstance(c, Mapping) and c.get("passed")) for c in checks) / len(checks)


def _legality(status: Any) -> bool | None:
    if not isinstance(status, str):
        return None
    if status in LEGAL_STATUSES:
        return True
    return False if status in ILLEGAL_STATUSES else None


def _landed_successes(items: Sequence[Mapping[str, Any]]) -> dict[object, bool]:
    """Whether each decision that landed a call succeeded, by the decision's identity (an
    item keeps the decision record that landed it, equal to the one in the decisions)."""
    out = {}
    for item in items:
        decision, result = item.get("policy_decision"), item.get("skill_result")
        if isinstance(decision, Mapping) and isinstance(result, Mapping):
            out[_identity(decision)] = bool(result.get("success"))
    return out


def _identity(decision: Mapping[str, Any]) -> object:
    # The harness's records carry a cumulative counter of model calls (planner_steps): with
    # the seat and the prompt it tells an episode's decisions apart. A record without it (a
    # trajectory written elsewhere) is known by its whole content.
    # (As text either way: a field of a damaged record may be a list, which no key holds.)
    if isinstance(decision.get("planner_steps"), int):
        return json.dumps([decision.get("agent"), decision.get("step_index"),
                           decision["planner_steps"], decision.get("prompt_hash")],
                          sort_keys=True, default=str)
    return json.dumps(decision, sort_keys=True, default=str)


class _Frames:
    """The frames a trajectory's items name (a file in the run folder, or a `data:` URI, as
    the reference's recorder keeps them), by the step counter of the state they show."""

    def __init__(self, folder: RunFolder, items: Sequence[Mapping[str, Any]]) -> None:
        self.folder = folder
        named = {}
        for item in items:
            step, image = item.get("step_index"), item.get("image")
            if isinstance(step, int) and isinstance(image, str) and image:
                named[step] = image  # a later item of the same counter shows a later state
        self.steps = sorted(named)
        self.named = named

    def at(self, step: Any) -> dict[str, Any] | None:
        """The frame of the latest state at or before step counter `step` (None: none kept,
        or one that cannot be read)."""
        if not isinstance(step, int) or not self.steps:
            return None
        place = bisect.bisect_right(self.steps, step)
        if place == 0:
            return None
        name = self.named[self.steps[place - 1]]
        data = _data_uri(name) if name.startswith("data:") else self.folder.read_file(name)
        if data is None:
            return None
        return {"bytes": data, "path": None if name.startswith("data:") else name}


def _data_uri(uri: str) -> bytes | None:
    header, _, payload = uri.partition(",")
    if not header.endswith(";base64"):
        return None
    try:
        return base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        return None


def _text(value: Any) -> str | None:
    return None if value is None else str(value)


def _boolean(value: Any) -> bool | None:
    """A result line's flag (written as true/false, or 1/0 by the reference's scorer)."""
    if isinstance(value, bool):
        return value
    return bool(value) if isinstance(value, int) and value in (0, 1) else None


def _integer(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)

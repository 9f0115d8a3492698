"""Replaying one recorded episode through the embedded simulator, step by step.

The world is rebuilt from the task config the trajectory records (checked against the
reference's own config where the instance is a reference one), every landed call is executed
again in order, and each rebuilt trajectory item (the call, its result, its error message, the
state, the goal progress) is compared with the recorded one. Each model decision is checked
against the replayed menu of its step: its reply parses to the action id and call it
records, and its kept prompt (when the run kept prompts) hashes to its `prompt_hash` and
lists that menu. Then every metric is recomputed from the replayed trajectory by the
benchmark's own scorer and compared with the result line.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import orjson
from pydantic import ValidationError

from benchmark_adapter.episode import Episode
from benchmark_adapter.menu import menu_lines
from benchmark_adapter.metrics import EpisodeResult, TrajectoryError, score_trajectory
from benchmark_adapter.metrics.result import RUN_IDENTIFIERS
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import EMBEDDED
from cocobench_agents.prompts import parse_reply
from cocobench_agents.tools.decisions import prompt_hash

Status = Literal["verified", "mismatch", "unverifiable"]
#: Item labels that land no call.
INIT, STOP = "init", "policy_stop"
#: Decision statuses of a reply read by the prompt suite's parser (`parse_reply`).
PARSED = ("action", "done", "parse_error", "invalid_action_id")
#: How the shipped prompt suites show an agent's hand.
HOLDING = "holding="
#: Result-line fields that are not the benchmark's numbers about the episode: the run's own
#: labels (which planner, which backend, how long it took).
NOT_SCORES = RUN_IDENTIFIERS | {"schema_version"}


@dataclass(frozen=True)
class Verdict:
    """What the replay of one episode found."""

    status: Status
    #: The first differing step (the trajectory item's index), when one is to blame.
    step: int | None = None
    #: The first differing field (``skill_result.success``, ``task_success``, …).
    field: str | None = None
    detail: str = ""

    def describe(self) -> str:
        """One line: ``mismatch at step 3, skill_result.success: recorded true, replay false``."""
        where = []
        if self.step is not None:
            where.append(f"step {self.step}")
        if self.field:
            where.append(self.field)
        head = f"{self.status} ({', '.join(where)})" if where else self.status
        return f"{head}: {self.detail}" if self.detail else head


class Mismatch(Exception):
    """The first difference found: where, and what."""

    def __init__(self, field: str, detail: str, step: int | None = None) -> None:
        super().__init__(detail)
        self.field, self.detail, self.step = field, detail, step


def verify_episode(document: Mapping[str, Any] | None, line: Mapping[str, Any], *,
                   prompts: Mapping[str, str] | None = None,
                   reference: Mapping[str, Mapping[str, Any]] | None = None,
                   stable_ids: bool = False) -> Verdict:
    """The verdict on one episode: its result `line`, its trajectory `document` (None when
    the run has none), the `prompts` its decisions name (None: not checked), and
    the `reference` configs by task id (an instance found there must carry that config)."""
    if line.get("infra_error"):
        return Verdict("unverifiable", detail=f"no trajectory: the episode ended on an "
                                              f"infrastructure error ({line['infra_error']})")
    if document is None:
        return Verdict("unverifiable", detail="no trajectory recorded for this result line")
    try:
        return _verify(document, line, prompts, reference or {}, stable_ids)
    except Mismatch as found:
        return Verdict("mismatch", found.step, found.field, found.detail)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError, RecursionError,
            OverflowError) as exc:
        # A recording no run writes (a field of another type, a call the skills cannot
        # parse): it does not replay, and says what failed.
        return Verdict("mismatch", field="trajectory", detail=f"the replay cannot execute "
                       f"the recording ({type(exc).__name__}: {str(exc)[:200]})")


def _verify(document: Mapping[str, Any], line: Mapping[str, Any],
            prompts: Mapping[str, str] | None, reference: Mapping[str, Mapping[str, Any]],
            stable_ids: bool) -> Verdict:
    config = _checked_config(document, line, reference)
    if line.get("backend", EMBEDDED) != EMBEDDED:
        _compare_scores(line, _scored(document))
        return Verdict("unverifiable", detail=f"recorded on the {line.get('backend')} "
                       "backend, whose physics is not replayed here; its metrics recomputed "
                       "from the trajectory as recorded match its result line")
    replayed = replay(config, document, prompts=prompts, stable_ids=stable_ids)
    _compare_scores(line, _scored(replayed))
    return Verdict("verified")


def _checked_config(document: Mapping[str, Any], line: Mapping[str, Any],
                    reference: Mapping[str, Mapping[str, Any]]) -> TaskConfig:
    recorded = document.get("task_config")
    if not isinstance(recorded, dict):
        raise Mismatch("task_config", "the trajectory records no task config")
    for name, value in (("trajectory task_id", document.get("task_id")),
                        ("task_config.task_id", recorded.get("task_id"))):
        if value != line.get("task_id"):
            raise Mismatch("task_id", f"the result line is for {line.get('task_id')!r}, "
                                      f"the {name} is {value!r}")
    own = reference.get(str(line.get("task_id")))
    if own is not None and own != recorded:
        difference = first_difference(own, recorded, "task_config")
        if difference is not None:
            path, expected, got = difference
            raise Mismatch(path, f"the reference's config of this instance has {expected}, "
                                 f"the trajectory's has {got}")
    try:
        return TaskConfig.model_validate(recorded)
    except ValidationError as exc:
        raise Mismatch("task_config", f"not a task config ({exc.error_count()} problems: "
                                      f"{exc.errors(include_url=False)[0]['msg']})") from None


def replay(config: TaskConfig, document: Mapping[str, Any], *,
           prompts: Mapping[str, str] | None = None, stable_ids: bool = False
           ) -> dict[str, Any]:
    """Execute the recorded episode again from `config`; the replayed trajectory document
    (with the recorded decisions). `Mismatch` at the first item, decision or top-level
    field that differs from the recording."""
    items = document.get("trajectory")
    if not isinstance(items, list) or not items:
        raise Mismatch("trajectory", "no trajectory items")
    decisions = document.get("planner_decisions") or []
    if not isinstance(decisions, list):
        raise Mismatch("planner_decisions", "not a list of decisions")
    by_step = _decisions_by_step(decisions)
    recorded_decisions = {_json(decision) for decision in decisions}
    episode = Episode(config)
    episode.reset()
    for index, recorded in enumerate(items):
        if not isinstance(recorded, dict):
            raise Mismatch("trajectory", "not a trajectory item (an object)", index)
        _check_decisions(episode, by_step.pop(episode.step_index, ()), prompts, stable_ids)
        if index > 0:
            _land(episode, recorded, index)
        _compare(recorded, episode.items[-1], index)
        decision = recorded.get("policy_decision")
        if ("skill_result" in recorded and decision is not None
                and _json(decision) not in recorded_decisions):
            raise Mismatch("policy_decision", "not one of the episode's planner_decisions "
                           "(a step's decision is recorded in both)", index)
    for leftover in by_step.values():  # decisions of steps the trajectory does not have
        step = leftover[0].get("step_index")
        raise Mismatch("planner_decisions.step_index", f"a decision at step {step}, which "
                       f"the episode never reached ({episode.step_index} steps landed)")
    rebuilt = _plain(episode.finish())
    for name in ("task_id", "init_trace", "final_eval"):
        difference = first_difference(document.get(name), rebuilt[name], name)
        if difference is not None:
            path, recorded_value, replayed_value = difference
            raise Mismatch(path, f"recorded {recorded_value}, replay {replayed_value}")
    rebuilt["planner_decisions"] = decisions
    return rebuilt


def _land(episode: Episode, recorded: Mapping[str, Any], index: int) -> None:
    label = recorded.get("label")
    if label == INIT:
        raise Mismatch("label", "a second init item", index)
    if label == STOP:
        episode.stop(recorded.get("policy_decision"))  # type: ignore[arg-type]
        return
    if "skill_result" not in recorded or not isinstance(label, str):
        raise Mismatch("label", f"not a landed call, nor init or policy_stop ({label!r})",
                       index)
    options: dict[str, Any] = {"decision": recorded.get("policy_decision")}
    if "round_index" in recorded:
        options.update(round_index=recorded["round_index"], message=recorded.get("message"))
    episode.step(label, **options)


def _compare(recorded: Mapping[str, Any], replayed: Mapping[str, Any], index: int) -> None:
    # Equal JSON bytes (the item is built in the recorded key order) are the common case,
    # and the fast one: the field-by-field walk only names what differs.
    if _json(recorded) != _json(replayed):
        difference = first_difference(recorded, _plain(replayed))
        path, recorded_value, replayed_value = difference or ("(item)", "", "")
        raise Mismatch(path, f"recorded {recorded_value}, replay {replayed_value}", index)
    decision = recorded.get("policy_decision")
    call = decision.get("parsed_call") if isinstance(decision, dict) else None
    if "skill_result" in recorded and call is not None and call != recorded.get("label"):
        raise Mismatch("policy_decision.parsed_call", f"the decision chose {call!r}, the "
                       f"step landed {recorded.get('label')!r}", index)


def _decisions_by_step(decisions: Sequence[Any]) -> dict[int, list[dict[str, Any]]]:
    by_step: dict[int, list[dict[str, Any]]] = {}
    for number, decision in enumerate(decisions):
        step = decision.get("step_index") if isinstance(decision, dict) else None
        if type(step) is not int:
            raise Mismatch(f"planner_decisions[{number}].step_index",
                           "a decision without a step index")
        by_step.setdefault(step, []).append(decision)
    return by_step


def _check_decisions(episode: Episode, decisions: Sequence[dict[str, Any]],
                     prompts: Mapping[str, str] | None, stable_ids: bool) -> None:
    """Each decision taken at this step against the replayed state: its prompt's text, and
    a parsed reply's action id and call on the replayed menu."""
    if not decisions:
        return
    observation = episode.observe()
    for decision in decisions:
        agent = decision.get("agent")
        entries = [e for e in observation.action_menu if agent is None or e.agent == agent]
        text = _prompt_text(decision, prompts, episode.step_index)
        parsed = decision.get("status") in PARSED and "parse_mode" in decision
        if parsed and not stable_ids:
            _check_reply(decision, entries, episode.step_index)
            if text is not None:
                for shown in (menu_lines(entries, centralized=agent is None),
                              _holdings(text, agent, observation.inventories)):
                    _check_shown(text, shown, decision, episode.step_index)


def _prompt_text(decision: Mapping[str, Any], prompts: Mapping[str, str] | None,
                 step: int) -> str | None:
    hashed = decision.get("prompt_hash")
    if prompts is None or hashed is None:
        return None
    text = prompts.get(hashed)
    if text is None:
        raise Mismatch("policy_decision.prompt_hash", f"{hashed}: no kept prompt has this "
                       "hash", step)
    if prompt_hash(text) != hashed:
        raise Mismatch("policy_decision.prompt_hash", f"{hashed}: the kept prompt of this "
                       f"hash hashes to {prompt_hash(text)}", step)
    return text


def _check_reply(decision: Mapping[str, Any], entries: Sequence[Any], step: int) -> None:
    parsed = parse_reply(decision.get("raw_output"), [e.action_id for e in entries])
    call = (next((e.call for e in entries if e.action_id == parsed.action_id), None)
            if parsed.status == "action" else None)
    for name, replayed in (("status", parsed.status),
                           ("parsed_action_id", parsed.raw_choice),
                           ("parsed_call", call)):
        if decision.get(name) != replayed:
            raise Mismatch(f"policy_decision.{name}", f"the reply "
                           f"{_shown(decision.get('raw_output'))} on the replayed menu gives "
                           f"{_shown(replayed)}, the decision records "
                           f"{_shown(decision.get(name))}", step)


def _holdings(text: str, agent: str | None, inventories: Mapping[str, Sequence[str]]
              ) -> list[str]:
    """What a prompt that shows the agents' hands (``holding=…``, as the shipped suites
    do) must say of them in the replayed state: each agent's (the deciding agent's alone in
    its own prompt)."""
    if HOLDING not in text:
        return []
    shown = {a: HOLDING + (", ".join(ids) or "empty") for a, ids in inventories.items()}
    if agent is not None:
        return [shown[agent]] if agent in shown else []
    return [f"{a}: {hand}" for a, hand in shown.items()]


def _check_shown(text: str, lines: Sequence[str], decision: Mapping[str, Any],
                 step: int) -> None:
    if "\n".join(lines) in text:  # a menu is listed in one block: one search for it all
        return
    missing = next((line for line in lines if line not in text), None)
    if missing is not None:
        raise Mismatch("policy_decision.prompt_hash", f"the prompt {decision['prompt_hash']} "
                       f"does not show the replayed state of this step (no "
                       f"{missing.strip()!r})", step)


def _scored(document: Mapping[str, Any]) -> EpisodeResult:
    try:
        return score_trajectory(document)
    except (TrajectoryError, TypeError, KeyError, ValueError, AttributeError) as exc:
        raise Mismatch("trajectory", f"the scorer cannot read it ({exc})") from None


def _compare_scores(line: Mapping[str, Any], result: EpisodeResult) -> None:
    """Every score the result line carries against the one recomputed."""
    scores = result.model_dump(mode="json")
    for name in scores:
        if name in NOT_SCORES or name not in line:
            continue
        difference = first_difference(line[name], scores[name], name)
        if difference is not None:
            path, recorded, recomputed = difference
            raise Mismatch(path, f"the result line says {recorded}, the replayed trajectory "
                                 f"scores {recomputed}")


def first_difference(recorded: Any, replayed: Any, path: str = ""
                     ) -> tuple[str, str, str] | None:
    """The first place where two JSON values differ: (dotted path, recorded, replayed), the
    values shown short; None when they are equal (a number equals the same number of the
    other kind, 1 and 1.0, never a boolean)."""
    for where, left, right in _differences(recorded, replayed, path):
        return where or "(whole)", _shown(left), _shown(right)
    return None


def _differences(left: Any, right: Any, path: str) -> Iterator[tuple[str, Any, Any]]:
    if isinstance(left, dict) and isinstance(right, dict):
        for key in list(left) + [k for k in right if k not in left]:
            here = f"{path}.{key}" if path else str(key)
            if key not in left or key not in right:
                yield here, left.get(key, "(absent)"), right.get(key, "(absent)")
                return
            yield from _differences(left[key], right[key], here)
    elif isinstance(left, list) and isinstance(right, list) and len(left) == len(right):
        for i, (a, b) in enumerate(zip(left, right)):
            yield from _differences(a, b, f"{path}[{i}]")
    elif left != right or (type(left) is not type(right) and not _same_number(left, right)):
        yield path, left, right


def _same_number(left: Any, right: Any) -> bool:
    # A float that is a whole number is written by JSON as `1.0` and read back as a float;
    # an int read back stays an int: only a bool passing for a number is another value.
    numbers = (int, float)
    return (isinstance(left, numbers) and isinstance(right, numbers)
            and not isinstance(left, bool) and not isinstance(right, bool) and left == right)


def _json(value: Any) -> bytes:
    return orjson.dumps(value, option=orjson.OPT_NON_STR_KEYS)


def _plain(value: Any) -> Any:
    """`value` as JSON reads it back (tuples as lists, keys as text)."""
    return orjson.loads(_json(value))


def _shown(value: Any, limit: int = 80) -> str:
    text = json.dumps(value, ensure_ascii=False, default=str)
    return text if len(text) <= limit else text[:limit - 1] + "…"

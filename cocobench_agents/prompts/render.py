"""Rendering the planner prompts from a suite's templates (reference §6.2, §6.3)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from cocobench_agents.prompts.fields import view_template
from cocobench_agents.prompts.suite import PromptSuite


@dataclass(frozen=True)
class PromptInputs:
    """Everything a prompt shows, as plain data."""

    agents: Sequence[str]
    goal_text: str
    progress_text: str
    hint: str
    menu_lines: Sequence[str]
    history: Sequence[str]  # "call -> ok" / "call -> FAIL(…)", oldest first
    inventories: Mapping[str, Sequence[str]]
    obs_mode: str  # one of the observation modes (benchmark_adapter.vocabulary)
    messages: Sequence[Mapping[str, str]] = field(default_factory=tuple)  # {agent, text}


def render_centralized(suite: PromptSuite, inputs: PromptInputs) -> str:
    """The centralized planner's prompt (one planner, every agent's menu)."""
    return suite.render("centralized", **_team_fields(suite, inputs))


def render_leader(suite: PromptSuite, inputs: PromptInputs) -> str:
    """The leader–worker strategy's leader prompt: one instruction per robot."""
    reply_format = "\n".join(f"{a}: <instruction>" for a in inputs.agents)
    return suite.render("leader", **_team_fields(suite, inputs), reply_format=reply_format)


def _team_fields(suite: PromptSuite, inputs: PromptInputs) -> dict[str, object]:
    """The fields of a prompt that sees the whole team (centralized planner, leader)."""
    agents = ", ".join(inputs.agents)
    state_lines = [f"  {a}: holding={_holding(inputs.inventories.get(a))}" for a in inputs.agents]
    return {
        "n": len(inputs.agents), "agents": agents,
        "view": suite.render(view_template(inputs.obs_mode, "centralized"), agents=agents),
        "goal": inputs.goal_text,
        "progress_section": _progress(suite, inputs),
        "hint": _hint(inputs),
        "menu": "\n".join(inputs.menu_lines),
        "history_section": _history(suite, inputs, "centralized"),
        "state": suite.render("state_centralized", agent_lines="\n".join(state_lines)),
    }


def render_distributed(suite: PromptSuite, inputs: PromptInputs, me: str, broadcast: bool
                       ) -> str:
    """One agent's prompt in a decentralized team; `broadcast` adds the message board."""
    comm = msg_hint = ""
    if broadcast:
        window = suite.setting("message_window", 6)
        others = [m for m in inputs.messages if m.get("agent") != me][-window:]
        board = "\n".join(f"  {m.get('agent')}: {m.get('text')}" for m in others)
        comm = suite.render("comm_block", board=board or "  (no messages yet)")
        msg_hint = suite.render("msg_hint")
    return suite.render(
        "distributed",
        me=me, n=len(inputs.agents), agents=", ".join(inputs.agents),
        view=suite.render(view_template(inputs.obs_mode, "distributed")),
        goal=inputs.goal_text,
        progress_section=_progress(suite, inputs),
        hint=_hint(inputs), comm=comm, msg_hint=msg_hint,
        menu="\n".join(inputs.menu_lines),
        history_section=_history(suite, inputs, "distributed"),
        inv=_holding(inputs.inventories.get(me)),
    )


def render_own(suite: PromptSuite, template: str, inputs: PromptInputs, me: str | None,
               fields: Mapping[str, object], *, placeholders: bool = False) -> str:
    """A planner's own `template` (`PlannerSpec.templates`), as `ask` renders it: the
    strategy's `fields` over the view of agent `me` (the team's when None; `ASK_FIELDS`),
    whose `menu` is `inputs.menu_lines`. A field neither gives is a `ValueError` naming it; with
    `placeholders`, it is shown as `{name}` (a preview: the strategy's fields are unknown)."""
    view = _team_fields(suite, inputs) if me is None else _agent_fields(suite, inputs, me)
    values = {**view, **fields}
    if placeholders:
        values = _Placeholders(values)
    try:
        return suite.templates[template].format_map(values)
    except KeyError as exc:
        if template not in suite.templates:
            own = ", ".join(sorted(suite.own)) or "none"
            raise ValueError(f"no template {template!r} in prompt suite {suite.spec} (a "
                             f"planner's own templates: {own}; declare it in the "
                             "PlannerSpec's templates)") from None
        raise ValueError(f"template {template!r} uses the field {{{exc.args[0]}}}, which was "
                         f"not given (given: {', '.join(sorted(fields)) or 'none'}; filled: "
                         f"{', '.join(sorted(view))})") from None


class _Placeholders(dict):
    def __missing__(self, key: str) -> str:
        return f"{{{key}}}"


def _agent_fields(suite: PromptSuite, inputs: PromptInputs, me: str) -> dict[str, object]:
    """The fields of agent `me`'s view a planner's own template may use."""
    return {"me": me, "n": len(inputs.agents), "agents": ", ".join(inputs.agents),
            "view": suite.render(view_template(inputs.obs_mode, "distributed")),
            "goal": inputs.goal_text, "progress_section": _progress(suite, inputs),
            "hint": _hint(inputs), "menu": "\n".join(inputs.menu_lines),
            "history_section": _history(suite, inputs, "distributed"),
            "inv": _holding(inputs.inventories.get(me))}


def _progress(suite: PromptSuite, inputs: PromptInputs) -> str:
    if "no-progress" in suite.variants:
        return ""
    return suite.render("progress_section", goal_progress=inputs.progress_text)


def _history(suite: PromptSuite, inputs: PromptInputs, kind: str) -> str:
    if "no-history" in suite.variants:
        return ""
    window = suite.setting("history_window", 6)
    lines = [f"  {i}. {h}" for i, h in enumerate(list(inputs.history)[-window:], 1)]
    return suite.render(f"history_section_{kind}", history="\n".join(lines) or "  (none yet)")


def _hint(inputs: PromptInputs) -> str:
    return inputs.hint + "\n" if inputs.hint else ""


def _holding(ids: Sequence[str] | None) -> str:
    return ", ".join(ids or []) or "empty"


def history_line(call: str, success: bool, error: str, error_chars: int = 60) -> str:
    """One history entry: `call -> ok` or `call -> FAIL(first 60 chars of the error)`."""
    return f"{call} -> ok" if success else f"{call} -> FAIL({(error or '')[:error_chars]})"

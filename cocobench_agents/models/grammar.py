"""GBNF grammars for constrained decoding: a reply that can only name a menu id or DONE."""

from __future__ import annotations

from collections.abc import Iterable

from .protocol import MenuOption, Prompt, prompt_words

# The REASON and MSG lines are capped so that a constrained reply always reaches its ACTION
# line well within a modest max_tokens (a model that rambles would otherwise be cut off first).
REASON_MAX_CHARS = 300
MSG_MAX_CHARS = 200  # the reference truncates messages to 200 characters anyway


def wants_message(prompt: Prompt) -> bool:
    """Whether the prompt (its text, or its text parts) asks for a broadcast `MSG:` line."""
    return "MSG:" in prompt_words(prompt)


def menu_grammar(menu: Iterable[MenuOption], *, with_msg: bool = False) -> str:
    """A GBNF grammar for ``REASON: <text>\\nACTION: <menu id | DONE>`` (plus an optional
    ``\\nMSG: <text>`` line when `with_msg`). Ids are listed longest first so that a
    prefix id (``1`` vs ``12``) never hides a longer one."""
    ids = sorted({str(int(o.action_id)) for o in menu}, key=lambda s: (-len(s), s))
    action = " | ".join(f'"{i}"' for i in [*ids, "DONE"])
    lines = [
        'root ::= "REASON: " reason "\\nACTION: " action' + (" msg?" if with_msg else ""),
        f"reason ::= [^\\n]{{1,{REASON_MAX_CHARS}}}",
        f"action ::= {action}",
    ]
    if with_msg:
        lines.append(f'msg ::= "\\nMSG: " [^\\n]{{1,{MSG_MAX_CHARS}}}')
    return "\n".join(lines) + "\n"

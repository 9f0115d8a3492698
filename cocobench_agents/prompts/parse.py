"""Reading a model's reply: the chosen action id and the broadcast message (reference §5.4)."""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass

ACTION_LINE = re.compile(r"ACTION:\s*(\d+|DONE)", re.IGNORECASE)
BARE_INTEGER = re.compile(r"\b(\d+)\b")
MESSAGE_LINE = re.compile(r"MSG:\s*(.+)")
MESSAGE_LIMIT = 200


@dataclass(frozen=True)
class ParsedReply:
    """What a reply asks for.

    status: `action`, `done`, `parse_error` or `invalid_action_id`;
    mode: `action_line`, `bare_integer` or None (nothing usable found).
    """

    status: str
    action_id: int | None = None
    mode: str | None = None
    error: str | None = None

    @property
    def raw_choice(self) -> str | None:
        """The choice as the reference records it (`"12"`, `"DONE"`)."""
        if self.status == "done":
            return "DONE"
        return None if self.action_id is None else str(self.action_id)


def parse_reply(text: str | None, menu_ids: Collection[int]) -> ParsedReply:
    """The first `ACTION:` line, else the first bare integer anywhere (it may come from the
    REASON text — the reference's behaviour); ids not in `menu_ids` are invalid."""
    text = text or ""
    match = ACTION_LINE.search(text)
    mode = "action_line"
    if match is None:
        match, mode = BARE_INTEGER.search(text), "bare_integer"
        if match is None:
            return ParsedReply("parse_error", error="missing ACTION line or integer")
    choice = match.group(1)
    if choice.upper() == "DONE":
        return ParsedReply("done", mode=mode)
    action_id = int(choice)
    # Compared as text, as the reference does: "007" is not the id 7.
    if choice not in {str(i) for i in menu_ids}:
        return ParsedReply("invalid_action_id", action_id, mode, "action id not in current menu")
    return ParsedReply("action", action_id, mode)


def parse_message(text: str | None) -> str:
    """The first `MSG:` line's text, stripped and cut to 200 characters ("" if none)."""
    match = MESSAGE_LINE.search(text or "")
    return match.group(1).strip()[:MESSAGE_LIMIT] if match else ""

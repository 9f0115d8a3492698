"""Reading a model's reply: the chosen action id and the broadcast message (reference §5.4)."""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass

ACTION_LINE = re.compile(r"ACTION:\s*(\d+|DONE)", re.IGNORECASE)
BARE_INTEGER = re.compile(r"\b(\d+)\b")
MESSAGE_LINE = re.compile(r"MSG:\s*(.+)")
MESSAGE_LIMIT = 200
_MAX_ID_DIGITS = 18  # no menu holds 10^18 entries; int() of 5,000 digits raises


@dataclass(frozen=True)
class ParsedReply:
    """What a reply asks for.

    status: `action`, `done`, `parse_error` or `invalid_action_id`;
    action_id: the menu id chosen (status `action` only);
    mode: `action_line`, `bare_integer` or None (nothing usable found);
    choice: the id exactly as the model wrote it (`"12"`, `"007"`, a 5,000-digit number).
    """

    status: str
    action_id: int | None = None
    mode: str | None = None
    error: str | None = None
    choice: str | None = None

    @property
    def raw_choice(self) -> str | None:
        """The choice as the reference records it (`"12"`, `"DONE"`)."""
        return "DONE" if self.status == "done" else self.choice


def parse_reply(text: str | None, menu_ids: Collection[int]) -> ParsedReply:
    """The first `ACTION:` line, else the first bare integer anywhere (it may come from the
    REASON text — the reference's behaviour); ids not in `menu_ids` are invalid.

    Never raises: whatever the model wrote is its own protocol outcome, never a harness error.
    The id is matched as text against the menu, as the reference does (so `"007"` is not the
    id 7), and never converted on its own: an absurdly long number is just not on the menu.
    """
    text = text if isinstance(text, str) else ""
    match = ACTION_LINE.search(text)
    mode = "action_line"
    if match is None:
        match, mode = BARE_INTEGER.search(text), "bare_integer"
        if match is None:
            return ParsedReply("parse_error", error="missing ACTION line or integer")
    choice = match.group(1)
    if choice.upper() == "DONE":
        return ParsedReply("done", mode=mode)
    action_id = _menu_id(choice, menu_ids)
    if action_id is None:
        return ParsedReply("invalid_action_id", None, mode, "action id not in current menu",
                           choice)
    return ParsedReply("action", action_id, mode, choice=choice)


def _menu_id(choice: str, menu_ids: Collection[int]) -> int | None:
    """The menu id whose text is exactly `choice`, or None. Only ASCII digits without a
    leading zero, no longer than any id, can be one (`\\d` also matches other scripts'
    digits, which `int` reads): a dict of every id's text per decision cost more than the
    rest of the parse."""
    if (len(choice) > _MAX_ID_DIGITS or not choice.isascii()
            or (choice[0] == "0" and choice != "0")):
        return None
    action_id = int(choice)
    return action_id if action_id in menu_ids else None


def parse_message(text: str | None) -> str:
    """The first `MSG:` line's text, stripped and cut to 200 characters ("" if none)."""
    match = MESSAGE_LINE.search(text if isinstance(text, str) else "")
    return match.group(1).strip()[:MESSAGE_LIMIT] if match else ""

"""A person at the play page in a real browser (Playwright), for the browser tests."""

from __future__ import annotations

import re
from typing import Any

from playwright.sync_api import expect


class Player:
    """A person at the play page, choosing menu entries by the call they stand for."""

    def __init__(self, page: Any) -> None:
        self.page = page
        self.chosen: list[int | None] = []  # the ids chosen, None for DONE

    def pending(self) -> str:
        """The id of the decision shown, once its menu can be clicked."""
        menu = self.page.locator("#menu[data-decision]")
        expect(menu).to_have_count(1)
        expect(self.page.locator("#menu button").first).to_be_enabled()
        return menu.get_attribute("data-decision")

    def menu(self) -> list[str]:
        """The buttons' accessible names."""
        self.pending()
        return self.page.locator("#menu button").all_inner_texts()

    def choose(self, call: str | None, *, keyboard: bool = False, message: str = "") -> None:
        """Choose the entry of `call` (DONE when None or not on the menu), by its button or
        by typing its id and Enter; wait until the page has moved on."""
        page, decision = self.page, self.pending()
        if message:
            page.fill("#message", message)
            page.evaluate("document.activeElement.blur()")
        entry = page.locator(f'#menu button[title="{call}"]')
        if call is None or entry.count() == 0:
            page.get_by_role("button", name=re.compile(r"^DONE: ")).click()
            self.chosen.append(None)
        else:
            action_id = int(entry.inner_text().split(":")[0])
            if keyboard:
                page.keyboard.type(str(action_id))
                expect(page.locator("#typed")).to_contain_text(f"Action {action_id}")
                page.keyboard.press("Enter")
            else:
                page.get_by_role("button", name=re.compile(rf"^{action_id}: ")).click()
            self.chosen.append(action_id)
        expect(page.locator(f'#menu[data-decision="{decision}"]')).to_have_count(0)

    def replies(self) -> list[str]:
        """What a `scripted:` model replies to make the same choices."""
        return [f"ACTION: {'DONE' if c is None else c}" for c in self.chosen]

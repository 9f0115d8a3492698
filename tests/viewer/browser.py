"""Debian's headless chromium driven by Playwright (never Playwright's own browser build),
for the viewer's end-to-end test and `bench/viewer.py`."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def why_unavailable() -> str | None:
    """Why the browser cannot run here (None when it can)."""
    if shutil.which("chromium") is None:
        return "Debian's chromium is not installed (apt-get install chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install -e '.[dev]')"
    return None


@contextlib.contextmanager
def chromium_page(width: int = 1400, height: int = 900) -> Iterator[Any]:
    """A page of a fresh headless chromium with its own throwaway profile."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile, \
            sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            profile, executable_path=shutil.which("chromium"), args=CHROMIUM_ARGS,
            headless=True, viewport={"width": width, "height": height})
        try:
            yield context.new_page()
        finally:
            context.close()


def screenshots_folder(tmp_path: Path) -> Path:
    """Where browser tests keep their screenshots (COCOBENCH_VIEWER_SCREENSHOTS, else a
    temporary folder)."""
    folder = Path(os.environ.get("COCOBENCH_VIEWER_SCREENSHOTS") or tmp_path / "screenshots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def assert_inline_script_refused(page: Any) -> None:
    """An inline script added to the page does not run, and the refusal is logged."""
    with page.expect_console_message(lambda m: "Policy" in m.text):
        page.evaluate("document.body.appendChild(document.createElement('script')).text"
                      " = 'window.injected = 1'")
    assert page.evaluate("window.injected") is None

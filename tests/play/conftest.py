"""Runs started by a test end with it, even when it fails while the run waits for a person;
the browser tests' page, screenshots folder, and the oracle's calls of the demo instance."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.human.desks import oracle_calls
from tests.play.played_run import DEMO, WAIT_S, PlayedRun, StartRun
from tests.viewer.browser import chromium_page, screenshots_folder


@pytest.fixture
def start_run() -> Iterator[StartRun]:
    started: list[PlayedRun] = []

    def start(*args: str) -> PlayedRun:
        started.append(PlayedRun(*args))
        return started[-1]

    yield start
    for run in started:
        if run.process.poll() is None:
            run.kill()


@pytest.fixture(scope="module")
def calls(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """The calls the oracle lands on the demo instance, in order."""
    return oracle_calls(tmp_path_factory.mktemp("oracle") / "run", task=DEMO)


@pytest.fixture
def shots(tmp_path: Path) -> Path:
    return screenshots_folder(tmp_path)


@pytest.fixture
def page() -> Iterator[Any]:
    with chromium_page() as page:
        page.set_default_timeout(WAIT_S * 1000)
        yield page

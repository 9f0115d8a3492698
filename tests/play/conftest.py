"""Runs started by a test end with it, even when it fails while the run waits for a person."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.play.played_run import PlayedRun, StartRun


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

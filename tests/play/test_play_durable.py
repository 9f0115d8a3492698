"""An answer is on disk before the page is told it was taken: the play server answers 200
only once the answer's line is in the run's answer log (whole and fsync'd), so a kill right
after the 200 loses nothing the person was told was accepted."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import pytest

from cocobench_agents.harness.human_log import LoggedDesk, answers_file
from cocobench_agents.play.desk import PlayDesk
from cocobench_agents.play.server import PlayServer
from cocobench_agents.runfolder.folder import RunFolder
from tests.play.played_run import StartRun, answers_logged
from tests.play.test_play_cli import RUN_ARGS
from tests.play.test_play_cli import call as run_call
from tests.play.test_play_cli import pending as run_pending
from tests.play.test_play_server import Engine, call, decision, pending


def test_the_200_comes_after_the_answer_is_logged(tmp_path: Path) -> None:
    desk = PlayDesk()
    logged = LoggedDesk(desk, RunFolder(tmp_path))
    engine = Engine(desk)
    asked = decision()
    log = tmp_path / answers_file(asked.episode)
    try:
        with PlayServer(desk, 0) as server:
            answered = asyncio.run_coroutine_threadsafe(logged.ask(asked), engine.loop)
            shown = pending(server)
            # The engine's loop is busy (a slow step of a teammate, a long prompt to render)
            # when the person clicks: the answer waits for it, the page must too.
            engine.loop.call_soon_threadsafe(time.sleep, 1.0)
            status, body = call(server, "POST", "/play/api/answer",
                                body={"decision": shown["id"], "action_id": 7,
                                      "reason": "r", "message": "hello"})
            on_disk = log.read_text() if log.exists() else ""
            assert (status, body) == (200, {"accepted": shown["id"]})
            assert '"action_id": 7' in on_disk and '"message": "hello"' in on_disk
            assert answered.result(10).action_id == 7
    finally:
        engine.close()
    assert len(log.read_text().splitlines()) == 1  # logged once, not again by the engine


def test_an_answer_that_cannot_be_logged_is_not_taken(tmp_path: Path) -> None:
    desk = PlayDesk()
    folder = tmp_path / "run"
    folder.mkdir()
    logged = LoggedDesk(desk, RunFolder(folder))
    engine = Engine(desk)
    asked = decision()
    try:
        with PlayServer(desk, 0) as server:
            answered = asyncio.run_coroutine_threadsafe(logged.ask(asked), engine.loop)
            shown = pending(server)
            # The answer log cannot be created: its folder's place is taken by a file.
            (folder / "episodes").write_text("not a folder")
            status, body = call(server, "POST", "/play/api/answer",
                                body={"decision": shown["id"], "action_id": 3})
            assert status == 503 and "could not be recorded" in body["error"]
            assert pending(server)["id"] == shown["id"] and not answered.done()
            (folder / "episodes").unlink()  # room again: the same decision is answered
            status, _ = call(server, "POST", "/play/api/answer",
                             body={"decision": shown["id"], "action_id": 7})
            assert status == 200 and answered.result(10).action_id == 7
    finally:
        engine.close()
    (line,) = (folder / answers_file(asked.episode)).read_text().splitlines()
    assert '"action_id": 7' in line


@pytest.mark.slow
def test_a_kill_right_after_the_200_loses_no_answer(start_run: StartRun,
                                                     tmp_path: Path) -> None:
    # The reproduction: before the fix, 4 of 6 such kills lost the answer.
    for trial in range(3):
        out = tmp_path / f"human{trial}"
        run = start_run(*RUN_ARGS, "--out", str(out))
        decision_id = run_pending(run)["decision"]["id"]
        status, _ = run_call(run, "POST", "/play/api/answer",
                             body={"decision": decision_id, "action_id": None})
        run.kill()  # SIGKILL, the moment the 200 is read
        assert status == 200
        assert [line["decision"] for line in answers_logged(out)] == [decision_id]

"""`cocobench run --model human` over real HTTP, without a browser: only the player plays
(the token, the Host, the menu), a refused request records nothing, the token stays out of
the run folder, and `--port` is the page's port."""

from __future__ import annotations

import http.client
import json
import socket
import time
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main
from cocobench_agents.play.server import TOKEN_HEADER
from tests.play.played_run import (
    DEMO,
    WAIT_S,
    PlayedRun,
    StartRun,
    answers_logged,
    assert_token_nowhere,
    result_lines,
)

RUN_ARGS = ("--model", "human", "--conditions", "C0_blind", "--suite", "demo",
            "--task-id", DEMO)


def call(run: PlayedRun, method: str, path: str, *, body: Any = None, token: bool = True,
         host: str | None = None) -> tuple[int, Any]:
    connection = http.client.HTTPConnection("127.0.0.1", run.port, timeout=WAIT_S)
    headers = {"Host": host or f"127.0.0.1:{run.port}", "Content-Type": "application/json"}
    if token:
        headers[TOKEN_HEADER] = run.token
    try:
        connection.request(method, path, body=None if body is None else json.dumps(body),
                           headers=headers)
        response = connection.getresponse()
        return response.status, json.loads(response.read())
    finally:
        connection.close()


def pending(run: PlayedRun) -> dict[str, Any]:
    deadline = time.monotonic() + WAIT_S
    while True:
        status, state = call(run, "GET", "/play/api/state")
        if status == 200 and state["decision"] is not None:
            return state
        assert time.monotonic() < deadline, "no decision came"
        time.sleep(0.05)


@pytest.mark.slow
def test_only_the_player_plays(start_run: StartRun, tmp_path: Path) -> None:
    out = tmp_path / "human"
    run = start_run(*RUN_ARGS, "--out", str(out))
    state = pending(run)
    decision = state["decision"]
    off_menu = max(option["id"] for option in decision["menu"]) + 1
    refused = [
        call(run, "POST", "/play/api/answer", body={"decision": decision["id"], "action_id": 0},
             token=False),
        call(run, "POST", "/play/api/answer", body={"decision": decision["id"], "action_id": 0},
             host=f"rebound.example:{run.port}"),
        call(run, "POST", "/play/api/answer",
             body={"decision": decision["id"], "action_id": off_menu}),
        call(run, "POST", "/play/api/answer", body={"decision": decision["id"]}),
        call(run, "GET", "/play/api/state", token=False),
    ]
    assert [status for status, _ in refused] == [403, 403, 422, 400, 403]
    assert all("error" in body for _, body in refused)
    assert answers_logged(out) == [] and call(run, "GET", "/play/api/state")[1] == state

    assert call(run, "POST", "/play/api/answer",
                body={"decision": decision["id"], "action_id": None})[0] == 200  # DONE
    assert run.wait() == 0
    (result,) = result_lines(out)
    assert result["terminal_reason"] == "done" and len(answers_logged(out)) == 1
    assert "play: http://127.0.0.1:" in "".join(run.stderr)
    assert_token_nowhere(out, run.token)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.slow
def test_port_chooses_the_page_s_port(start_run: StartRun, tmp_path: Path) -> None:
    port = free_port()
    run = start_run(*RUN_ARGS, "--out", str(tmp_path / "human"), "--port", str(port))
    assert run.url.startswith(f"http://127.0.0.1:{port}/play?token=")
    decision = pending(run)["decision"]
    call(run, "POST", "/play/api/answer", body={"decision": decision["id"], "action_id": None})
    assert run.wait() == 0


def test_a_port_in_use_stops_the_run_before_anything_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = tmp_path / "human"
        assert main(["run", *RUN_ARGS, "--out", str(out), "--port", str(port),
                     "--no-browser"]) == 2
    assert f"port {port} on 127.0.0.1 is already in use" in capsys.readouterr().err
    assert not out.exists()


def test_a_run_without_human_seats_serves_no_page(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    assert main(["run", "--model", "greedy", "--conditions", "C0_blind", "--suite", "demo",
                 "--task-id", DEMO, "--max-steps", "2", "--out", str(tmp_path / "greedy")]) == 0
    assert "play:" not in capsys.readouterr().err


def test_a_refused_request_announces_no_page(tmp_path: Path,
                                             capsys: pytest.CaptureFixture) -> None:
    assert main(["run", *RUN_ARGS, "--executor", "ray", "--out", str(tmp_path / "human"),
                 "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert "human seats need the local executor" in err and "play:" not in err

"""The play desk and its server over real HTTP on 127.0.0.1, without the engine: a thread
with its own event loop asks decisions as the engine does. Only the player plays (token,
Host), a refused answer changes nothing, and answers reach the asking seat."""

from __future__ import annotations

import asyncio
import dataclasses
import http.client
import json
import logging
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from typing import Any
from urllib.parse import quote

import pytest

from cocobench_agents.engine import events
from cocobench_agents.models.human import Answer, Decision
from cocobench_agents.play.desk import AskedTwice, PlayDesk
from cocobench_agents.play.prompt_parts import agent_label, menu_labels, prompt_parts
from cocobench_agents.play.server import TOKEN_HEADER, PlayServer

PROMPT = """You are agent_1, one of 2 robots (agent_1, agent_2).

GOAL: Put the Apple in the Fridge

GOAL PROGRESS (live simulator state — trust this over your action history):
  [✗] Put the Apple in the Fridge
  0/1 objectives complete.

TEAMMATE MESSAGES (most recent last):
  agent_2: I open the fridge

YOUR ACTION MENU (action_id: skill):
  3: agent_1: pick up the Apple
  7: agent_1: wait

YOUR RECENT ACTIONS (most recent last):
  1. Find(agent_1, Apple) -> ok

YOUR STATE: holding=empty"""


def decision(n: int = 1, *, wants_message: bool = True) -> Decision:
    return Decision(id=f"human/D1_blind/T#agent_1#{n}", seat="agent_1", prompt=PROMPT,
                    episode="human/D1_blind/T",
                    menu=({"id": 3, "skill": "PickUp", "call": "PickUp(agent_1, Apple)"},
                          {"id": 7, "skill": "Wait", "call": "Wait(agent_1)"}),
                    wants_message=wants_message)


class Engine:
    """Stands in for the engine's thread: its own event loop, asking the desk."""

    def __init__(self, desk: PlayDesk) -> None:
        self.desk = desk
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    def ask(self, asked: Decision) -> Future[Answer]:
        return asyncio.run_coroutine_threadsafe(self.desk.ask(asked), self.loop)

    def close(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)


@pytest.fixture
def desk() -> PlayDesk:
    return PlayDesk()


@pytest.fixture
def engine(desk: PlayDesk) -> Iterator[Engine]:
    engine = Engine(desk)
    yield engine
    engine.close()


@pytest.fixture
def server(desk: PlayDesk) -> Iterator[PlayServer]:
    with PlayServer(desk, 0) as server:
        yield server


def call(server: PlayServer, method: str, path: str, *, body: Any = None,
         token: str | None = "ok", host: str | None = None) -> tuple[int, Any]:
    """One HTTP request: the run's token in the header unless `token` is None (or the given
    wrong one), the server's own Host unless `host`."""
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    headers = {"Host": host or f"127.0.0.1:{server.port}"}
    if token is not None:
        headers[TOKEN_HEADER] = server.token if token == "ok" else token
    data = body if isinstance(body, bytes) or body is None else json.dumps(body).encode()
    if data is not None:
        headers["Content-Type"] = "application/json"
    try:
        connection.request(method, path, body=data, headers=headers)
        response = connection.getresponse()
        text = response.read().decode()
        kind = response.getheader("Content-Type", "")
        return response.status, json.loads(text) if "json" in kind else text
    finally:
        connection.close()


def state(server: PlayServer) -> dict[str, Any]:
    status, body = call(server, "GET", "/play/api/state")
    assert status == 200
    return body


def wait_until(check: Callable[[], bool], timeout: float = 10) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def pending(server: PlayServer) -> dict[str, Any]:
    wait_until(lambda: state(server)["decision"] is not None)
    return state(server)["decision"]


def test_the_page_needs_the_token_in_its_query(server: PlayServer) -> None:
    status, html = call(server, "GET", f"/play?token={server.token}", token=None)
    assert status == 200 and "cocobench play" in html and server.token not in html
    assert call(server, "GET", "/play", token=None)[0] == 403
    assert call(server, "GET", "/play?token=wrong", token=None)[0] == 403
    # the header is for the API; the page itself is opened from the printed URL
    assert call(server, "GET", "/play")[0] == 403
    assert server.play_url == f"http://127.0.0.1:{server.port}/play?token={server.token}"


def test_the_page_runs_only_its_own_script(server: PlayServer) -> None:
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    connection.request("GET", f"/play?token={server.token}")
    response = connection.getresponse()
    policy = response.getheader("Content-Security-Policy")
    connection.close()
    assert "default-src 'none'" in policy and "script-src 'sha256-" in policy
    assert response.getheader("Referrer-Policy") == "no-referrer"


def test_api_calls_need_the_token_header_and_the_own_host(server: PlayServer,
                                                          engine: Engine) -> None:
    engine.ask(decision())
    shown = pending(server)
    answer = {"decision": shown["id"], "action_id": 3}
    for kwargs in ({"token": None}, {"token": "wrong"}, {"token": server.token[:-1]},
                   {"host": f"attacker.example:{server.port}"}, {"host": "127.0.0.1:1"}):
        assert call(server, "GET", "/play/api/state", **kwargs)[0] == 403, kwargs
        status, body = call(server, "POST", "/play/api/answer", body=answer, **kwargs)
        assert status == 403 and "error" in body, kwargs
    assert state(server)["decision"]["id"] == shown["id"]  # nothing taken
    assert call(server, "GET", "/play/api/state", host=f"localhost:{server.port}")[0] == 200


@pytest.mark.parametrize(("body", "status", "says"), [
    (b"not json", 400, "malformed"),
    (b"", 400, "malformed"),
    ([3], 400, "malformed"),
    ({"action_id": 3}, 400, "decision"),
    ({"decision": "D", "action_id": "3"}, 400, "action_id"),
    ({"decision": "D", "action_id": True}, 400, "action_id"),
    ({"decision": "D", "action_id": 3, "cheat": 1}, 400, "cheat"),
    ({"decision": "D", "action_id": 3, "reason": "x" * 1001}, 400, "reason"),
    # longer than a teammate would read (a model's message is cut there)
    ({"decision": "D", "action_id": 3, "message": "x" * 201}, 400, "message"),
    ({"decision": "D", "action_id": 4}, 422, "not on the menu"),
    ({"decision": "D", "action_id": 3, "message": "hi"}, 422, "sends no messages"),
    ({"decision": "human/D1_blind/T#agent_1#9", "action_id": 3}, 409, "not waiting"),
])
def test_a_refused_answer_changes_nothing(server: PlayServer, engine: Engine, body: Any,
                                          status: int, says: str) -> None:
    asked = engine.ask(decision(wants_message=False))
    shown = pending(server)
    if isinstance(body, dict) and body.get("decision") == "D":
        body = body | {"decision": shown["id"]}
    before = state(server)
    got, reply = call(server, "POST", "/play/api/answer", body=body)
    assert (got, says in reply["error"]) == (status, True), reply
    assert state(server) == before and not asked.done()


def test_a_too_large_body_is_refused(server: PlayServer, engine: Engine) -> None:
    engine.ask(decision())
    pending(server)
    status, reply = call(server, "POST", "/play/api/answer", body=b"{" + b" " * 20_000 + b"}")
    assert status == 413 and "larger" in reply["error"]


def test_an_answer_reaches_the_seat_once(server: PlayServer, engine: Engine) -> None:
    asked = engine.ask(decision())
    shown = pending(server)
    assert [(o["agent"], o["label"]) for o in shown["menu"]] == [
        ("agent_1", "pick up the Apple"), ("agent_1", "wait")]
    assert shown["parts"]["messages"] == "agent_2: I open the fridge"
    answer = {"decision": shown["id"], "action_id": 3, "reason": "closest",
              "message": "apple is mine"}
    assert call(server, "POST", "/play/api/answer", body=answer) == (
        200, {"accepted": shown["id"]})
    got = asked.result(10)
    assert (got.action_id, got.reason, got.message) == (3, "closest", "apple is mine")
    assert got.think_s > 0
    status, reply = call(server, "POST", "/play/api/answer", body=answer | {"action_id": 7})
    assert status == 409 and "not waiting" in reply["error"]
    assert state(server)["decision"] is None


def test_done_is_answered_with_a_null_id(server: PlayServer, engine: Engine) -> None:
    asked = engine.ask(decision())
    shown = pending(server)
    status, _ = call(server, "POST", "/play/api/answer",
                     body={"decision": shown["id"], "action_id": None})
    assert status == 200 and asked.result(10).action_id is None


def test_a_waiting_state_request_answers_when_a_decision_comes(server: PlayServer,
                                                               engine: Engine) -> None:
    version = state(server)["version"]
    waiting: Future[tuple[int, Any]] = Future()
    threading.Thread(target=lambda: waiting.set_result(
        call(server, "GET", f"/play/api/state?after={version}")), daemon=True).start()
    with pytest.raises(FutureTimeout):  # the request waits on the server for a change
        waiting.result(0.3)
    engine.ask(decision())
    status, body = waiting.result(10)
    assert status == 200 and body["decision"]["id"] == decision().id
    assert call(server, "GET", "/play/api/state?after=x")[0] == 400


def test_one_decision_is_asked_at_a_time(server: PlayServer, engine: Engine) -> None:
    """The runner asks one at a time (`SeatDesk`); a second ask meanwhile is its bug."""
    first = engine.ask(decision(1))
    pending(server)
    with pytest.raises(AskedTwice):
        engine.ask(decision(2)).result(10)
    assert state(server)["decision"]["id"] == decision(1).id and not first.done()


def test_a_cancelled_ask_is_withdrawn(server: PlayServer, engine: Engine) -> None:
    asked = engine.ask(decision())
    shown = pending(server)
    asked.cancel()  # the episode timed out, or the run was interrupted
    wait_until(lambda: state(server)["decision"] is None)
    status, _ = call(server, "POST", "/play/api/answer",
                     body={"decision": shown["id"], "action_id": 3})
    assert status == 409


def test_the_run_s_events_and_its_end_are_shown(server: PlayServer, desk: PlayDesk,
                                                tmp_path: Any) -> None:
    desk.on_event(events.RunStarted(tmp_path, 2, 0))
    key = {"model": "human", "condition": "C0_blind", "task_id": "T"}
    desk.on_event(events.EpisodeStarted(key))
    desk.on_event(events.StepLanded(key, {}))  # not shown
    record = key | {"task_success": True, "construct_score": 0.5, "terminal_reason": "done",
                    "num_steps": 4, "usage": {"prompt_tokens": 0}}
    desk.on_event(events.EpisodeRecorded(record))
    shown = state(server)
    assert shown["run"]["total"] == 2 and shown["episode"] == key
    assert shown["outcomes"] == [{k: record.get(k) for k in shown["outcomes"][0]}]
    assert shown["outcomes"][0]["construct_score"] == 0.5 and "usage" not in shown["outcomes"][0]
    desk.finish("2 of 2 episodes recorded")
    assert state(server)["ended"] == "2 of 2 episodes recorded"


def test_prompt_parts_of_the_shipped_suite() -> None:
    parts = prompt_parts(PROMPT)
    assert parts == {
        "goal": "Put the Apple in the Fridge",
        "progress": "[✗] Put the Apple in the Fridge\n0/1 objectives complete.",
        "messages": "agent_2: I open the fridge",
        "menu": "3: agent_1: pick up the Apple\n7: agent_1: wait",
        "history": "1. Find(agent_1, Apple) -> ok",
        "state": "holding=empty"}
    assert menu_labels(parts) == {3: "agent_1: pick up the Apple", 7: "agent_1: wait"}
    assert prompt_parts("a prompt of one's own wording") == {}


def test_an_answer_to_a_decision_no_longer_asked_is_refused(server: PlayServer,
                                                              engine: Engine) -> None:
    """A stale tab, or the second click of a double click, names the decision it was made
    on: once a newer one is asked, the server refuses it and the newer one stays open."""
    first = engine.ask(decision(1))
    shown = pending(server)
    assert call(server, "POST", "/play/api/answer",
                body={"decision": shown["id"], "action_id": 3})[0] == 200
    first.result(10)
    second = engine.ask(decision(2))
    wait_until(lambda: (state(server)["decision"] or {}).get("id") == decision(2).id)
    status, reply = call(server, "POST", "/play/api/answer",
                         body={"decision": shown["id"], "action_id": 7})
    assert status == 409 and set(reply) == {"error"}
    assert f"{shown['id']!r} is not waiting" in reply["error"]
    assert f"asked now: {decision(2).id}" in reply["error"]
    assert state(server)["decision"]["id"] == decision(2).id and not second.done()


HISTORY_PROMPT = PROMPT.replace("  1. Find(agent_1, Apple) -> ok", "\n".join([
    "  1. Find(agent_1, Apple) -> ok",
    "  2. PickUp(agent_1, Apple) -> FAIL(too far)"]))


def steps_landed(desk: PlayDesk, key: dict[str, Any],
                 steps: list[tuple[int, str, str]]) -> None:
    for index, agent, label in steps:
        desk.on_event(events.StepLanded(key, {"step_index": index, "label": label,
                                              "skill_result": {"agent": agent}}))


def test_recent_actions_are_numbered_by_the_episode_s_steps(server: PlayServer, desk: PlayDesk,
                                                            engine: Engine) -> None:
    key = {"model": "greedy", "condition": "D1_blind", "task_id": "T", "epoch": 0, "arm": ""}
    desk.on_event(events.EpisodeStarted(key | {"models": {"agent_1": "human",
                                                          "agent_2": "greedy"}}))
    steps_landed(desk, key, [(1, "agent_2", "Find(agent_2, Fridge)"),
                             (2, "agent_1", "Find(agent_1, Apple)"),
                             (3, "agent_2", "Open(agent_2, Fridge)"),
                             (4, "agent_1", "PickUp(agent_1, Apple)")])
    steps_landed(desk, key | {"task_id": "other"}, [(5, "agent_1", "Wait(agent_1)")])
    engine.ask(dataclasses.replace(decision(), prompt=HISTORY_PROMPT))
    shown = pending(server)
    assert shown["parts"]["history"] == ("step 2: Find(agent_1, Apple) -> ok\n"
                                         "step 4: PickUp(agent_1, Apple) -> FAIL(too far)")
    assert shown["last_action"] == "step 4: PickUp(agent_1, Apple) -> FAIL(too far)"
    assert state(server)["episode"]["models"] == {"agent_1": "human", "agent_2": "greedy"}


@pytest.mark.parametrize("steps", [
    [],  # no step kept (the lines are not the episode's)
    [(2, "agent_1", "Find(agent_1, Apple)"), (4, "agent_1", "Open(agent_1, Fridge)")],
])
def test_recent_actions_that_are_not_the_steps_keep_the_prompt_s_numbers(
        server: PlayServer, desk: PlayDesk, engine: Engine, steps: list) -> None:
    key = {"model": "human", "condition": "D1_blind", "task_id": "T"}
    desk.on_event(events.EpisodeStarted(key))
    steps_landed(desk, key, steps)
    engine.ask(dataclasses.replace(decision(), prompt=HISTORY_PROMPT))
    shown = pending(server)
    assert shown["parts"]["history"] == prompt_parts(HISTORY_PROMPT)["history"]
    assert shown["last_action"] is None


def test_a_centralized_menu_line_names_its_agent_once() -> None:
    assert agent_label("agent_1: find a Fridge [agent_1]") == ("agent_1", "find a Fridge")
    assert agent_label("agent_2: put object in hand on the CoffeeTable") == (
        "agent_2", "put object in hand on the CoffeeTable")
    assert agent_label("find a Fridge") == (None, "find a Fridge")


@pytest.mark.parametrize("given", [b"\xff\xfe", "é".encode(), b"\x80" * 43])
def test_a_token_of_raw_bytes_is_refused_cleanly(server: PlayServer, given: bytes,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    # A header of bytes that are not ASCII: a 403, never a 500 with a traceback on the
    # player's terminal (aiohttp logs a handler's exception there).
    caplog.set_level(logging.WARNING)
    for path in ("/play/api/state", f"/play?token={given.decode('latin-1')}"):
        connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
        connection.putrequest("GET", quote(path, safe="/?="), skip_host=True)
        connection.putheader("Host", f"127.0.0.1:{server.port}")
        connection.putheader(TOKEN_HEADER, given)
        connection.endheaders()
        response = connection.getresponse()
        body = json.loads(response.read())
        connection.close()
        assert response.status == 403 and "token" in body["error"], path
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR or r.exc_info]

"""The play server over real HTTP on 127.0.0.1 against malformed requests: every malformed
number, path, query or body is answered 4xx, never 5xx, nothing of the disk is ever served,
and every answer carries a Content-Security-Policy and `nosniff`."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.play import server as play_server
from cocobench_agents.play.desk import PlayDesk
from cocobench_agents.play.server import POLICY, TOKEN_HEADER, PlayServer
from tests.play.test_play_server import Engine, decision
from tests.viewer.browser import assert_inline_script_refused, chromium_page
from tests.viewer.hostile import Answer, Markers, plant_markers, send, targets


@dataclass(frozen=True)
class Played:
    """A play server asking one decision, with markers planted in two folders."""

    server: PlayServer
    markers: Markers

    def send(self, target: bytes | str, *, token: bool = True, **kwargs: Any) -> Answer:
        """`send` to this server, with the run's token in its header unless `token` is
        False."""
        headers = {TOKEN_HEADER: self.server.token} if token else {}
        return send(self.server.port, target, headers=headers, **kwargs)


@pytest.fixture(scope="module")
def played(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Played]:
    desk = PlayDesk()
    engine = Engine(desk)
    markers = plant_markers(tmp_path_factory.mktemp("beside"), tmp_path_factory.mktemp("out"))
    # a state request naming the current version would wait for a change: not here
    with pytest.MonkeyPatch.context() as patch, PlayServer(desk, 0) as server:
        patch.setattr(play_server, "LONG_POLL_S", 0.01)
        engine.ask(decision())
        yield Played(server, markers)
    engine.close()


@pytest.mark.parametrize("after", [
    "%C2%B2", "%EF%BC%91", "-1", "%2B1", "1_0", "", "%00", "0x1",
    pytest.param("9" * 5000, id="5000 digits"),
])
def test_a_state_version_that_is_not_plain_ascii_digits_is_a_400(played: Played,
                                                                 after: str) -> None:
    answer = played.send(f"/play/api/state?after={after}")
    assert answer.status == 400
    error = json.loads(answer.raw.partition(b"\r\n\r\n")[2])["error"]
    assert error.startswith("after (a state version) must be a whole number")


def test_raw_non_ascii_digits_are_a_400(played: Played) -> None:
    assert played.send(b"/play/api/state?after=\xc2\xb2").status == 400  # aiohttp's parser


def test_every_answer_carries_a_policy_and_nosniff(played: Played) -> None:
    token = played.server.token
    answers = {
        "page": played.send(f"/play?token={token}", token=False),
        "state": played.send("/play/api/state?after=0"),
        "no token": played.send("/play/api/state", token=False),
        "unknown": played.send("/play/static/play.js"),
        "bad number": played.send("/play/api/state?after=x"),
        "refused": played.send("/play/api/answer", method="POST",
                               body=b'{"decision": "gone", "action_id": 3}'),
    }
    assert {k: a.status for k, a in answers.items()} == {
        "page": 200, "state": 200, "no token": 403, "unknown": 404, "bad number": 400,
        "refused": 409}
    for answer in answers.values():
        assert answer.header("X-Content-Type-Options") == "nosniff"
    page = answers.pop("page").header("Content-Security-Policy") or ""
    assert page.startswith(POLICY) and "script-src 'sha256-" in page
    assert "'unsafe-inline'" not in page
    assert all(a.header("Content-Security-Policy") == POLICY for a in answers.values())


def bodies() -> st.SearchStrategy[bytes]:
    """Answer bodies: raw bytes, or JSON objects with odd fields and values."""
    value = st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(),
                      st.text(max_size=20), st.lists(st.integers(), max_size=2))
    fields = st.dictionaries(st.sampled_from(["decision", "action_id", "reason", "message",
                                              "x"]), value, max_size=5)
    return st.one_of(st.binary(max_size=64), fields.map(lambda f: json.dumps(f).encode()))


@pytest.mark.slow
@pytest.mark.parametrize("route", [
    "GET /play?token=TOKEN", "GET /play?token={n}", "GET /play/api/state?after={n}",
    "GET /play/api/state/{p}", "POST /play/api/answer", "POST /play/api/answer?after={n}",
    "GET /play/{p}", "GET /{p}", "HEAD /static/{p}"])
@settings(max_examples=40, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_no_request_gets_a_5xx_or_a_byte_from_outside(played: Played, route: str,
                                                      data: Any) -> None:
    """Generated paths, queries and bodies at every route (with the token: a request without
    it never reaches a route): never a 5xx, never the markers."""
    method, _, route = route.replace("TOKEN", played.server.token).partition(" ")
    target = data.draw(targets(route, list(played.markers.files)), label="target")
    body = data.draw(bodies(), label="body") if method == "POST" else None
    answer = played.send(target, method=method, body=body)
    assert answer.status < 500
    assert played.markers.secret not in answer.raw


@pytest.mark.slow
@pytest.mark.needs_browser
def test_the_page_works_under_its_policy(played: Played) -> None:
    """The page's inline script and style run (allowed by their hashes) and nothing is
    refused; an injected inline script is, and the refusal is logged where this test looks."""
    refused: list[str] = []
    with chromium_page() as page:
        page.on("console", lambda m: refused.append(m.text) if "Policy" in m.text else None)
        page.goto(played.server.play_url)
        page.wait_for_selector("#menu button")  # drawn by the script from the API's state
        background = page.eval_on_selector("header.top", "h => getComputedStyle(h).background"
                                                         "Color")
        assert background == "rgb(35, 40, 58)"  # the inline style applied
        assert refused == []
        assert_inline_script_refused(page)
    assert len(refused) == 1 and "script-src" in refused[0], refused

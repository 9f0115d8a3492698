"""What `cocobench view` serves over real HTTP on 127.0.0.1, and nothing more: the package's
static files, the files inside the runs given (links leading out are not followed), its pages;
every malformed number, path or query is answered 4xx, never 5xx, and every answer (aiohttp's
own 400s included) carries the viewer's Content-Security-Policy, `nosniff` and
`Cross-Origin-Resource-Policy`."""

from __future__ import annotations

import json
import logging
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import POLICY, STATIC, ViewerServer
from cocobench_agents.viewer.source import Catalog

from .browser import assert_inline_script_refused, chromium_page
from .hostile import Markers, encodings, plant_markers, send, targets


@dataclass(frozen=True)
class Hostile:
    """A viewer of a run with markers beside it and in a folder outside it, and links in it:
    `inner.json` (to its `run.json`), `frame.png` (to the marker beside it) and `escape` (to
    the folder outside)."""

    port: int
    run: Path
    markers: Markers  # beside the run, and in the folder outside


@pytest.fixture(scope="module")
def hostile(fixed_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Hostile]:
    run = Path(shutil.copytree(fixed_run, tmp_path_factory.mktemp("hostile") / "run"))
    outside = tmp_path_factory.mktemp("outside")
    markers = plant_markers(run.parent, outside)
    (run / "inner.json").symlink_to("run.json")
    (run / "frame.png").symlink_to(run.parent / "marker.txt")
    (run / "escape").symlink_to(outside, target_is_directory=True)
    with ViewerServer(Pages.create(Catalog([run]), live=True), 0) as server:
        yield Hostile(server.port, run, markers)


@pytest.mark.parametrize("target", [
    "/static/%2fetc%2fpasswd", "/static/..%2f__init__.py", "/static/..%2fserver.py",
    "/static/%2e%2e%2fserver.py", "/static/%5c..%5cserver.py", "/static/..%5cserver.py",
    "/static/%252e%252e%252fserver.py", "/static/.", "/static/%2e", "/static/viewer.js%00",
    "/static/", "/files/0/..%2f..%2fetc%2fpasswd", "/files/0/%2fetc%2fpasswd",
    "/files/0/%c0%ae%c0%ae%c0%afetc%c0%afpasswd", "/files/0/", "/files/1/run.json",
])
def test_traversal_probes_find_nothing(hostile: Hostile, target: str) -> None:
    answer = send(hostile.port, target)
    assert answer.status == 404, target
    assert b"root:" not in answer.raw and b"import" not in answer.raw


@pytest.mark.parametrize("target", [
    "/api/rows?since=%C2%B2", "/api/rows?since=%EF%BC%91", "/api/rows?since=-1",
    "/api/rows?since=%2B1", "/api/rows?since=1_0", "/api/rows?since=", "/api/rows?since=%00",
    "/files/%C2%B2/run.json", "/files/-1/run.json", "/files/%2B0/run.json",
    pytest.param("/api/rows?since=" + "9" * 5000, id="since=5000 digits"),
    pytest.param("/files/" + "9" * 5000 + "/run.json", id="files/5000 digits"),
])
def test_a_number_that_is_not_plain_ascii_digits_is_a_400(hostile: Hostile,
                                                          target: str) -> None:
    answer = send(hostile.port, target)
    assert answer.status == 400, target
    error = json.loads(answer.raw.partition(b"\r\n\r\n")[2])["error"]
    assert "must be a whole number (1 to 15 digits 0-9)" in error


def test_a_request_aiohttp_cannot_parse_is_a_400_and_no_traceback(
        hostile: Hostile, caplog: pytest.LogCaptureFixture) -> None:
    """Raw non-ASCII bytes (as `curl '...?since=²'` sends them) never reach a route."""
    with caplog.at_level(logging.DEBUG):
        for target in (b"/api/rows?since=\xc2\xb2", b"/static/\xc0\xaf", b"/files/\xff/x"):
            assert send(hostile.port, target).status == 400
    assert [r for r in caplog.records if r.exc_info] == []


def test_only_the_package_s_static_files_are_served(hostile: Hostile) -> None:
    shipped = [r for r in STATIC.iterdir() if r.is_file()]
    assert {r.name for r in shipped} >= {"viewer.js", "viewer.css"}
    for resource in shipped:
        answer = send(hostile.port, f"/static/{resource.name}")
        assert answer.status == 200 and answer.raw.endswith(resource.read_bytes())
    assert send(hostile.port, "/static/viewer.js").header("Content-Type") == "text/javascript"
    own = str(STATIC / "viewer.js")  # even the right file, named by its absolute path
    for target in encodings(Path(own)):
        assert send(hostile.port, f"/static/{target}").status == 404, target


def test_run_files_are_read_only_from_inside_the_run(hostile: Hostile) -> None:
    run_json = (hostile.run / "run.json").read_bytes()
    for inside in ("run.json", "inner.json", "episodes/..%2frun.json", "./run.json"):
        answer = send(hostile.port, f"/files/0/{inside}")
        assert (answer.status, answer.raw.endswith(run_json)) == (200, True), inside
    beside, out = hostile.markers.files
    for target in ["frame.png", "escape/marker.txt", "..%2fmarker.txt", "%2e%2e/marker.txt",
                   *encodings(beside), *encodings(out)]:
        answer = send(hostile.port, f"/files/0/{target}")
        assert answer.status == 404, target
        assert hostile.markers.secret not in answer.raw


def test_a_trajectory_or_frame_linked_from_outside_is_not_read(run_copy: Path,
                                                               tmp_path: Path) -> None:
    record = json.loads((run_copy / "results.jsonl").read_text().splitlines()[0])
    trajectory = run_copy / record["trajectory"]
    document = json.loads(trajectory.read_text())
    document["trajectory"][0]["image"] = "frame.png"  # a link to a file outside the run
    document["trajectory"][1]["image"] = "kept.png"  # a real frame inside it
    outside = tmp_path / "outside"
    outside.mkdir()
    markers = plant_markers(outside)
    (run_copy / "frame.png").symlink_to(markers.files[0])
    (run_copy / "kept.png").write_bytes(b"\x89PNG frame")
    (outside / "trajectory.json").write_text(json.dumps(document))
    trajectory.unlink()
    trajectory.symlink_to(run_copy / "inside.json")  # first a link that stays inside
    (run_copy / "inside.json").write_text(json.dumps(document))
    pages = Pages.create(Catalog([run_copy]), live=False)
    episode = pages.catalog.episodes()[0]
    assert 'id="step-1"' in pages.episode(episode)
    site = tmp_path / "site"
    assert main(["view", str(run_copy), "--export", str(site)]) == 0
    copied = {p.name for p in (site / "files").rglob("*") if p.is_file()}
    assert copied == {"kept.png"}  # the frame linked outside is not copied
    assert all(markers.secret not in p.read_bytes() for p in site.rglob("*") if p.is_file())

    trajectory.unlink()
    trajectory.symlink_to(outside / "trajectory.json")  # now one leading out
    assert 'id="step-1"' not in pages.episode(episode)  # shown as an episode without one


def test_every_answer_carries_the_policy_nosniff_and_corp(hostile: Hostile) -> None:
    answers = [send(hostile.port, target) for target in (
        "/", "/static/viewer.css", "/api/rows", "/files/0/run.json", "/nope",
        "/api/rows?since=x", "/files/0/frame.png")]
    answers.append(send(hostile.port, "/", headers={"Host": "rebound.example"}))
    assert [a.status for a in answers] == [200, 200, 200, 200, 404, 400, 404, 403]
    for answer in answers:
        assert answer.header("Content-Security-Policy") == POLICY
        assert answer.header("X-Content-Type-Options") == "nosniff"
        assert answer.header("Cross-Origin-Resource-Policy") == "same-origin"
    assert "script-src 'self'" in POLICY and "'unsafe-inline'" not in POLICY


@pytest.mark.parametrize(("target", "method"), [
    (b"/api/rows?since=\xc2\xb2", "GET"), (b"/static/\xc0\xaf", "GET"),
    (b"/files/\xff/x", "GET"), (b"/" + b"a" * 9000, "GET"), (b"/index.html", "FOO"),
    (b"/<script>x</script>", "G\x01T")], ids=["raw ²", "overlong UTF-8", "raw 0xff",
                                              "over-long URL", "unknown method",
                                              "control byte in method"])
def test_the_400s_aiohttp_makes_itself_carry_the_headers_and_quote_nothing(
        hostile: Hostile, target: bytes, method: str) -> None:
    """A request aiohttp's parser refuses never reaches the application, its middleware or
    its signals: its 400 is given the same headers, and says nothing of the request."""
    answer = send(hostile.port, target, method=method)
    assert answer.status == 400
    assert answer.header("Content-Security-Policy") == POLICY
    assert answer.header("X-Content-Type-Options") == "nosniff"
    assert answer.header("Cross-Origin-Resource-Policy") == "same-origin"
    body = answer.raw.partition(b"\r\n\r\n")[2]
    assert body == b"400 Bad Request"


@pytest.mark.slow
@pytest.mark.parametrize("route", [
    "GET /static/{p}", "GET /files/{n}/{p}", "GET /files/0/{p}", "GET /files/0/escape/{p}",
    "GET /api/rows?since={n}", "GET /{p}", "GET /episode/{n}/{p}", "GET /compare/{p}.html",
    "HEAD /static/{p}", "POST /files/0/{p}"])
@settings(max_examples=50, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_no_request_gets_a_5xx_or_a_byte_from_outside(hostile: Hostile, route: str,
                                                      data: Any) -> None:
    """Generated paths and queries at every route: never a 5xx, never the markers."""
    method, _, route = route.partition(" ")
    markers = [*hostile.markers.files, hostile.run / "frame.png",
               hostile.run / "escape" / "marker.txt"]
    answer = send(hostile.port, data.draw(targets(route, markers), label="target"),
                  method=method)
    assert answer.status < 500
    assert hostile.markers.secret not in answer.raw


@pytest.mark.slow
@pytest.mark.needs_browser
def test_the_pages_work_under_the_policy(hostile: Hostile) -> None:
    """The viewer's script and style run and nothing is refused: a page broken by the policy
    would log the refusal in the console."""
    refused: list[str] = []
    base = f"http://127.0.0.1:{hostile.port}/"
    with chromium_page() as page:
        page.on("console", lambda m: refused.append(m.text) if "Policy" in m.text else None)
        page.goto(base)
        page.wait_for_selector("table.episodes tbody tr")  # drawn by the script
        assert page.locator("table.episodes tbody tr").count() == 8
        background = page.eval_on_selector("header.top", "h => getComputedStyle(h).background"
                                                         "Color")
        assert background == "rgb(35, 40, 58)"  # the stylesheet applied
        row = page.locator("table.episodes tbody tr").first
        episode, compare = (row.locator("a").nth(i).get_attribute("href") for i in (0, 1))
        page.goto(base + str(compare))
        page.wait_for_selector("#compare-pick select")
        page.goto(base + str(episode))
        page.wait_for_selector("svg.gantt")
        page.locator("#expand-prompts").click()  # the script works on this page too
        page.wait_for_selector("details.prompt[open]")
        assert refused == []
        # an inline script is refused, and the refusal is logged where this test looks
        assert_inline_script_refused(page)
    assert len(refused) == 1 and "script-src 'self'" in refused[0], refused

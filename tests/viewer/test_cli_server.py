"""`cocobench view` on the command line and its live server over real HTTP on 127.0.0.1:
what it serves, and how it fails (bad folders, a port in use, a non-empty export folder)."""

from __future__ import annotations

import http.client
import json
import re
import socket
import subprocess
import sys
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog

from .test_pages import listed


@pytest.fixture
def server(run_copy: Path) -> Iterator[ViewerServer]:
    with ViewerServer(Pages.create(Catalog([run_copy]), live=True), 0) as srv:
        yield srv


def get(url: str) -> tuple[int, str]:
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status, response.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, ""


def test_server_serves_pages_assets_and_live_rows(server: ViewerServer, run_copy: Path) -> None:
    assert server.url == f"http://127.0.0.1:{server.port}/"
    status, index = get(server.url)
    assert status == 200 and len(listed(index)) == 8
    href = listed(index)[0]["h"]
    status, episode = get(server.url + href)
    assert status == 200 and 'id="step-1"' in episode
    assert get(server.url + "static/viewer.css")[0] == 200
    assert get(server.url + "static/../pages.py")[0] == 404
    assert get(server.url + "files/0/../../etc/passwd")[0] == 404
    assert get(server.url + "episode/0/nope.html")[0] == 404
    line = (run_copy / "results.jsonl").read_text().splitlines()[0]
    seq = json.loads(get(server.url + "api/rows?since=0")[1])["seq"]
    with open(run_copy / "results.jsonl", "a") as f:
        f.write(json.dumps(json.loads(line) | {"epoch": 3}) + "\n")
    fresh = json.loads(get(server.url + f"api/rows?since={seq}")[1])
    assert len(fresh["rows"]) == 1 and fresh["episodes"] == 9
    assert len(listed(get(server.url)[1])) == 9  # no restart needed


def test_server_answers_only_to_its_own_address(server: ViewerServer) -> None:
    """A page that DNS rebinding points at 127.0.0.1 sends its own host name: refused."""
    def status(host: str) -> int:
        connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
        try:
            connection.request("GET", "/", headers={"Host": host})
            return connection.getresponse().status
        finally:
            connection.close()

    assert status(f"127.0.0.1:{server.port}") == status(f"localhost:{server.port}") == 200
    assert status(f"attacker.example:{server.port}") == 403
    assert status("127.0.0.1:1") == 403


def test_missing_folder_and_folder_without_run_json_exit_2(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture) -> None:
    assert main(["view", str(tmp_path / "nope"), "--no-browser"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"cocobench: error: {tmp_path / 'nope'}: no such run folder"
    (tmp_path / "results.jsonl").write_text("")
    assert main(["view", str(tmp_path), "--no-browser"]) == 2
    err = capsys.readouterr().err.strip()
    assert "no run.json" in err and len(err.splitlines()) == 1
    (tmp_path / "run.json").write_text("[1, 2")
    assert main(["view", str(tmp_path), "--no-browser"]) == 2
    assert "not a run record" in capsys.readouterr().err


def test_port_in_use_is_a_clear_error(fixed_run: Path, capsys: pytest.CaptureFixture) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["view", str(fixed_run), "--port", str(port), "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert f"port {port} on 127.0.0.1 is already in use" in err and "Traceback" not in err


def test_export_writes_a_self_contained_folder(fixed_run: Path, run_copy: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture) -> None:
    with open(run_copy / "results.jsonl", "a") as f:
        f.write("junk\n")
    out = tmp_path / "site"
    assert main(["view", str(fixed_run), str(run_copy), "--export", str(out)]) == 0
    captured = capsys.readouterr()
    assert "skipped 1 invalid result line(s)" in captured.err
    assert "16 episodes" in captured.out
    pages = [p for p in out.rglob("*.html")]
    assert len(pages) == 1 + 16 + 4  # runs, episodes, one compare page per instance
    for page in pages:  # every link and asset is relative and resolves inside the export
        html = page.read_text()
        assert 'data-live="false"' in html
        for ref in re.findall(r'(?:href|src)="([^"#?]+)', html):
            assert not ref.startswith(("/", "http")), ref
            assert (page.parent / ref).resolve().is_file(), (page, ref)
    for row in listed((out / "index.html").read_text()):  # the table's links
        assert (out / row["h"]).is_file() and (out / row["c"]).is_file()
    assert main(["view", str(fixed_run), "--export", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err


def test_view_help_imports_nothing_heavy() -> None:
    code = ("import sys; from cocobench_agents.cli import main; main(['view', '--help']); "
            "heavy = [m for m in ('jinja2', 'langgraph', 'litellm', 'numpy', "
            "'cocobench_agents.viewer.pages') if m in sys.modules]; print('HEAVY', heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "--export DIR" in out and "HEAVY []" in out

"""`cocobench run` with human seats in a subprocess (so that a test can kill it), its play
URL read from stderr, and what the tests check of its run folder."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import cocobench_agents as cb
from cocobench_agents.harness.human_log import HUMAN_ANSWERS

DEMO = "G_D1__DemoLivingRoom1__seed0"  # two agents; the oracle lands 8 calls
#: What differs between two plays with the same choices: how long they took, and by whom.
NOT_THE_PLAY = ("elapsed_s", "model", "models", "trajectory", "usage")
#: The longest a test waits for the run to start, a page to change, or the run to end.
WAIT_S = 120


class PlayedRun:
    """``cocobench run ARGS --no-browser``, running; `url` is its play page."""

    def __init__(self, *args: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "cocobench_agents.cli", "run", *args, "--no-browser"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.stderr: list[str] = []
        self.stdout: list[str] = []
        self._url: Future[str] = Future()
        threading.Thread(target=self._read_stderr, daemon=True).start()
        threading.Thread(target=lambda: self.stdout.extend(self.process.stdout or ()),
                         daemon=True).start()

    def _read_stderr(self) -> None:
        for line in self.process.stderr or ():
            self.stderr.append(line)
            if line.startswith("play: ") and not self._url.done():
                self._url.set_result(line.removeprefix("play: ").strip())
        if not self._url.done():
            self._url.set_exception(RuntimeError("no play URL:\n" + "".join(self.stderr)))

    @property
    def url(self) -> str:
        return self._url.result(WAIT_S)

    @property
    def token(self) -> str:
        return parse_qs(urlsplit(self.url).query)["token"][0]

    @property
    def port(self) -> int:
        return urlsplit(self.url).port or 0

    def wait(self) -> int:
        return self.process.wait(WAIT_S)

    def kill(self) -> None:
        self.process.kill()  # SIGKILL: nothing of the process runs after it
        self.process.wait(WAIT_S)


#: The `start_run` fixture: starts a `PlayedRun` that ends with the test.
StartRun = Callable[..., PlayedRun]


def result_lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def the_play(result: dict) -> dict:
    return {k: v for k, v in result.items() if k not in NOT_THE_PLAY}


def answers_logged(out: Path) -> list[dict]:
    return [json.loads(line) for path in sorted(out.rglob(HUMAN_ANSWERS))
            for line in path.read_text().splitlines()]


def scripted_result(folder: Path, replies: list[str], **fields) -> dict:
    """The result line of a `scripted:` run replying `replies` (a JSON script). On a thread
    of its own: the engine runs its own event loop, and Playwright's holds the test's."""
    folder.mkdir(parents=True)
    script = folder / "replies.json"
    script.write_text(json.dumps(replies))
    request = cb.RunRequest(out=folder / "run", models=[f"scripted:{script}"], **fields)
    with ThreadPoolExecutor(1) as thread:
        return thread.submit(cb.run, request).result()[0]


def assert_token_nowhere(out: Path, token: str) -> None:
    """Nothing of the token in any file of the run folder (gzip'd prompts included)."""
    for path in out.rglob("*"):
        if path.is_file():
            data = path.read_bytes()
            if path.suffix == ".gz":
                data = gzip.decompress(data)
            assert token[:12].encode() not in data, path

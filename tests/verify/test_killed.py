"""A `cocobench verify` killed mid-way (a worker process, or the whole command) leaves no
verdict behind to be taken for one, nor its unpacked bundle, and a rerun judges as before."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cocobench_agents.verify.run import PARALLEL_FROM
from tests.readers.test_reader_faults import ROOT

pytestmark = pytest.mark.slow  # a many-episode bundle packed, verify started and killed


def _start_verify(bundle: Path, tmp: Path) -> subprocess.Popen:
    """`verify --json` of `bundle` in its own session, its temporary files under `tmp`."""
    tmp.mkdir(exist_ok=True)
    return subprocess.Popen([sys.executable, "-m", "cocobench_agents.cli", "verify", str(bundle),
                             "--jobs", "2", "--json"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env={**os.environ, "TMPDIR": str(tmp)})


def _workers(process: subprocess.Popen, timeout: float = 120.0) -> list[int]:
    """The pids of `process`'s replaying workers, once it has started them."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and process.poll() is None:
        children = Path(f"/proc/{process.pid}/task/{process.pid}/children").read_text().split()
        if children:
            return [int(pid) for pid in children]
        time.sleep(0.02)
    raise AssertionError(f"verify started no worker: {process.communicate()}")


def test_a_killed_worker_stops_verify_in_one_line_without_a_verdict(many_episodes_bundle,
                                                                   tmp_path) -> None:
    tmp = tmp_path / "tmp"
    process = _start_verify(many_episodes_bundle, tmp)
    os.kill(_workers(process)[0], signal.SIGKILL)
    out, err = process.communicate(timeout=300)
    assert process.returncode == 1, err
    assert out == ""  # no verdict: a killed worker judged nothing
    assert err.startswith(f"Error: {many_episodes_bundle}: verify stopped: "), err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert list(tmp.iterdir()) == []  # the unpacked bundle is removed


def test_a_verify_killed_whole_is_judged_the_same_by_a_rerun(many_episodes_bundle,
                                                             tmp_path) -> None:
    tmp = tmp_path / "tmp"
    process = _start_verify(many_episodes_bundle, tmp)
    _workers(process)
    os.killpg(process.pid, signal.SIGKILL)  # the command and its workers, mid-way
    out, _ = process.communicate(timeout=60)
    assert out == ""
    rerun = _start_verify(many_episodes_bundle, tmp)
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    [outcome] = json.loads(out)
    assert outcome["ok"] and outcome["counts"] == {"verified": 128}
    assert len(outcome["episodes"]) == 128 >= PARALLEL_FROM
    assert list(tmp.iterdir()) == []  # the killed one's unpacked bundle is reclaimed too


def test_a_killed_packs_partial_bundle_is_removed_by_the_next_pack(demo_run, tmp_path) -> None:
    # A SIGKILL runs no clean-up: the hidden partial bundle stays until the next pack beside it.
    out = tmp_path / "demo.cocobench.tar.gz"
    process = subprocess.Popen([sys.executable, "-c", STAGER, str(out)], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    partial = Path(process.stdout.readline().strip())
    process.kill()
    process.wait(timeout=30)
    assert partial.exists() and partial.name.startswith(".demo.cocobench.tar.gz.")
    done = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "submit", "pack",
                           str(demo_run), "--out", str(out)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


# What `cocobench submit pack` stages, as a pack killed mid-way leaves it.
STAGER = """
import sys
from pathlib import Path
from cocobench_agents.partial_output import staged_beside

with staged_beside(Path(sys.argv[1]), folder=False) as partial:
    partial.write_bytes(b"half a tar")
    print(partial, flush=True)
    sys.stdin.read()
"""

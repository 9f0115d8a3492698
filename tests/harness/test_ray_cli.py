"""`cocobench run --executor ray` as users run it: a run SIGKILLed or interrupted midway leaves
no Ray process behind and `--resume` on Ray completes it into what an uninterrupted run
records; mistakes are one-line errors (exit 2) that never import Ray."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.harness.ray_local import children_of
from tests.harness.test_resume import RUN, cocobench, episodes, start_and_wait_for_results

RAY = ("--executor", "ray", "--jobs", "2")
TOTAL = 24  # the demo suite × all six conditions


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory) -> Path:
    """The same run, uninterrupted, with the local executor."""
    out = tmp_path_factory.mktemp("runs") / "whole"
    done = cocobench(out, "--jobs", "4")
    assert done.returncode == 0, done.stderr
    return out


def process_tree(pid: int) -> dict[int, str]:
    """Every descendant of `pid`, with its start time (pids may be reused later)."""
    out = {}
    for child in children_of(pid):
        out[child] = _start_time(child)
        out.update(process_tree(child))
    return out


def _start_time(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except OSError:
        return ""


def assert_all_gone(tree: dict[int, str], timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        left = [pid for pid, start in tree.items() if start and _start_time(pid) == start]
        if not left:
            return
        time.sleep(0.1)
    names = {pid: Path(f"/proc/{pid}/comm").read_text().strip() for pid in left
             if Path(f"/proc/{pid}/comm").exists()}
    raise AssertionError(f"orphaned Ray processes: {names}")


def without_nodes(recorded: dict[tuple, tuple]) -> dict[tuple, tuple]:
    """`episodes` without the node a Ray run records for each episode."""
    return {key: ({k: v for k, v in record.items() if k not in ("node", "requeued")}, text)
            for key, (record, text) in recorded.items()}


def wait_for_ray_workers(process: subprocess.Popen, count: int = 2) -> dict[int, str]:
    """The driver's process tree once `count` Ray workers are running episodes."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        tree = process_tree(process.pid)
        comms = [Path(f"/proc/{pid}/comm").read_text() for pid in tree
                 if Path(f"/proc/{pid}/comm").exists()]
        if sum("EpisodeWorker" in c or "ray::Episode" in c for c in comms) >= count:
            return tree
        time.sleep(0.1)
    return process_tree(process.pid)


@pytest.mark.needs_ray
@pytest.mark.slow
@pytest.mark.parametrize("stop", [signal.SIGKILL, signal.SIGINT], ids=["sigkill", "ctrl-c"])
def test_a_stopped_ray_run_leaves_nothing_behind_and_resumes(reference_run, tmp_path, stop):
    out = tmp_path / "stopped"
    process = start_and_wait_for_results(out, *RAY, count=3)
    tree = process_tree(process.pid)
    assert len(tree) >= 5, "the local Ray's processes run under the driver"
    os.kill(process.pid, stop)
    code = process.wait(timeout=60)
    recorded = len((out / "results.jsonl").read_text().splitlines())
    assert 3 <= recorded < TOTAL, "the stop must land midway"
    if stop == signal.SIGINT:
        assert code == 130
    assert_all_gone(tree)

    resumed = cocobench(out, "--resume", *RAY)
    assert resumed.returncode == 0, resumed.stderr
    assert f"({recorded} already done)" in resumed.stderr
    assert without_nodes(episodes(out)) == episodes(reference_run)


@pytest.mark.needs_ray
@pytest.mark.slow
def test_a_finished_ray_run_records_its_executor_and_leaves_nothing(tmp_path):
    out = tmp_path / "whole"
    process = subprocess.Popen([*RUN, "--out", str(out), *RAY], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    tree = wait_for_ray_workers(process)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 0, stderr
    assert "2 Ray workers (2 episodes at once) on a local Ray" in stderr
    assert '"executor": "ray"' in (out / "run.json").read_text()
    assert_all_gone(tree)


def test_ray_options_need_the_ray_executor(tmp_path, capsys):
    code = main(["run", "--suite", "demo", "--model", "greedy", "--out", str(tmp_path / "r"),
                 "--ray-address", "127.0.0.1:6379"])
    assert code == 2
    assert "ray_address (--ray-address) needs executor ray" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_a_missing_ray_names_the_extra_to_install(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if it were not installed
    code = main(["run", "--suite", "demo", "--model", "greedy", "--out", str(tmp_path / "r"),
                 "--executor", "ray"])
    err = capsys.readouterr().err
    assert code == 2
    assert "pip install 'cocobench-agents[ray]'" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()


@pytest.mark.needs_ray
def test_an_address_where_no_cluster_answers_is_a_quick_usage_error(tmp_path):
    started = time.monotonic()
    done = cocobench(tmp_path / "r", "--executor", "ray", "--ray-address", "127.0.0.1:9")
    assert done.returncode == 2, done.stderr
    assert "--ray-address 127.0.0.1:9: no Ray cluster answers there" in done.stderr
    assert "ray start --head" in done.stderr and "Traceback" not in done.stderr
    assert time.monotonic() - started < 60


def test_help_and_mistakes_do_not_import_ray():
    code = ("import sys; from cocobench_agents.cli import main; "
            "main(['run', '--help']); "
            "main(['run', '--suite', 'demo', '--model', 'greedy', '--out', '/nonexistent/x', "
            "'--ray-address', 'h:1']); "
            "print('ray' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.strip().splitlines()[-1] == "False", out.stderr

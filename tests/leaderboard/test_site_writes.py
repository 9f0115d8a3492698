"""The site folder is whole or absent: two leaderboards into one `--out` (at once, or one
after the other), one killed mid-way, one on a full disk."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.verify import pack
from tests.readers.test_reader_faults import ROOT, _mount


@pytest.fixture(scope="module")
def bundle(tmp_path_factory: pytest.TempPathFactory) -> Path:
    home = tmp_path_factory.mktemp("site-writes")
    assert main(["run", "--suite", "demo", "--model", "greedy", "--conditions", "C0_blind",
                 "--out", str(home / "run")]) == 0
    pack(home / "run", home / "greedy.cocobench.tar.gz")
    return home / "greedy.cocobench.tar.gz"


@pytest.fixture(scope="module")
def alone(bundle: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The site of `bundle` built with nothing else writing there."""
    out = tmp_path_factory.mktemp("alone") / "site"
    assert main(["leaderboard", str(bundle), "--out", str(out), "--jobs", "1"]) == 0
    return contents(out)


def contents(site: Path) -> dict[str, bytes]:
    """Every file of the site."""
    return {str(p.relative_to(site)): p.read_bytes()
            for p in sorted(site.rglob("*")) if p.is_file()}


def test_the_site_names_no_folder_of_the_machine_that_built_it(alone, bundle):
    """A published site holds no path of the builder's machine: not the temporary folder a
    bundle was unpacked in (the runs page showed it), not the bundle's own folder."""
    for name, data in alone.items():
        assert b"cocobench-bundle-" not in data, name
        assert str(bundle.parent).encode() not in data, name


def _start(bundle: Path, out: Path, **options) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cocobench_agents.cli", "leaderboard",
                             str(bundle), "--out", str(out), "--jobs", "1"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **options)


@pytest.mark.slow
def test_two_at_once_leave_one_whole_site_and_one_clear_refusal(bundle, alone, tmp_path):
    out = tmp_path / "site"
    first, second = _start(bundle, out), _start(bundle, out)
    done = [(p.wait(timeout=300), *p.communicate()) for p in (first, second)]
    assert sorted(code for code, _, _ in done) == [0, 2], done
    [(_, _, refused)] = [d for d in done if d[0] == 2]
    assert refused.startswith(f"cocobench: error: {out}: "), refused
    assert refused.count("\n") == 1 and "Traceback" not in refused
    assert contents(out) == alone  # the winner's site, nothing of the other mixed in
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]  # no hidden folder left


def test_one_after_another_keeps_the_first_site_whole(bundle, alone, tmp_path, capsys):
    out = tmp_path / "site"
    assert main(["leaderboard", str(bundle), "--out", str(out), "--jobs", "1"]) == 0
    assert main(["leaderboard", str(bundle), "--out", str(out), "--jobs", "1"]) == 2
    assert "exists and is not empty" in capsys.readouterr().err
    assert contents(out) == alone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]


@pytest.mark.slow
def test_a_leaderboard_killed_mid_way_leaves_no_site(bundle, alone, tmp_path):
    out = tmp_path / "site"
    process = _start(bundle, out, start_new_session=True)
    deadline = time.monotonic() + 120
    while not any(tmp_path.glob("*.partial")) and time.monotonic() < deadline:
        time.sleep(0.01)  # until it is writing its staged site
    os.killpg(process.pid, signal.SIGKILL)
    process.communicate(timeout=60)
    assert not out.exists()  # a half-written site is never at --out
    assert main(["leaderboard", str(bundle), "--out", str(out), "--jobs", "1"]) == 0
    assert contents(out) == alone
    assert [p.name for p in tmp_path.iterdir()] == ["site"]  # the killed one's staging too


@pytest.mark.slow
def test_a_full_disk_is_one_line_and_leaves_nothing(bundle, tmp_path):
    disk = tmp_path / "disk"
    _mount(disk, "size=64k")  # smaller than the site (its pages)
    try:
        process = _start(bundle, disk / "site")
        out, err = process.communicate(timeout=300)
        left = list(disk.iterdir())
    finally:
        subprocess.run(["umount", str(disk)], check=True)
    assert process.returncode == 1, err
    assert err.startswith("Error: cannot write ") and err.count("\n") == 1, err
    assert f" {disk / 'site'}" in err
    assert "No space left on device" in err and out == "" and left == []

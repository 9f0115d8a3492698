"""Submission bundles: packed with a manifest, verified as a folder is, refused when they do
not cover what they declare, labelled when their settings are not the reference's, and read
as data only (no link, no name leaving the folder, bounded sizes)."""

from __future__ import annotations

import io
import json
import resource
import signal
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from cocobench_agents.verify import bundle as bundle_module
from cocobench_agents.verify import pack, verify_source
from tests.readers.test_reader_faults import ROOT, _mount
from tests.verify.conftest import lines, write_lines

CopyRun = Callable[[], Path]


@pytest.fixture(scope="module")
def demo_bundle(demo_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bundle") / "demo.cocobench.tar.gz"
    pack(demo_run, out)
    return out


def members(bundle: Path) -> dict[str, bytes]:
    with tarfile.open(bundle, "r:gz") as tar:
        return {m.name: tar.extractfile(m).read() for m in tar if m.isfile()}


def write_bundle(path: Path, files: dict[str, bytes], extra: list[tarfile.TarInfo] = ()
                 ) -> Path:
    with tarfile.open(path, "w:gz") as tar:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
        for info in extra:
            tar.addfile(info)
    return path


def test_pack_writes_a_manifest_of_every_file(demo_run: Path, demo_bundle: Path,
                                              capsys) -> None:
    files = members(demo_bundle)
    manifest = json.loads(files["manifest.json"])
    assert set(files) - {"manifest.json"} == set(manifest["files"])
    assert {"run.json", "results.jsonl"} <= set(files)
    assert any(name.endswith("prompts.json.gz") for name in files)
    suite = manifest["suite"]
    assert suite["sources"] == ["demo"] and len(suite["instances"]) == 4
    assert manifest["conditions"] == ["C0_blind", "D1_blind"]
    assert manifest["prompt_suites"][0]["spec"] == "cocobench-v1"
    assert manifest["versions"]["cocobench_agents"]
    assert manifest["settings"]["max_steps"] == 10
    assert manifest["non_reference"] == {"max_steps": 10}  # labelled, not refused
    for name, entry in manifest["files"].items():
        assert entry["bytes"] == len(files[name])


def test_a_bundle_verifies_as_its_folder_does_with_its_label(demo_bundle: Path,
                                                             capsys) -> None:
    outcome = verify_source(demo_bundle, jobs=1)
    assert outcome.ok and outcome.counts["verified"] == 8
    assert outcome.labels == ["max_steps=10"]
    assert main(["verify", str(demo_bundle)]) == 0
    assert "not the reference's settings: max_steps=10" in capsys.readouterr().out


def test_pack_refuses_an_unfinished_run_and_an_existing_out(copy_run: CopyRun, tmp_path: Path,
                                                            capsys) -> None:
    run = copy_run()
    write_lines(run, lines(run)[:-1])
    out = tmp_path / "x.cocobench.tar.gz"
    assert main(["submit", "pack", str(run), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "not a finished run" in err and "1 of 4 planned episodes have no result" in err
    assert not out.exists()
    out.write_bytes(b"")
    assert main(["submit", "pack", str(copy_run()), "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["submit", "pack", str(copy_run()), "--out", str(tmp_path / "x.tgz")]) == 2


def _pack_command(run: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "cocobench_agents.cli", "submit", "pack", str(run), "--out",
            str(out)]


def _assert_one_line_and_nothing_left(done: subprocess.CompletedProcess, out: Path,
                                      says: str) -> None:
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(f"Error: cannot write {out}: "), done.stderr
    assert says in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert list(out.parent.iterdir()) == []  # no bundle, no partial one


def test_pack_on_a_real_full_disk_is_one_line_and_leaves_nothing(demo_run: Path,
                                                                 tmp_path: Path) -> None:
    """A tmpfs smaller than the bundle (some 38 kB); needs the right to mount."""
    disk = tmp_path / "disk"
    _mount(disk, "size=16k")
    out = disk / "demo.cocobench.tar.gz"
    try:
        done = subprocess.run(_pack_command(demo_run, out), capture_output=True, text=True,
                              cwd=ROOT, timeout=120)
        _assert_one_line_and_nothing_left(done, out, "No space left on device")
    finally:
        subprocess.run(["umount", str(disk)], check=True)


def test_pack_past_a_file_size_limit_is_one_line_and_leaves_nothing(demo_run: Path,
                                                                    tmp_path: Path) -> None:
    """A full disk as a file size limit makes it (EFBIG): runs where mounting is refused."""
    def small_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, not the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))

    out = tmp_path / "bundles" / "demo.cocobench.tar.gz"
    out.parent.mkdir()
    done = subprocess.run(_pack_command(demo_run, out), capture_output=True, text=True,
                          cwd=ROOT, timeout=120, preexec_fn=small_files)
    _assert_one_line_and_nothing_left(done, out, "File too large")


def rewritten(demo_bundle: Path, tmp_path: Path, edit: Callable[[dict[str, bytes]], None],
              *, rehash: bool = True) -> Path:
    """The bundle with `edit` applied to its files (the manifest's hashes made to match,
    as a careful forger would)."""
    import hashlib

    files = members(demo_bundle)
    edit(files)
    manifest = json.loads(files["manifest.json"])
    if rehash:
        manifest["files"] = {n: {"sha256": hashlib.sha256(d).hexdigest(), "bytes": len(d)}
                             for n, d in files.items() if n != "manifest.json"}
    files["manifest.json"] = json.dumps(manifest).encode()
    return write_bundle(tmp_path / "edited.cocobench.tar.gz", files)


def test_a_bundle_missing_an_episode_is_refused(demo_bundle: Path, tmp_path: Path,
                                                capsys) -> None:
    def drop_last_line(files: dict[str, bytes]) -> None:
        kept = files["results.jsonl"].splitlines(keepends=True)[:-1]
        files["results.jsonl"] = b"".join(kept)

    bundle = rewritten(demo_bundle, tmp_path, drop_last_line)
    outcome = verify_source(bundle, jobs=1)
    assert not outcome.ok
    assert any("does not cover what it declares" in p for p in outcome.problems)
    assert main(["verify", str(bundle)]) == 1


def test_a_bundle_declaring_other_instances_is_refused(demo_bundle: Path,
                                                       tmp_path: Path) -> None:
    def declare_more(files: dict[str, bytes]) -> None:
        manifest = json.loads(files["manifest.json"])
        manifest["suite"]["instances"].append("A_D1__Elsewhere__seed0")
        files["manifest.json"] = json.dumps(manifest).encode()

    outcome = verify_source(rewritten(demo_bundle, tmp_path, declare_more), jobs=1)
    assert "refused: the manifest's instance list is not its run's" in outcome.problems


def test_a_file_edited_after_packing_is_refused_by_its_hash(demo_bundle: Path,
                                                            tmp_path: Path, capsys) -> None:
    def edit(files: dict[str, bytes]) -> None:
        files["results.jsonl"] = files["results.jsonl"].replace(b'"task_success": 0',
                                                                b'"task_success": 1', 1)

    bundle = rewritten(demo_bundle, tmp_path, edit, rehash=False)
    assert main(["verify", str(bundle)]) == 2
    assert "results.jsonl: its sha256 is not the manifest's" in capsys.readouterr().err
    # rehashed, the manifest agrees: the replay finds the flipped success
    (tmp_path / "b").mkdir()
    outcome = verify_source(rewritten(demo_bundle, tmp_path / "b", edit), jobs=1)
    assert outcome.counts["mismatch"] == 1


@pytest.mark.parametrize(("entry", "message"), [
    ("../escape.json", "is not a file a run folder holds"),
    ("/etc/passwd", "is not a file a run folder holds"),
    ("episodes/a/b/../../../../x/trajectory.json", "is not a file a run folder holds"),
    ("episodes/greedy/C0/t1/evil.py", "is not a file a run folder holds"),
    ("results.jsonl", "is in it twice"),
])
def test_names_outside_a_run_folders_layout_are_refused(demo_bundle: Path, tmp_path: Path,
                                                        entry: str, message: str,
                                                        capsys) -> None:
    files = members(demo_bundle)
    info = tarfile.TarInfo(entry)
    info.size = 0
    bundle = write_bundle(tmp_path / "bad.cocobench.tar.gz", files, [info])
    assert main(["verify", str(bundle)]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "escape.json").exists()


@pytest.mark.parametrize("kind", [tarfile.SYMTYPE, tarfile.LNKTYPE, tarfile.DIRTYPE,
                                  tarfile.FIFOTYPE, tarfile.CHRTYPE])
def test_links_folders_and_devices_are_refused(demo_bundle: Path, tmp_path: Path, kind: bytes,
                                               capsys) -> None:
    info = tarfile.TarInfo("episodes/greedy/C0_blind/t1/trajectory.json")
    info.type, info.linkname = kind, "/etc/passwd"
    bundle = write_bundle(tmp_path / "link.cocobench.tar.gz", members(demo_bundle), [info])
    assert main(["verify", str(bundle)]) == 2
    assert "is not a regular file" in capsys.readouterr().err


def test_a_file_past_its_bound_is_refused_before_it_is_inflated(
        demo_bundle: Path, tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(bundle_module, "MAX_FILE_BYTES", 1000)
    assert main(["verify", str(demo_bundle)]) == 2
    assert "larger than a bundle may be" in capsys.readouterr().err


@pytest.mark.parametrize("content", [b"", b"not gzip at all", b"\x1f\x8b\x08\x00garbage"])
def test_not_a_bundle(tmp_path: Path, content: bytes, capsys) -> None:
    path = tmp_path / "x.cocobench.tar.gz"
    path.write_bytes(content)
    assert main(["verify", str(path)]) == 2
    err = capsys.readouterr().err
    assert "not a bundle" in err or "no manifest.json" in err
    assert "Traceback" not in err


#: How deep below the fuzz test's watched folder the temporary folder is: the unpacked run is
#: two below that, so a member name climbing up to ESCAPE_DEPTH + 2 `..` still lands in it.
ESCAPE_DEPTH = 6


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(names=st.lists(st.text(min_size=1, max_size=40), min_size=1, max_size=4),
       data=st.binary(max_size=64))
def test_fuzzed_member_names_never_leave_the_folder(tmp_path: Path, names: list[str],
                                                    data: bytes) -> None:
    """The bundle is unpacked under `tmp_path`, ESCAPE_DEPTH folders down, so a name climbing
    out of the private folder (up to that many `..`) or a file written beside the bundle lands
    in `tmp_path`, which is watched: a small tree, walked twice per example (walking all the
    worker's temporary folders cost 35 s in a whole run)."""
    from cocobench_agents.verify import VerifyError, open_bundle

    files = {}
    for name in names:
        files.setdefault(name, data)
    path = tmp_path / "fuzz.cocobench.tar.gz"
    try:
        write_bundle(path, files)
    except (ValueError, UnicodeError):
        return  # a name tarfile cannot write
    temp = tmp_path.joinpath(*(f"up{n}" for n in range(ESCAPE_DEPTH)))
    temp.mkdir(parents=True, exist_ok=True)
    before = set(tmp_path.rglob("*"))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tempfile, "tempdir", str(temp))  # where open_bundle makes its folder
        with pytest.raises(VerifyError), open_bundle(path):
            pass
    assert set(tmp_path.rglob("*")) == before

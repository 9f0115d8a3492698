"""Submission bundles: a run folder packed with a manifest (`pack`), and read back as data
only (`open_bundle`).

A bundle is a ``.tar.gz`` of `run.json`, `results.jsonl`, each episode's trajectory and kept
prompts, and `manifest.json`: the sha256 of every other file, the package and prompt-suite
versions, the instance list and its hash, the conditions, models and epochs, and the settings
that change what is sent or scored (`shaping` ones), with those that are not the reference's.

Reading one trusts nothing in it: only regular files, at the names a run folder has, within
bounded sizes and counts, are extracted into a private temporary folder; a link, a device,
a name leaving the folder, a file the manifest does not list or whose hash differs refuses
the bundle (`VerifyError`) before anything in it is read as JSON.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import fcntl
import hashlib
import io
import json
import os
import re
import shutil
import tarfile
import tempfile
import zlib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path, PurePosixPath
from typing import Any

from benchmark_adapter.tasks import available_suites
from benchmark_adapter.vocabulary import EMBEDDED
from cocobench_agents.engine.request import iter_fields, kind
from cocobench_agents.partial_output import staged_beside
from cocobench_agents.runfolder import PROMPTS_FILE, RESULTS, RUN_FILE, RunFolder, RunFolderError
from cocobench_agents.verify.errors import BundleWriteError, VerifyError
from cocobench_agents.version import __version__

MANIFEST = "manifest.json"
FORMAT = "cocobench-bundle"
FORMAT_VERSION = 1
SUFFIX = ".cocobench.tar.gz"
TRAJECTORY = "trajectory.json"
#: Where a file may lie in a bundle: the run's two files, the manifest, and an episode's
#: trajectory or prompts at most four folders below `episodes/` (model, condition, arm, task).
ALLOWED = re.compile(r"(?:run\.json|results\.jsonl|manifest\.json|episodes/(?:[A-Za-z0-9_.@~-]"
                     r"{1,200}/){2,3}[A-Za-z0-9_.@~-]{1,200}/(?:trajectory\.json|"
                     r"prompts\.json\.gz))")
#: Bounds on what a bundle may hold: a full run of 2,691 episodes is some 10,000 files and a
#: few hundred megabytes; a file past its bound refuses the bundle before it is inflated.
MAX_FILES = 200_000
MAX_FILE_BYTES = 256 * 2**20
MAX_TOTAL_BYTES = 16 * 2**30
#: A bundle is unpacked into ``TMPDIR/cocobench-bundle-*/run``, beside the `LOCK` its
#: process holds: a folder whose lock nobody holds was left by a killed one.
TEMP_PREFIX = "cocobench-bundle-"
LOCK = "lock"
#: Settings the reference runs with: a bundle recorded otherwise is labelled with them.
REFERENCE_SETTINGS: dict[str, Any] = {"max_steps": None, "stable_ids": False,
                                      "backend": EMBEDDED}


def pack(run: str | Path, out: str | Path) -> dict[str, Any]:
    """Write the run folder `run` as the bundle `out` (new; a name ending ``.cocobench.tar.gz``)
    and return its manifest. `VerifyError` for a folder that is no finished run (a planned
    episode without its result line, a result line without its trajectory), or an `out`
    that exists; `BundleWriteError` for a disk that cannot take it (nothing is left)."""
    folder, out = RunFolder(run), Path(out)
    if not out.name.endswith(SUFFIX):
        raise VerifyError(f"{out}: a bundle's name ends with {SUFFIX}")
    if out.exists():
        raise VerifyError(f"{out} already exists: choose another --out")
    record = folder.run_record()
    scan = folder.scan_results(check_trajectories=True)
    problems = scan.problems + coverage_problems(record, scan.latest)
    if problems:
        raise VerifyError("\n".join([f"{run}: not a finished run, not packed:", *problems]))
    files = [RUN_FILE, RESULTS, *_episode_files(folder, scan.latest.values())]
    manifest = manifest_of(folder, record, files)
    _write_tar(folder, files, manifest, out)
    return manifest


def _episode_files(folder: RunFolder, lines: Iterable[Mapping[str, Any]]) -> list[str]:
    files = []
    for line in lines:
        if line.get("infra_error"):
            continue
        trajectory = str(line["trajectory"])
        files.append(trajectory)
        prompts = str(PurePosixPath(trajectory).parent / PROMPTS_FILE)
        if folder.inside(prompts).is_file():
            files.append(prompts)
    return files


def manifest_of(folder: RunFolder, record: Mapping[str, Any], files: list[str]
                ) -> dict[str, Any]:
    """The manifest of a run folder's `files` (paths relative to it)."""
    plan = record.get("plan") or {}
    instances = sorted(plan.get("task_ids") or [])
    settings = shaping_settings(record.get("request") or {})
    return {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "packed_by": __version__,
        "versions": {"cocobench_agents": record.get("cocobench_agents"),
                     **(record.get("versions") or {})},
        "prompt_suites": _suites(record),
        "suite": {"sources": plan.get("sources") or settings.get("sources") or [],
                  "instances": instances, "instances_sha256": instances_hash(instances)},
        "models": plan.get("models") or [], "conditions": plan.get("conditions") or [],
        "epochs": plan.get("epochs") or 1,
        "settings": settings,
        "non_reference": non_reference(settings),
        "files": {name: {"sha256": _sha256(folder.inside(name)),
                         "bytes": folder.inside(name).stat().st_size} for name in files},
    }


def instances_hash(instances: list[str]) -> str:
    return hashlib.sha256("\n".join(sorted(instances)).encode("utf-8")).hexdigest()


def shaping_settings(request: Mapping[str, Any]) -> dict[str, Any]:
    """The recorded request's settings that change what is sent or scored, by leaf name."""
    out = {}
    for path, _ in iter_fields():
        if kind(path) != "shaping" or path == ("out",):
            continue
        value: Any = request
        for part in path:
            value = value.get(part) if isinstance(value, Mapping) else None
        out[path[-1]] = value
    return out


def non_reference(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The settings that are not the reference's (`REFERENCE_SETTINGS`), and a selection
    that is not one whole built-in suite."""
    out = {name: settings.get(name) for name, value in REFERENCE_SETTINGS.items()
           if name in settings and settings.get(name) != value}
    sources = settings.get("sources") or []
    filters = {name: settings.get(name) for name in ("eval_set", "only_cell", "only_family",
                                                     "only_dim", "task_ids", "limit")
               if settings.get(name)}
    if len(sources) != 1 or sources[0] not in available_suites() or filters:
        out["selection"] = {"sources": sources, **filters}
    return out


def _suites(record: Mapping[str, Any]) -> list[dict[str, Any]]:
    suites = record.get("prompt_suites") or [record.get("prompt_suite") or {}]
    return [{k: s.get(k) for k in ("arm", "spec", "version", "content_hash", "path")
             if s.get(k) is not None} for s in suites if isinstance(s, Mapping)]


def coverage_problems(record: Mapping[str, Any], latest: Mapping[Any, Mapping[str, Any]]
                      ) -> list[str]:
    """What the run does not cover of what it declares: each (model, condition, arm) it
    recorded must have every planned instance at every epoch, and each planned condition
    and model must appear."""
    plan = record.get("plan") or {}
    instances = list(plan.get("task_ids") or [])
    epochs = int(plan.get("epochs") or 1)
    groups: dict[tuple[str, str, str], set[tuple[str, int]]] = {}
    for key in latest:
        groups.setdefault((key.model, key.condition, key.arm), set()).add(
            (key.task_id, key.epoch))
    problems = []
    for (model, condition, arm), done in sorted(groups.items()):
        missing = [f"{t}{f' epoch {e}' if e else ''}" for t in instances
                   for e in range(epochs) if (t, e) not in done]
        if missing:
            arm_text = f" arm {arm}" if arm else ""
            problems.append(f"{model} {condition}{arm_text}: {len(missing)} of "
                            f"{len(instances) * epochs} planned episodes have no result "
                            f"(first: {missing[0]})")
    seen_conditions = {c for _, c, _ in groups}
    for condition in plan.get("conditions") or []:
        if condition not in seen_conditions:
            problems.append(f"condition {condition}: planned, no episode recorded")
    seen_models = {m for m, _, _ in groups}
    problems += [f"model {m}: planned, no episode recorded"
                 for m in plan.get("models") or [] if m not in seen_models]
    return problems


def _write_tar(folder: RunFolder, files: list[str], manifest: dict[str, Any],
               out: Path) -> None:
    """Write the bundle to a temporary file beside `out`, renamed to it once whole: a full
    disk or a killed process never leaves a partial bundle under `out`'s name, and a failed
    write leaves nothing; the partial bundles of packs killed meanwhile are removed first.
    `BundleWriteError` for a file that cannot be written."""
    try:
        with staged_beside(out, folder=False) as partial:
            _write_members(folder, files, manifest, partial)
            partial.chmod(0o644)  # a bundle is for sharing
            os.replace(partial, out)
    except OSError as exc:
        raise BundleWriteError(f"cannot write {out}: {exc.strerror or exc}") from None


def _write_members(folder: RunFolder, files: list[str], manifest: dict[str, Any],
                   partial: Path) -> None:
    with tarfile.open(partial, "w:gz", format=tarfile.PAX_FORMAT) as tar:
        data = json.dumps(manifest, indent=2, sort_keys=True).encode("utf-8")
        info = tarfile.TarInfo(MANIFEST)
        info.size, info.mtime, info.mode = len(data), 0, 0o644
        tar.addfile(info, io.BytesIO(data))
        for name in files:
            path = folder.inside(name)
            info = tarfile.TarInfo(name)
            info.size, info.mtime, info.mode = path.stat().st_size, 0, 0o644
            with open(path, "rb") as f:
                tar.addfile(info, f)


@contextlib.contextmanager
def open_bundle(path: str | Path) -> Iterator[tuple[Path, dict[str, Any]]]:
    """The bundle at `path` unpacked into a private temporary run folder (removed after),
    and its manifest, every file checked against it; `VerifyError` naming what is wrong.
    The folders of bundles whose process was killed meanwhile are removed first."""
    _reclaim_abandoned()
    home = Path(tempfile.mkdtemp(prefix=TEMP_PREFIX))
    try:
        with _held(home):
            root = home / "run"
            root.mkdir()
            names = _extract(Path(path), root)
            manifest = _read_manifest(path, root)
            _check_files(path, root, names, manifest)
            yield root, manifest
    finally:
        shutil.rmtree(home, ignore_errors=True)


@contextlib.contextmanager
def _held(home: Path) -> Iterator[None]:
    """An exclusive `flock` on ``home/lock`` while the bundle is open (the kernel releases
    it when its holder dies, even by SIGKILL; forked workers hold it with their parent)."""
    handle, name = tempfile.mkstemp(dir=home)
    with os.fdopen(handle, "wb") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        os.replace(name, home / LOCK)  # named once locked: an unlocked one is abandoned
        yield


def _reclaim_abandoned() -> None:
    """Remove the temporary folders of bundles whose process is gone (an unheld lock)."""
    for home in Path(tempfile.gettempdir()).glob(f"{TEMP_PREFIX}*"):
        try:
            with open(home / LOCK, "rb") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
                shutil.rmtree(home, ignore_errors=True)
        except OSError:  # no lock yet (being opened), held (in use), or another user's
            continue


def _extract(path: Path, root: Path) -> set[str]:
    names: set[str] = set()
    total = 0
    try:
        with tarfile.open(path, "r:gz") as tar:
            for member in tar:
                name = member.name
                if not member.isfile():
                    raise VerifyError(f"{path}: refused: {name!r} is not a regular file "
                                      "(a bundle holds files only: no link, folder entry or "
                                      "device)")
                if not ALLOWED.fullmatch(name) or ".." in PurePosixPath(name).parts:
                    raise VerifyError(f"{path}: refused: {name!r} is not a file a run folder "
                                      "holds")
                if name in names:
                    raise VerifyError(f"{path}: refused: {name!r} is in it twice")
                total += member.size
                if (member.size > MAX_FILE_BYTES or total > MAX_TOTAL_BYTES
                        or len(names) >= MAX_FILES):
                    raise VerifyError(f"{path}: refused: larger than a bundle may be "
                                      f"({name!r}: {member.size:,} bytes; at most "
                                      f"{MAX_FILE_BYTES:,} a file, {MAX_TOTAL_BYTES:,} in "
                                      f"all, {MAX_FILES:,} files)")
                names.add(name)
                _write_member(tar, member, root / name)
    except (tarfile.TarError, EOFError, OSError, zlib.error) as exc:
        raise VerifyError(f"{path}: not a bundle (a .tar.gz): {exc}") from None
    return names


def _write_member(tar: tarfile.TarFile, member: tarfile.TarInfo, target: Path) -> None:
    source = tar.extractfile(member)
    if source is None:
        raise VerifyError(f"{member.name!r}: unreadable")
    target.parent.mkdir(parents=True, exist_ok=True)
    written = 0
    with source, open(target, "xb") as out:  # "x": never through anything already there
        while chunk := source.read(2**20):
            written += len(chunk)
            if written > member.size:
                raise VerifyError(f"{member.name!r}: longer than its header says")
            out.write(chunk)


def _read_manifest(path: str | Path, root: Path) -> dict[str, Any]:
    try:
        manifest = json.loads((root / MANIFEST).read_bytes())
    except FileNotFoundError:
        raise VerifyError(f"{path}: refused: no {MANIFEST}") from None
    except (ValueError, RecursionError) as exc:
        raise VerifyError(f"{path}: refused: {MANIFEST} is not JSON ({exc})") from None
    if (not isinstance(manifest, dict) or manifest.get("format") != FORMAT
            or not isinstance(manifest.get("files"), dict)):
        raise VerifyError(f"{path}: refused: {MANIFEST} is not a {FORMAT} manifest")
    if manifest.get("format_version") != FORMAT_VERSION:
        raise VerifyError(f"{path}: refused: manifest format_version "
                          f"{manifest.get('format_version')!r} (this version reads "
                          f"{FORMAT_VERSION})")
    return manifest


def _check_files(path: str | Path, root: Path, names: set[str],
                 manifest: Mapping[str, Any]) -> None:
    listed = manifest["files"]
    unlisted = sorted(names - set(listed) - {MANIFEST})
    absent = sorted(set(listed) - names)
    if unlisted or absent:
        what = (f"{unlisted[0]!r} is not in the manifest" if unlisted
                else f"{absent[0]!r} is in the manifest, not in the bundle")
        raise VerifyError(f"{path}: refused: {what}")
    for name, entry in sorted(listed.items()):
        expected = entry.get("sha256") if isinstance(entry, dict) else None
        if _sha256(root / name) != expected:
            raise VerifyError(f"{path}: refused: {name}: its sha256 is not the manifest's")
    for required in (RUN_FILE, RESULTS):
        if required not in names:
            raise VerifyError(f"{path}: refused: no {required}")


def bundle_problems(root: Path, manifest: Mapping[str, Any]) -> list[str]:
    """What refuses an unpacked bundle: it does not cover what it declares, or declares
    another instance list or other settings than its run's, or not all of the suite it
    names."""
    folder = RunFolder(root)
    try:
        record = folder.run_record()
    except RunFolderError as exc:
        return [f"refused: {exc}"]
    plan = record.get("plan") or {}
    suite = manifest.get("suite") or {}
    instances = sorted(plan.get("task_ids") or [])
    problems = []
    if suite.get("instances") != instances or suite.get("instances_sha256") != \
            instances_hash(instances):
        problems.append("refused: the manifest's instance list is not its run's")
    settings = shaping_settings(record.get("request") or {})
    declared = manifest.get("settings") or {}
    changed = sorted(n for n in set(settings) | set(declared)
                     if settings.get(n) != declared.get(n))
    if changed:
        problems.append(f"refused: the manifest's settings are not its run's ({changed[0]})")
    problems += _whole_suite_problems(settings, instances)
    scan = folder.scan_results(check_trajectories=True)
    return problems + [f"refused: does not cover what it declares: {p}"
                       for p in coverage_problems(record, scan.latest)]


def settings_labels(root: Path) -> list[str]:
    """The settings of the run at `root` that are not the reference's (``max_steps=10``);
    none for a folder whose run.json cannot be read (its verification says why)."""
    try:
        record = RunFolder(root).run_record()
    except RunFolderError:
        return []
    settings = shaping_settings(record.get("request") or {})
    return [f"{name}={json.dumps(value)}" for name, value in
            sorted(non_reference(settings).items())]


def _whole_suite_problems(settings: Mapping[str, Any], instances: list[str]) -> list[str]:
    """A bundle that names one built-in suite, unfiltered, must list all of its instances."""
    from benchmark_adapter.tasks import load_tasks

    sources = settings.get("sources") or []
    if len(sources) != 1 or sources[0] not in available_suites() or non_reference(
            settings).get("selection"):
        return []
    own = sorted(config.task_id for config in load_tasks(sources[0]))
    if own != instances:
        return [f"refused: declares the suite {sources[0]} ({len(own)} instances) but runs "
                f"{len(instances)} instances, not the same"]
    return []


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(2**20):
            digest.update(chunk)
    return digest.hexdigest()

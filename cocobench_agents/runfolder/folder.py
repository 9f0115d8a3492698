"""The run folder (DESIGN §4): `run.json`, `results.jsonl`, one trajectory (and one
compressed file of the prompts its decisions name) per episode, `run.lock`.

Crash safety: a trajectory is written atomically (temp file + rename) before its result line;
each result line is appended whole or not at all (short writes are completed; a failed write
is cut back off) and fsync'd. A SIGKILL can at worst leave one partial last line, which
readers skip and `open_for_resume` cuts off. So the folder is never corrupt, and an episode
counts as done only once its line is complete and its trajectory is there. A folder that
cannot be written stops the run (`RunFolderWriteError`): it is not the episode failing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gzip
import json
import os
import re
import tempfile
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import orjson

from benchmark_adapter.trajectory import PROMPTS_FIELD, json_text, write_json_atomic
from cocobench_agents.runfolder.episode_key import EpisodeKey, result_key
from cocobench_agents.runfolder.errors import RunFolderError, gist, read_failed, write_failed
from cocobench_agents.runfolder.json_lines import (
    append_json_line,
    append_json_lines,
    cut_torn_tail,
    file_identity,
    json_object,
)
from cocobench_agents.runfolder.lock import RunLock
from cocobench_agents.runfolder.record import record_error
from cocobench_agents.runfolder.result_line import line_error, line_identity

RESULTS = "results.jsonl"
RUN_FILE = "run.json"
PROMPTS_FILE = "prompts.json.gz"
#: The most an episode's prompts may inflate to (no run comes near it): more is refused.
MAX_PROMPTS_BYTES = 256 * 2**20
SHOWN_PROBLEMS = 10  # problems of a results file named one by one; the rest are counted
#: The temporary files of this folder's atomic writes (`tempfile.mkstemp`'s random part).
_TEMPORARY = re.compile(r"\.(trajectory\.json|prompts\.json\.gz|run\.json)\.[^/]+\.tmp")


@dataclass
class ResultsScan:
    """What `results.jsonl` holds: its valid lines, and every problem found in it."""

    rows: list[dict[str, Any]] = field(default_factory=list)  # valid lines, in file order
    # (the rows are read-only: a folder hands the same ones to every scan of one file state)
    #: Each episode's latest valid line (an episode whose latest line is invalid is absent).
    latest: dict[EpisodeKey, dict[str, Any]] = field(default_factory=dict)
    #: Episodes of `latest` whose trajectory file is missing (when checked).
    missing: list[EpisodeKey] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)  # one line each, naming file and line
    invalid_lines: int = 0
    torn_tail: bool = False  # an incomplete last line (a crash in mid-write), skipped

    @property
    def done(self) -> dict[EpisodeKey, dict[str, Any]]:
        """The episodes that count as done: a valid latest line, and its trajectory."""
        missing = set(self.missing)
        return {k: r for k, r in self.latest.items() if k not in missing}


class RunFolder:
    """One run's folder."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.warnings: list[str] = []  # what `open_for_resume` repaired or found wrong
        #: The last scan of `results.jsonl` and the file's identity then (a resume reads it
        #: five times: 0.45 s of a 1.4 s resume of 2,691 episodes, measured here).
        self._scanned: tuple[tuple[int, ...], ResultsScan] | None = None

    @property
    def results_path(self) -> Path:
        return self.path / RESULTS

    @property
    def record_path(self) -> Path:
        """`run.json`: the run's record."""
        return self.path / RUN_FILE

    @contextlib.contextmanager
    def lock(self) -> Iterator[RunLock]:
        """Hold the folder's lock (creating the folder) for the whole run: a second process
        gets `RunLocked` naming the holder's pid; a killed holder's lock is taken over (its
        pid in `stale_pid`)."""
        try:
            lock = RunLock(self.path).acquire()
        except OSError as exc:
            raise RunFolderError(f"cannot use {self.path} as a run folder: "
                                 f"{exc.strerror or exc}") from None
        try:
            yield lock
        finally:
            lock.release()

    def check_unused(self) -> None:
        """Refuse a folder that already holds a run (`RunFolderError`): a new run checks it
        before anything is called, and again as it creates the folder."""
        if (self.path / RUN_FILE).exists() or self.results_path.exists():
            raise RunFolderError(f"{self.path} already holds a run: pass --resume to complete "
                                 "it, or choose another --out folder")

    def create(self, run_record: dict[str, Any]) -> None:
        """Start a new run; refuse to touch an existing one."""
        self.check_unused()
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            write_json_atomic(self.path / RUN_FILE, run_record)
        except OSError as exc:
            raise RunFolderError(f"cannot write {self.path / RUN_FILE}: "
                                 f"{exc.strerror or exc}") from None
        except (TypeError, ValueError) as exc:  # text no UTF-8 file holds: a path's bytes
            shown = os.fsencode(self.path / RUN_FILE).decode("utf-8", "backslashreplace")
            raise RunFolderError(f"cannot write {shown}: the run's request holds text that "
                                 "is not valid UTF-8 (a path of bytes that are not UTF-8?): "
                                 f"{gist(exc)}") from None

    def open_for_resume(self) -> dict[str, Any] | None:
        """The recorded run (None if the folder holds none yet). A torn last result line
        (from a kill) is cut off; that repair and every problem of the results (invalid
        lines, missing trajectories) are left in `warnings`."""
        self.warnings = []
        if not (self.path / RUN_FILE).exists():
            if self.results_path.exists():
                raise RunFolderError(f"{self.path} has results but no {RUN_FILE}")
            return None
        record = self.run_record()
        if not isinstance(record.get("plan"), dict):
            raise RunFolderError(f"{self.path / RUN_FILE}: not a run record (no plan)")
        cut = len(cut_torn_tail(self.results_path)[1])
        if cut:
            self.warnings.append(f"{self.results_path}: removed an incomplete last line "
                                 f"({cut} bytes, from a run stopped in mid-write)")
        removed = self._remove_temporaries()
        if removed:
            self.warnings.append(f"{self.path}: removed {removed} temporary file"
                                 f"{'s' if removed != 1 else ''} of writes a stopped run "
                                 "left unfinished")
        self.warnings += self.scan_results(check_trajectories=True).problems
        return record

    def _remove_temporaries(self) -> int:
        """Remove the temporary files of atomic writes that a killed writer left (a
        `.trajectory.json.*.tmp`, …): under the lock no write is under way. Only files of
        that name, in the run folder's own tree (links are not followed); their count."""
        removed = 0
        for folder, _, names in os.walk(self.path):
            for name in names:
                path = Path(folder, name)
                if _TEMPORARY.fullmatch(name) and not path.is_symlink():
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
                        removed += 1
        return removed

    def run_record(self) -> dict[str, Any]:
        """`run.json` (`RunFolderError` naming it if it cannot be read, is not a JSON object,
        or has a field of a type its readers do not read: `record.RunRecord`)."""
        path = self.path / RUN_FILE
        try:
            record = json_text(path.read_bytes())
        except (ValueError, RecursionError) as exc:  # not JSON, not UTF-8, too deep
            raise RunFolderError(f"{path}: not a run record ({gist(exc)})") from None
        except OSError as exc:
            raise read_failed(path, exc) from None
        if not isinstance(record, dict):
            raise RunFolderError(f"{path}: not a run record (a JSON object)")
        error = record_error(record)
        if error is not None:
            raise RunFolderError(f"{path}: not a run record ({error})")
        return record

    def write_trajectory(self, key: EpisodeKey, document: dict[str, Any]) -> str:
        """Write an episode's trajectory (its `PROMPTS_FIELD` to the episode's compressed
        prompt file); return its path relative to the run folder."""
        relative = f"{key.folder()}/trajectory.json"
        target = self.inside(relative)
        prompts = document.get(PROMPTS_FIELD)
        try:
            if prompts is not None:
                document = {k: v for k, v in document.items() if k != PROMPTS_FIELD}
                _write_bytes_atomic(target.parent / PROMPTS_FILE, _compressed(prompts))
            write_json_atomic(target, document)
        except OSError as exc:
            raise write_failed(target, exc) from None
        return relative

    def prompts(self, episode: EpisodeKey | Mapping[str, Any]) -> dict[str, str]:
        """An episode's prompts by `prompt_hash` (a decision record's field); empty for an
        episode without model calls or a folder written before prompts were kept. The
        episode is its `EpisodeKey` or its result line (what `results()` yields)."""
        key = episode if isinstance(episode, EpisodeKey) else _episode_of_line(episode)
        path = self.inside(f"{key.folder()}/{PROMPTS_FILE}")
        try:
            prompts = json_text(inflate_prompts(path.read_bytes()))
        except FileNotFoundError:
            return {}
        except (OSError, EOFError, ValueError, RecursionError, zlib.error) as exc:  # damaged
            raise RunFolderError(f"{path}: unreadable ({gist(exc)})") from None
        if not isinstance(prompts, dict) or not all(isinstance(text, str)
                                                    for text in prompts.values()):
            raise RunFolderError(f"{path}: not the prompts of an episode (an object of texts)")
        return prompts

    def trajectory(self, episode: EpisodeKey | Mapping[str, Any]) -> dict[str, Any] | None:
        """An episode's trajectory document (its key, or its result line, whose `trajectory`
        names the file); None when the folder has none for it (an infrastructure error, a
        missing file); `RunFolderError` naming the file when it is not a JSON object."""
        line = None if isinstance(episode, EpisodeKey) else episode
        key = episode if isinstance(episode, EpisodeKey) else _episode_of_line(episode)
        relative = str((line or {}).get("trajectory") or f"{key.folder()}/trajectory.json")
        path = self.inside(relative)
        try:
            document = orjson.loads(path.read_bytes())  # trajectories run to megabytes
        except FileNotFoundError:
            return None
        except (OSError, ValueError, RecursionError) as exc:  # orjson's error is a ValueError
            raise RunFolderError(f"{path}: unreadable ({gist(exc)})") from None
        if not isinstance(document, dict):
            raise RunFolderError(f"{path}: not a trajectory (a JSON object)")
        return document

    def prompt(self, episode: EpisodeKey | Mapping[str, Any], prompt_hash: str) -> str | None:
        """The text of the prompt a decision of `episode` (its key or its result line) names
        (None if not kept)."""
        return self.prompts(episode).get(prompt_hash)

    def inside(self, relative: str) -> Path:
        """The path of `relative` in the run folder; refuses one that would leave it (`..`,
        an absolute path, a NUL byte): nothing is ever written outside the run folder."""
        root = os.path.normpath(os.path.abspath(self.path))
        target = os.path.normpath(os.path.join(root, relative))
        if "\0" in relative or target == root or os.path.commonpath([root, target]) != root:
            raise RunFolderError(f"refusing to write {relative!r}: it is not inside the run "
                                 f"folder {self.path}")
        return Path(target)

    def read_file(self, relative: str) -> bytes | None:
        """The bytes of the file at `relative` in the run folder (a frame a trajectory item
        names); None when there is none, or when it, or a link on its way, leads out of the
        folder: a reader takes nothing else of the disk."""
        try:
            target = self.inside(relative).resolve(strict=True)
            if not target.is_relative_to(self.path.resolve(strict=True)):
                return None
            return target.read_bytes() if target.is_file() else None
        except (OSError, ValueError, RuntimeError, RunFolderError):  # RuntimeError: a loop
            return None

    def append_result(self, record: dict[str, Any]) -> None:
        """Append one result line, whole or not at all, and fsync it; `RunFolderWriteError`
        (the file cut back to its previous end) if it cannot be written."""
        self.append_results([record])

    def append_results(self, records: list[dict[str, Any]]) -> None:
        """`append_result` for several lines with one fsync (a group commit: a supervisor
        of many workers records each batch that arrived together at the cost of one)."""
        written = append_json_lines(self.results_path, records)
        self._scan_appended(*written)

    def _scan_appended(self, before: tuple[int, ...], after: tuple[int, ...],
                       data: bytes) -> None:
        """Extend the last scan by the lines just appended (`data`) when it is the scan of
        the file as it was just before (`before`): the run's summary then reads no line
        again (7.6 MB of JSON and 0.43 CPU s after the last episode of `cocobench-full`,
        parsed here while the workers run instead)."""
        if after[1] != before[1] + len(data):  # another writer's bytes came in between
            return
        if before[1] == 0:
            scan = ResultsScan()
        elif self._scanned is not None and self._scanned[0] == before \
                and not self._scanned[1].torn_tail:
            scan = self._scanned[1]
        else:
            return
        lines_before = len(scan.rows) + scan.invalid_lines  # each line is one or the other
        for number, raw in enumerate(data.split(b"\n")[:-1], start=lines_before + 1):
            self._scan_line(scan, number, raw)
        self._scanned = after, scan

    def append_line(self, relative: str, record: dict[str, Any]) -> None:
        """Append `record` as one whole, fsync'd line to the file at `relative` in the run
        folder (created, with its folders, if new), as `append_result` appends."""
        path = self.inside(relative)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise write_failed(path, exc) from None
        append_json_line(path, record)

    def read_lines(self, relative: str) -> list[dict[str, Any]]:
        """The whole JSON-object lines of the file at `relative` (none if it is absent),
        after cutting off a torn last line (a kill in mid-write) so that the next
        `append_line` starts a line of its own."""
        whole, _ = cut_torn_tail(self.inside(relative))
        return [line for line in (json_object(raw) for raw in whole.splitlines())
                if line is not None]

    def results(self) -> Iterator[dict[str, Any]]:
        """Valid result lines in file order (invalid ones and a torn last line are skipped:
        `scan_results` names them)."""
        yield from self.scan_results().rows

    def scan_results(self, *, check_trajectories: bool = False) -> ResultsScan:
        """Read `results.jsonl`, validating every line (`result_line.ResultLine`); with
        `check_trajectories`, also find the episodes whose trajectory file is missing."""
        try:
            with open(self.results_path, "rb") as results:
                identity = file_identity(results.fileno())  # of the bytes read below
                if self._scanned is None or self._scanned[0] != identity:
                    self._scanned = identity, self._scan(results.read())
        except FileNotFoundError:
            return ResultsScan()
        except OSError as exc:
            raise read_failed(self.results_path, exc) from None
        scanned = self._scanned[1]
        # Copies of the containers (the rows themselves are shared: read-only), so that a
        # caller may change its scan, not the next one's.
        scan = dataclasses.replace(scanned, rows=list(scanned.rows),
                                   latest=dict(scanned.latest), missing=[],
                                   problems=list(scanned.problems))
        if check_trajectories:
            self._find_missing_trajectories(scan)
        if len(scan.problems) > SHOWN_PROBLEMS:
            hidden = len(scan.problems) - SHOWN_PROBLEMS
            scan.problems[SHOWN_PROBLEMS:] = [f"{self.results_path}: {hidden} more problems"]
        return scan

    def _scan(self, data: bytes) -> ResultsScan:
        scan = ResultsScan()
        *lines, tail = data.split(b"\n")
        scan.torn_tail = bool(tail)
        for number, raw in enumerate(lines, start=1):
            self._scan_line(scan, number, raw)
        return scan

    def _scan_line(self, scan: ResultsScan, number: int, raw: bytes) -> None:
        try:
            data: Any = json_text(raw)
            error = line_error(data)
        except (ValueError, RecursionError) as exc:  # not JSON, not UTF-8, nested too deep
            data, error = None, f"not JSON ({gist(exc)})"
        if error is None:
            scan.rows.append(data)
            key = result_key(data)
            scan.latest.pop(key, None)  # a later line (a retry) supersedes an earlier one
            scan.latest[key] = data
            return
        scan.invalid_lines += 1
        identity = line_identity(data)
        outcome = "skipped"
        if identity is not None:
            key = EpisodeKey(*identity)
            scan.latest.pop(key, None)
            outcome = f"episode {key.name()} counts as not done"
        scan.problems.append(f"{self.results_path} line {number}: {error}; {outcome}")

    def _find_missing_trajectories(self, scan: ResultsScan) -> None:
        for key, row in scan.latest.items():
            relative = row.get("trajectory")
            if row.get("infra_error") or not relative:
                continue
            try:
                problem = _trajectory_problem(self.inside(relative))
            except RunFolderError:  # outside the folder
                problem = "missing"
            if problem is not None:
                scan.missing.append(key)
                scan.problems.append(f"{self.path / relative}: {problem}; episode "
                                     f"{key.name()} counts as not done")


def _trajectory_problem(path: Path) -> str | None:
    """Why the trajectory file at `path` does not make its episode done (missing, empty, cut
    short), or None. A whole file written by `write_json_atomic` ends with its top-level
    object's brace alone on the last line (indented JSON: an inner brace is indented), so
    reading its end tells; a file that ends otherwise with a brace is parsed whole."""
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size == 0:
                return "empty"
            f.seek(max(0, size - 64))
            tail = f.read().rstrip()
            if tail.endswith(b"\n}"):
                return None
            if not tail.endswith(b"}"):
                return f"cut short ({size} bytes, not a whole JSON document)"
            f.seek(0)
            document = orjson.loads(f.read())
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
        return "missing"
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    except orjson.JSONDecodeError:
        return f"cut short ({size} bytes, not a whole JSON document)"
    return None if isinstance(document, dict) else "not a trajectory (a JSON object)"


def _episode_of_line(line: Mapping[str, Any]) -> EpisodeKey:
    """The episode of a result line a caller passed (`TypeError` naming what it lacks)."""
    try:
        return result_key(line)
    except (KeyError, TypeError, ValueError) as exc:
        raise TypeError("expected an EpisodeKey or a result line of results.jsonl (with "
                        f"model, condition, task_id): {type(exc).__name__}: {exc}") from None


def inflate_prompts(raw: bytes) -> bytes:
    """An episode's gzip'd prompts inflated, `MAX_PROMPTS_BYTES` at most (`ValueError` past
    it; `zlib.error` when damaged): a compression bomb in a shared run folder would exhaust
    a reader's memory."""
    inflate = zlib.decompressobj(wbits=zlib.MAX_WBITS | 16)  # gzip
    text = inflate.decompress(raw, MAX_PROMPTS_BYTES)
    if inflate.unconsumed_tail:
        raise ValueError(f"inflates past {MAX_PROMPTS_BYTES // 2**20} MiB")
    return text


def _compressed(prompts: dict[str, str]) -> bytes:
    # One gzip stream per episode: consecutive prompts share most of their text.
    text = json.dumps(prompts, ensure_ascii=False, sort_keys=True)
    return gzip.compress(text.encode("utf-8"), compresslevel=6, mtime=0)


def _write_bytes_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise

"""Run folders read live: each look reads only the bytes appended to `results.jsonl` since
the previous one, so a page reflects a running run without a restart.

An episode is (model, condition, task_id, epoch); a later line supersedes an earlier one
(a retry). A line that is not a valid result (`result_line.line_error`) is skipped and
counted, and a torn last line (a run in mid-write) waits for its end.
"""

from __future__ import annotations

import json
import threading
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cocobench_agents.runfolder.episode_key import EpisodeKey, result_key
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import (
    PROMPTS_FILE,
    RESULTS,
    RUN_FILE,
    RunFolder,
    inflate_prompts,
)
from cocobench_agents.runfolder.result_line import line_error
from cocobench_agents.viewer.errors import ViewerError
from cocobench_agents.viewer.paths import path_part

SHOWN_PROBLEMS = 5  # junk lines named one by one on the page; the rest are counted


@dataclass
class Episode:
    """One episode's latest result line, where it lives and the order it arrived in."""

    run: int  # index of its run among the viewer's runs
    key: EpisodeKey
    record: dict[str, Any]
    seq: int  # increases with every accepted line of any run (what a live page asks after)

    @property
    def path(self) -> str:
        """Its page's path below the viewer's root (the same live and exported): the parts
        of its trajectory's folder, each a plain name (`paths.path_part`), so that a key such
        as `../../x` names a page inside the root like any other."""
        return f"episode/{self.run}/{'/'.join(map(path_part, self.key.parts()))}.html"


@dataclass
class RunSource:
    """One run folder, read incrementally."""

    index: int
    path: Path
    record: dict[str, Any] = field(default_factory=dict)
    episodes: dict[EpisodeKey, Episode] = field(default_factory=dict)
    lines: int = 0  # valid lines read
    junk: int = 0  # invalid lines skipped
    problems: list[str] = field(default_factory=list)
    _offset: int = 0

    @property
    def name(self) -> str:
        return str(self.record.get("name") or self.path.resolve().name)

    @property
    def folder(self) -> RunFolder:
        return RunFolder(self.path)

    def read_new(self, next_seq: int) -> int:
        """Read the complete lines appended since the last call; return the next sequence
        number."""
        try:
            with open(self.path / RESULTS, "rb") as f:
                f.seek(self._offset)
                data = f.read()
        except FileNotFoundError:
            return next_seq
        except OSError as exc:  # a folder, unreadable: what was read stays shown
            raise ViewerError(f"{self.path / RESULTS}: cannot read it "
                              f"({exc.strerror or exc})") from None
        end = data.rfind(b"\n")
        if end < 0:
            return next_seq  # nothing complete yet (a torn or empty tail)
        line_no = self.lines + self.junk
        for raw in data[: end + 1].splitlines():
            line_no += 1
            next_seq = self._accept(raw, line_no, next_seq)
        self._offset += end + 1
        return next_seq

    def _accept(self, raw: bytes, line_no: int, seq: int) -> int:
        if not raw.strip():
            return seq
        try:
            data: Any = json.loads(raw)
            error = line_error(data)
        except (ValueError, RecursionError) as exc:
            error = f"not JSON ({type(exc).__name__})"
        if error is not None:
            self.junk += 1
            if len(self.problems) < SHOWN_PROBLEMS:
                self.problems.append(f"{self.path / RESULTS} line {line_no}: {error}")
            return seq
        self.lines += 1
        key = result_key(data)
        self.episodes.pop(key, None)  # the latest line of an episode goes last
        self.episodes[key] = Episode(self.index, key, data, seq)
        return seq + 1

    def file(self, relative: str) -> Path | None:
        """The file at `relative` inside the run folder, with every link resolved; None when
        there is none or when it lies outside the folder (`..`, an absolute path, a link
        leading out): the viewer reads and serves nothing else of the disk."""
        try:
            target = self.folder.inside(relative).resolve(strict=True)
            inside = target.is_relative_to(self.path.resolve(strict=True))
            return target if inside and target.is_file() else None
        except (OSError, ValueError, RuntimeError, RunFolderError):  # RuntimeError: a link loop
            return None

    def relative(self, relative: str) -> str | None:
        """The path inside the run folder (POSIX, links resolved) of the file at `relative`;
        None when `file` finds none: the one spelling a page links to and `--export` copies
        to, whatever `..` or `./` the trajectory wrote."""
        found = self.file(relative)
        if found is None:
            return None
        return found.relative_to(self.path.resolve()).as_posix()

    def trajectory_name(self, episode: Episode) -> str:
        """Where the episode's trajectory is, relative to the run folder (for messages)."""
        return str(episode.record.get("trajectory")
                   or f"{episode.key.folder()}/trajectory.json")

    def trajectory(self, episode: Episode) -> dict[str, Any] | None:
        """The episode's trajectory document (None when it is missing or unreadable)."""
        path = self.file(self.trajectory_name(episode))
        if path is None:
            return None
        try:
            with open(path, encoding="utf-8") as f:
                document = json.load(f)
        except (OSError, ValueError, RecursionError):  # RecursionError: nested too deep
            return None
        return document if isinstance(document, dict) else None

    def prompts(self, episode: Episode) -> dict[str, str]:
        """The episode's prompts by hash (empty when the run did not keep them, or kept
        them in a form that is not text by hash)."""
        path = self.file(f"{episode.key.folder()}/{PROMPTS_FILE}")
        if path is None:
            return {}  # absent, or a link out of the run folder
        try:
            prompts = json.loads(inflate_prompts(path.read_bytes()))  # bounded: no bomb
        except (OSError, ValueError, RecursionError, zlib.error):  # nested too deep, damaged
            return {}
        if not isinstance(prompts, dict):
            return {}
        return {k: v for k, v in prompts.items() if isinstance(v, str)}


class Catalog:
    """The viewer's run folders: every request looks for new result lines first."""

    def __init__(self, paths: list[str | Path]) -> None:
        if not paths:
            raise ViewerError("no run folder given")
        self.runs = [open_run(index, Path(p)) for index, p in enumerate(paths)]
        self._lock = threading.Lock()
        self._seq = 0
        self.refresh(strict=True)

    def refresh(self, *, strict: bool = False) -> None:
        """Read what the runs appended since the last look (only the new bytes). A
        `results.jsonl` that cannot be read is a `ViewerError` when the viewer starts
        (`strict`); later, its run keeps what was read and names the file among its
        problems."""
        with self._lock:
            for run in self.runs:
                try:
                    self._seq = run.read_new(self._seq)
                except ViewerError as exc:
                    if strict:
                        raise
                    if str(exc) not in run.problems:
                        run.problems.append(str(exc))

    @property
    def seq(self) -> int:
        return self._seq

    def episodes(self) -> list[Episode]:
        """Every run's episodes, in arrival order."""
        return sorted((e for run in self.runs for e in run.episodes.values()),
                      key=lambda e: e.seq)

    def by_path(self) -> dict[str, Episode]:
        return {e.path: e for e in self.episodes()}

    def find(self, path: str) -> Episode | None:
        return self.by_path().get(path)

    @property
    def junk(self) -> int:
        return sum(run.junk for run in self.runs)


def open_run(index: int, path: Path) -> RunSource:
    """A run folder with its `run.json` read; `ViewerError` naming the path if it is not
    one."""
    if not path.is_dir():
        raise ViewerError(f"{path}: no such run folder")
    if not (path / RUN_FILE).is_file():
        raise ViewerError(f"{path}: not a run folder (no {RUN_FILE}; make one with "
                          "`cocobench run --out DIR`)")
    try:
        record = RunFolder(path).run_record()
    except (OSError, RunFolderError) as exc:
        raise ViewerError(str(exc)) from None
    return RunSource(index=index, path=path, record=record)

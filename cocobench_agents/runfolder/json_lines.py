"""Files of JSON lines that survive a kill: each line is appended whole or not at all (short
writes are completed; a failed write is cut back off) and fsync'd, so a SIGKILL can at worst
leave one partial last line, which `cut_torn_tail` removes and readers skip."""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path
from typing import Any

from cocobench_agents.runfolder.errors import read_failed, write_failed


def cut_torn_tail(path: Path) -> tuple[bytes, bytes]:
    """Cut an incomplete last line (a kill in mid-write) off the file at `path`; its whole
    lines and what was cut (both empty when it is absent). `RunFolderError` if it cannot be
    read (a folder, no permission), `RunFolderWriteError` if the cut cannot be written."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return b"", b""
    except OSError as exc:
        raise read_failed(path, exc) from None
    end = data.rfind(b"\n") + 1
    if end != len(data):
        try:
            with open(path, "r+b") as f:
                f.truncate(end)
        except OSError as exc:
            raise write_failed(path, exc) from None
    return data[:end], data[end:]


def append_json_line(path: Path, record: dict[str, Any]) -> None:
    """Append `record` to `path` as one JSON line, whole or not at all, and fsync it;
    `RunFolderWriteError` (the file cut back to its previous end) if it cannot be written."""
    append_json_lines(path, [record])


def append_json_lines(path: Path, records: list[dict[str, Any]]
                      ) -> tuple[tuple[int, ...], tuple[int, ...], bytes]:
    """Append `records` to `path`, a JSON line each, all or none, with one fsync;
    `RunFolderWriteError` (the file cut back to its previous end) if they cannot be written.
    Returns the file's `file_identity` before and after, and the bytes appended."""
    line = "".join(json.dumps(record, sort_keys=True, ensure_ascii=False) + "\n"
                   for record in records).encode("utf-8")
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    except OSError as exc:
        raise write_failed(path, exc) from None
    try:
        before = file_identity(fd)
        end = os.lseek(fd, 0, os.SEEK_END)
        try:
            _write_all(fd, line)
            os.fsync(fd)
        except OSError as exc:
            _truncate(fd, end)  # no partial line for the next one to be glued to
            raise write_failed(path, exc) from None
        return before, file_identity(fd), line
    finally:
        os.close(fd)


def file_identity(fd: int) -> tuple[int, ...]:
    """What tells one state of an open file from another: inode, size, change times."""
    stat = os.fstat(fd)
    return stat.st_ino, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns


def json_object(raw: bytes) -> dict[str, Any] | None:
    """One line as a JSON object, or None when it is not one."""
    try:
        value = json.loads(raw.decode("utf-8"))
    except (ValueError, RecursionError):
        return None
    return value if isinstance(value, dict) else None


def _write_all(fd: int, data: bytes) -> None:
    """`os.write` until every byte is written (it may write fewer than asked)."""
    view = memoryview(data)
    while view:
        written = os.write(fd, view)
        if written <= 0:
            raise OSError(0, "the file system accepted no more bytes")
        view = view[written:]


def _truncate(fd: int, size: int) -> None:
    with contextlib.suppress(OSError):  # else the partial line stays: readers name it
        os.ftruncate(fd, size)

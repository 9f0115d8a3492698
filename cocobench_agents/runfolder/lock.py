"""One process per run folder: an OS lock (`flock`) on `run.lock`, held for the whole run.

The kernel releases a `flock` when its holder dies, even by SIGKILL, so a lock is never
stale in the OS sense; the file's content tells the rest. The holder writes its pid into it
and empties it on a clean release: a pid found there by a process that got the lock is one
that was killed while running (a stale lock, taken over and reported).
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

LOCK_FILE = "run.lock"


class RunLocked(RuntimeError):
    """Another live process holds the run folder (its pid, when it wrote one)."""

    def __init__(self, path: Path, pid: int | None) -> None:
        holder = f"pid {pid}" if pid else "a process whose pid is not recorded"
        super().__init__(f"{path} is in use by another cocobench run ({holder}): wait for it "
                         "to end, or stop it, before running on this folder")
        self.pid = pid


class RunLock:
    """The lock of one run folder (a context manager; `acquire` creates the folder)."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_FILE
        self.stale_pid: int | None = None  # the killed holder a lock was taken over from
        self._fd: int | None = None
        self._made_folder = False

    def acquire(self) -> RunLock:
        """Take the lock or raise `RunLocked`; `OSError` if the folder cannot be made."""
        self._made_folder = not self.folder.exists()
        self.folder.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                pid = _read_pid(fd)
                os.close(fd)
                raise RunLocked(self.folder, pid) from None
            if _same_file(fd, self.path):
                break
            os.close(fd)  # unlinked by a holder releasing an empty folder meanwhile: again
        self._fd = fd
        previous = _read_pid(fd)
        self.stale_pid = previous if previous and previous != os.getpid() else None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        return self

    def release(self) -> None:
        """Release the lock (a folder this lock created and nothing else used is removed)."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            os.ftruncate(fd, 0)  # a clean release: no pid left to take for a killed holder
            if self._made_folder and os.listdir(self.folder) == [LOCK_FILE]:
                self.path.unlink()  # still locked: a waiter sees the unlink (`_same_file`)
                self.folder.rmdir()
        except OSError:
            pass  # the lock itself goes with the descriptor either way
        finally:
            os.close(fd)

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def holder(folder: str | Path) -> RunLocked | None:
    """Whether a live process holds `folder`'s lock (its `RunLocked`, naming the pid), found
    without taking the lock nor writing anything: readers of a finished run (an export) need
    no write access to it, and leave a killed run's pid for `--resume` to report."""
    path = Path(folder) / LOCK_FILE
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # no lock file: no run ever held it, or it was released and removed
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return RunLocked(Path(folder), _read_pid(fd))
    except OSError:
        return None
    finally:
        os.close(fd)  # closing the descriptor releases the shared lock just taken
    return None


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def _same_file(fd: int, path: Path) -> bool:
    try:
        here, there = os.fstat(fd), os.stat(path)
    except FileNotFoundError:
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)

"""Outputs that are whole or absent.

* `removed_on_failure`: a new output folder that a failing command takes back: `cocobench
  export` and `cocobench import-inspect` leave either the whole folder or nothing (a
  half-written one would be refused as taken by the same command run again).
* `staged_beside`: a hidden file or folder beside the output, renamed to it once whole
  (`cocobench submit pack`, `cocobench leaderboard`). A SIGKILL leaves it behind, so each
  staged one is locked while its process lives and the next command writing beside it removes
  those of dead processes.
"""

from __future__ import annotations

import fcntl
import os
import secrets
import shutil
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

#: The name a staged output takes once it is locked; before, it is `.new`.
STAGED_SUFFIX, FRESH_SUFFIX = ".partial", ".new"
#: A writer locks what it made within microseconds: an unlocked `.new` this old was left by a
#: process killed in between.
FRESH_ABANDONED_S = 60


@contextmanager
def removed_on_failure(out: Path) -> Iterator[None]:
    """Remove what the block wrote under `out` when it raises (anything, Ctrl-C too): `out`
    itself if it did not exist before, else the entries it did not hold before (what was
    there is left as it was)."""
    before = set(out.iterdir()) if out.is_dir() else None
    try:
        yield
    except BaseException:
        if before is None:
            shutil.rmtree(out, ignore_errors=True)
        else:
            for child in set(out.iterdir()) - before:
                if child.is_dir() and not child.is_symlink():
                    shutil.rmtree(child, ignore_errors=True)
                else:
                    child.unlink(missing_ok=True)
        raise


@contextmanager
def staged_beside(out: Path, *, folder: bool) -> Iterator[Path]:
    """A new hidden file (or folder) beside `out`, on its file system so that one rename
    publishes it, held under an exclusive `flock` until the block ends (the kernel drops the
    lock when the process dies, even by SIGKILL); removed after the block unless renamed away.
    The staged outputs beside `out` of processes that are gone are removed first. `OSError`
    where `out`'s folder cannot be written."""
    out.parent.mkdir(parents=True, exist_ok=True)
    reclaim_abandoned(out)
    stem = out.parent / f".{out.name}.{secrets.token_hex(6)}"
    fresh = stem.with_name(stem.name + FRESH_SUFFIX)  # reclaimed only when old: not locked yet
    if folder:
        fresh.mkdir()  # as `out` would be made: the user's umask, not a private 0700
    else:
        fresh.touch(exist_ok=False)
    staged = stem.with_name(stem.name + STAGED_SUFFIX)
    try:
        descriptor = os.open(fresh, os.O_RDONLY)
    except OSError:
        _remove(fresh)
        raise
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        fresh.rename(staged)  # named once locked: an unlocked staged output is abandoned
        yield staged
    finally:
        _remove(staged)
        _remove(fresh)
        os.close(descriptor)


def reclaim_abandoned(out: Path) -> list[Path]:
    """Remove the staged outputs beside `out` whose process is gone (an unheld lock, or
    never locked and old); what was removed."""
    removed = []
    for fresh in out.parent.glob(f".{out.name}.*{FRESH_SUFFIX}"):
        with suppress(OSError):
            if time.time() - fresh.lstat().st_mtime > FRESH_ABANDONED_S:
                _remove(fresh)
                removed.append(fresh)
    for staged in out.parent.glob(f".{out.name}.*{STAGED_SUFFIX}"):
        try:
            descriptor = os.open(staged, os.O_RDONLY)
        except OSError:  # gone meanwhile, or another user's
            continue
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its process is writing it
            continue
        else:
            _remove(staged)
            removed.append(staged)
        finally:
            os.close(descriptor)
    return removed


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with suppress(FileNotFoundError):
            path.unlink()

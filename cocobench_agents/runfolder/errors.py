"""Why a run folder cannot be used: a mistake of the user's (`RunFolderError`), or a folder
that cannot be written (`RunFolderWriteError`: the run stops, what it recorded stays valid)."""

from __future__ import annotations

from pathlib import Path


class RunFolderError(ValueError):
    """A run folder that cannot be used as asked (exists without --resume, …)."""


class RunFolderWriteError(RuntimeError):
    """The run folder could not be written (a full disk, an I/O error): the run stops, what
    it recorded stays valid, and `--resume` completes it."""


def read_failed(path: Path, exc: OSError) -> RunFolderError:
    """The `RunFolderError` of `path`, which `exc` could not read (a folder, no permission,
    an I/O error)."""
    return RunFolderError(f"{path}: unreadable ({exc.strerror or exc})")


def write_failed(path: Path, exc: OSError) -> RunFolderWriteError:
    """The `RunFolderWriteError` of `path` that `exc` could not write."""
    return RunFolderWriteError(f"cannot write {path}: {exc.strerror or exc}")


def gist(exc: BaseException) -> str:
    """The first line of `exc`'s message, short (its type when it has none)."""
    return str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__

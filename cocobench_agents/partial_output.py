"""A new output folder that a failing command takes back: `cocobench export` and `cocobench
import-inspect` leave either the whole folder or nothing (a half-written one would be refused
as taken by the same command run again)."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def removed_on_failure(out: Path) -> Iterator[None]:
    """Remove what the block wrote under `out` when it raises (anything, Ctrl-C too): `out`
    itself if it did not exist before, else its contents (it was empty: the command checked)."""
    made = not out.exists()
    try:
        yield
    except BaseException:
        if made:
            shutil.rmtree(out, ignore_errors=True)
        else:
            for child in out.iterdir() if out.is_dir() else ():
                if child.is_dir() and not child.is_symlink():
                    shutil.rmtree(child, ignore_errors=True)
                else:
                    child.unlink(missing_ok=True)
        raise

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

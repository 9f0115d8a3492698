"""Fixtures for the report tests (see helpers.py for the static run folders)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from .helpers import RUN_SMALL


@pytest.fixture
def small_copy(tmp_path: Path) -> Path:
    """A writable copy of run_small."""
    return Path(shutil.copytree(RUN_SMALL, tmp_path / "run_small"))

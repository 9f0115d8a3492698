"""Fixtures for the core tests: synthetic kitchens (see `worlds.py`)."""

from __future__ import annotations

import pytest

from .worlds import Sim, make_config, make_sim


@pytest.fixture
def kitchen() -> Sim:
    """The default two-agent kitchen, reset."""
    return make_sim(make_config())

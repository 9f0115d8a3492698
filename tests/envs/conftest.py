"""Shared pieces of the environments' tests."""

from __future__ import annotations

import warnings

import pytest


@pytest.fixture
def quiet():
    """Warnings ignored: the ecosystem's checkers warn about dict and text spaces (the prompt
    needs them) and about reset's option ``{"options": 1}``, which PettingZoo passes to check
    that options are taken; LiteLLM warns on its own. (`pytest.warns` still sees warnings.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield

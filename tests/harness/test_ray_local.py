"""The private local Ray is private: its keeper starts a Ray of its own even where RAY_ADDRESS
(or /tmp/ray's record of the last cluster started on the machine, which another test's
cluster writes) names another."""

from __future__ import annotations

import pytest

from cocobench_agents.harness.ray_local import local_ray

pytestmark = [pytest.mark.needs_ray, pytest.mark.slow]


def test_the_local_ray_starts_its_own_where_ray_address_names_another(monkeypatch):
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:9")  # nothing listens there
    with local_ray(1) as local:
        assert local.address.rpartition(":")[2] != "9"
    assert local.keeper.returncode == 0

"""Every shared config's oracle gives the same trajectory through the thor adapter (ai2thor's
Controller over a fake Unity backed by the embedded world) as on the embedded backend.

One fake AI2-THOR process serves all 36 episodes in turn, as a worker's pooled controller
would: each episode reconfigures it with a reset (new scene, new agentCount).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import pytest

from benchmark_adapter.metrics import score_trajectory
from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.thor import ThorController, ThorOptions
from benchmark_adapter.sim.thor.pool import ControllerPool
from benchmark_adapter.tasks import TaskConfig, load_task

from .conftest import SHARED_FILES, needs_data, shared_library

if TYPE_CHECKING:
    from .fake_unity import SceneLibrary

pytestmark = [pytest.mark.needs_thor, needs_data]


@pytest.fixture(scope="module")
def shared_thor() -> Iterator[tuple[SceneLibrary, ControllerPool, Any]]:
    """One library, pool and factory for the whole module (so one fake Unity is reused)."""
    from .fake_unity import fake_factory  # needs ai2thor: imported once the test runs

    library = shared_library()
    pool = ControllerPool(install_exit_hooks=False)
    yield library, pool, fake_factory(library)
    pool.close()


def run_both(config: TaskConfig, shared_thor) -> tuple[dict, dict]:
    library, pool, factory = shared_thor
    library.add(config)
    with ThorController(config, ThorOptions(), factory=factory, pool=pool) as thor:
        on_thor = run_oracle(config, controller=thor)
    return on_thor, run_oracle(config, controller=EmbeddedController(config))


def steps(document: dict) -> list[tuple[str, Any, str]]:
    return [
        (
            item["label"],
            item.get("skill_result", {}).get("success"),
            item.get("skill_result", {}).get("errorMessage"),
        )
        for item in document["trajectory"]
    ]


def without_backend(document: dict) -> str:
    document = json.loads(json.dumps(document))
    for item in document["trajectory"]:
        (item.get("policy_decision") or {}).pop("backend", None)
    return json.dumps(document, sort_keys=True)


@pytest.mark.parametrize("path", SHARED_FILES, ids=[p.stem for p in SHARED_FILES])
def test_oracle_results_match_the_embedded_backend(path, shared_thor):
    config = load_task(path)
    on_thor, on_embedded = run_both(config, shared_thor)
    thor, embedded = score_trajectory(on_thor), score_trajectory(on_embedded)
    assert thor.task_success == embedded.task_success == 1
    assert thor.legal_plan == embedded.legal_plan
    assert thor.construct_score == embedded.construct_score
    assert steps(on_thor) == steps(on_embedded)
    assert [t["lastActionSuccess"] for t in on_thor["init_trace"]] == [
        t["lastActionSuccess"] for t in on_embedded["init_trace"]
    ]
    # Stronger: the whole documents agree (states, native traces, evals), backend aside.
    assert without_backend(on_thor) == without_backend(on_embedded)
    assert on_thor["trajectory"][-1]["policy_decision"]["backend"] == "ai2thor"
    library, pool, _ = shared_thor
    assert len(library.servers) == len(pool) == 1  # the same fake AI2-THOR, reconfigured

"""Golden prompts: what each planner shows a model, in both views, for a D1, a D3 and a D4
instance, must equal the reviewed files under `golden/`.

Regenerate after an intended change with `COCOBENCH_UPDATE_GOLDEN=1 pytest tests/planners`,
then review the diff.
"""

from __future__ import annotations

import asyncio
import io
import os
from pathlib import Path

import pytest
from PIL import Image

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.episode_runner import EpisodeSpec, run_episode

from .recording import RecordingPool

GOLDEN = Path(__file__).parent / "golden"
INSTANCES = ("G_D1__DemoLivingRoom1__seed0", "K_D3__DemoKitchen1__seed0",
             "J_D4__DemoBedroom2__seed0")
PLANNERS = ("centralized", "decentralized", "decentralized-broadcast", "leader-worker")
DECISIONS_KEPT = 5  # enough to show history, messages and a changed menu
STEPS = 3


def render_requests(requests) -> str:
    parts = []
    for i, request in enumerate(requests[:DECISIONS_KEPT], 1):
        sizes = [Image.open(io.BytesIO(png)).size for png in request.images]
        header = (f"=== request {i} | agent={request.agent} | images="
                  f"{[f'{w}x{h}' for w, h in sizes]} | menu ids={len(request.menu)} ===")
        parts.append(f"{header}\n{request.prompt}\n")
    return "\n".join(parts)


@pytest.mark.parametrize("obs_mode", ["image", "blind"])
@pytest.mark.parametrize("planner", PLANNERS)
@pytest.mark.parametrize("task_id", INSTANCES)
def test_prompts_equal_the_reviewed_files(task_id: str, planner: str, obs_mode: str) -> None:
    config = next(c for c in load_tasks("demo") if c.task_id == task_id)
    pool = RecordingPool()
    spec = EpisodeSpec(config, planner=planner, obs_mode=obs_mode, max_steps=STEPS)
    asyncio.run(run_episode(spec, pool))
    text = render_requests(pool.client_.requests)
    golden = GOLDEN / task_id / f"{planner}_{obs_mode}.txt"
    if os.environ.get("COCOBENCH_UPDATE_GOLDEN"):
        golden.parent.mkdir(parents=True, exist_ok=True)
        golden.write_text(text, encoding="utf-8")
    assert golden.exists(), f"missing golden file {golden} (set COCOBENCH_UPDATE_GOLDEN=1)"
    assert text == golden.read_text(encoding="utf-8")

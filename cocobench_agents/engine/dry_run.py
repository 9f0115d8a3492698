"""`plan(request)`: what a request would run and spend, before anything is spent.

It resolves the request as `run` would (the same checks: unusable configs, unknown
conditions or models are the same errors), then estimates each model × condition × arm
(`estimate`). It calls no model and writes nothing: not even the run folder.
"""

from __future__ import annotations

from cocobench_agents.engine.costs import CostPlan
from cocobench_agents.engine.estimate import estimate
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.engine.resolve import canonical, resolve
from cocobench_agents.runfolder.folder import RunFolder


def plan(request: RunRequest, *, resume: bool = False) -> CostPlan:
    """The estimate of `request`'s episodes (with `resume`, of those its run folder has not
    recorded yet)."""
    request = canonical(request)
    resolved = resolve(request, notify=lambda message: None)
    episodes = resolved.episodes
    folder = RunFolder(request.out)
    if resume and folder.record_path.is_file():
        from cocobench_agents.harness.pending import pending_episodes

        episodes = pending_episodes(episodes, folder)
    return estimate(episodes, request.model_settings,
                    max_cost_usd=request.limits.max_cost)

"""`plan(request)`: what a request would run and spend, before anything is spent.

It resolves the request as `run` would (the same checks: unusable configs, unknown
conditions or models are the same errors), then estimates each model × condition × arm
(`estimate`), and what difference in success rate the run could detect (`power`). It calls
no model and writes nothing: not even the run folder.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from cocobench_agents.engine.costs import CostPlan
from cocobench_agents.engine.estimate import estimate
from cocobench_agents.engine.power import PRIOR_VARIANCE, baseline_variance, power_of
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.engine.resolve import canonical, resolve
from cocobench_agents.runfolder.folder import RunFolder


def plan(request: RunRequest, *, resume: bool = False,
         power_baseline: str | Path | None = None, detect: float | None = None) -> CostPlan:
    """The estimate of `request`'s episodes (with `resume`, of those its run folder has not
    recorded yet), with the power of the whole planned run: the smallest paired SR difference
    between two arms it detects (variances from the run `power_baseline`, else a prior) and,
    given `detect`, the epochs or instances that detect that difference."""
    request = canonical(request)
    variance = PRIOR_VARIANCE if power_baseline is None else baseline_variance(power_baseline)
    resolved = resolve(request, notify=lambda message: None)
    episodes = resolved.episodes
    power = power_of(len({e.key.task_id for e in episodes}), request.epochs, variance,
                     detect=detect)
    folder = RunFolder(request.out)
    if resume and folder.record_path.is_file():
        from cocobench_agents.harness.pending import pending_episodes

        episodes = pending_episodes(episodes, folder)
    costs = estimate(episodes, request.model_settings, max_cost_usd=request.limits.max_cost)
    return dataclasses.replace(costs, power=power)

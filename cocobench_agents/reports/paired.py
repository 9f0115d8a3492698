"""The arms of an ablation side by side, each with its paired difference from the first arm.

Arms are the prompt-suite arms of a run (rows ``MODEL @ARM``), runs reported with ``--arms``
(``MODEL @RUN``) and the planner arms of a run (``--planner A --planner B``: one condition
each). Within each model and condition (for planner arms: model and observation mode) the
first arm, in the order given on the command line, is the baseline. A difference is taken over
the instances (task, epoch) that both arms have, and its interval resamples those instances
with the same indices for both arms (`stats.paired_diff_ci`); a construct-score difference
uses the pairs where both episodes are scored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cocobench_agents.conditions import split_condition
from cocobench_agents.reports.load import ReportData
from cocobench_agents.reports.result_tables import (
    Ctx,
    delta_cells,
    paired_indices,
    sr_cs_cells,
    sr_cs_columns,
)
from cocobench_agents.reports.table import Column, Table

NAME = "arms"


@dataclass(frozen=True)
class ArmGroup:
    """The arms compared under one model and condition, baseline first."""

    model: str
    condition: str  # the condition; for planner arms, the observation mode they share
    arms: list[tuple[str, np.ndarray]]  # (arm, mask of its episodes)
    pair_by: str  # the episode column both arms of a pair share besides task and epoch


def arm_groups(data: ReportData) -> list[ArmGroup]:
    """Every model × condition with at least two arms that have episodes."""
    return [*_model_arm_groups(data), *_planner_arm_groups(data)]


def _model_arm_groups(data: ReportData) -> list[ArmGroup]:
    """Rows labelled ``MODEL @ARM`` (`ReportData.model_arms`), grouped by model."""
    by_model: dict[str, list[tuple[str, str]]] = {}
    for label in data.models:  # the plan's order: arms as given, runs as given
        if label in data.model_arms:
            model, arm = data.model_arms[label]
            by_model.setdefault(model, []).append((arm, label))
    ep = data.episodes
    groups = []
    for model, arms in by_model.items():
        for condition in data.conditions if len(arms) > 1 else []:
            masks = [(arm, ep.mask(model=label, condition=condition)) for arm, label in arms]
            masks = [(arm, mask) for arm, mask in masks if mask.any()]
            if len(masks) > 1:
                groups.append(ArmGroup(model, condition, masks, "condition"))
    return groups


def _planner_arm_groups(data: ReportData) -> list[ArmGroup]:
    """The conditions of runs that gave several planners (`plan.planner_arms`), grouped by
    model and observation mode."""
    arms = list(dict.fromkeys(c for run in data.runs for c in run.plan.get("planner_arms") or []
                              if c in data.conditions))
    ep = data.episodes
    groups = []
    for model in data.models:
        for obs in data.obs_modes():
            masks = [(c, ep.mask(model=model, condition=c)) for c in arms
                     if split_condition(c)[1] == obs]
            masks = [(arm, mask) for arm, mask in masks if mask.any()]
            if len(masks) > 1:
                groups.append(ArmGroup(model, obs, masks, "obs"))
    return groups


def arms_table(ctx: Ctx) -> Table:
    """Each arm's SR and CS, then each arm's paired difference from the baseline arm."""
    table = Table(
        NAME, "Arms: paired differences",
        "Each model and condition's arms (prompt suites, runs given with --arms, or planners; "
        "for planner arms the Condition column is the observation mode they share), then "
        "`ARM - BASELINE` rows: the mean paired difference from the first arm given (the "
        "baseline) over the instances (task, epoch) both arms have (n = pairs; CS over the "
        "pairs where both are scored), with a 95% bootstrap interval that resamples "
        "instances with the same indices for both arms. SR differences in percentage points.",
        [Column("model", "Model"), Column("condition", "Condition"), Column("arm", "Arm"),
         Column("baseline", "Baseline", markdown=False), Column("n", "n", "int"),
         *sr_cs_columns()])
    for group in arm_groups(ctx.data):
        base, base_mask = group.arms[0]
        for arm, mask in group.arms:
            table.rows.append([group.model, group.condition, arm, "", int(mask.sum()),
                               *sr_cs_cells(ctx, mask)])
        for arm, mask in group.arms[1:]:
            ia, ib = paired_indices(ctx, mask, base_mask, group.pair_by)
            table.rows.append([group.model, group.condition, f"{arm} - {base}", base,
                               int(ia.size), *delta_cells(ctx, ia, ib)])
    return table

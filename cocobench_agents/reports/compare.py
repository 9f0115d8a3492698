"""Models compared with each other on the instances both ran (`compare.{md,csv}`).

For each pair of report rows' models (every pair in report order, or each model against a
chosen baseline) and each condition: the paired differences in SR, CS and legal-plan rate
over the episodes of the same task and epoch, with intervals that resample instances; how
many instances each model wins, loses or ties on (by its success rate over the instance's
paired epochs); and an exact two-sided test of the SR difference (McNemar's, over instances).
Runs reported with `--arms` are models labelled ``MODEL @RUN``, so they are compared too.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from cocobench_agents.reports.load import ReportError
from cocobench_agents.reports.result_tables import Ctx, paired_indices
from cocobench_agents.reports.stats import sign_test_p
from cocobench_agents.reports.table import Column, Table

NAME = "compare"


def model_pairs(models: list[str], baseline: str | None = None) -> Iterator[tuple[str, str]]:
    """(model, baseline) pairs: each model against `baseline`, or every later model against
    every earlier one (report order)."""
    if baseline is not None:
        if baseline not in models:
            raise ReportError(f"--baseline {baseline}: no such model in the runs (models: "
                              f"{', '.join(models) or 'none'})")
        yield from ((m, baseline) for m in models if m != baseline)
        return
    for i, base in enumerate(models):
        for model in models[i + 1:]:
            yield model, base


def compare(ctx: Ctx, baseline: str | None = None) -> Table:
    """Paired model differences per condition, with wins/losses/ties and McNemar's p."""
    table = Table(
        NAME, "Model comparisons (paired)",
        "`MODEL - BASELINE` under each condition, over the episodes both ran (same task and "
        "epoch; n = pairs, instances = their tasks): the mean paired difference in SR, CS "
        "(pairs where both are scored) and legal-plan rate (pairs where both have one), in "
        "percentage points for rates, with 95% bootstrap intervals that resample instances "
        "(all epochs of a task together, both models with the same draws). Wins / Losses / "
        "Ties: instances where MODEL's success rate over the paired epochs is higher / lower "
        "/ equal. p (McNemar) = exact two-sided binomial test of wins against losses: with "
        "one epoch, McNemar's exact test on the discordant pairs; with several, the same "
        "test over instances (a sign test), which keeps instances independent.",
        [Column("model", "Model"), Column("baseline", "Baseline"),
         Column("condition", "Condition"), Column("n", "n", "int"),
         Column("instances", "Instances", "int"),
         Column("sr", "SR diff", "pct"), Column("cs", "CS diff", "score", show_n=True),
         Column("legal", "Legal diff", "pct", show_n=True),
         Column("wins", "Wins", "int"), Column("losses", "Losses", "int"),
         Column("ties", "Ties", "int"), Column("mcnemar_p", "p (McNemar)", "p", estimate=False)])
    ep = ctx.ep
    success = ep.col("success")
    for model, base in model_pairs(ctx.data.models, baseline):
        for condition in ctx.data.conditions:
            ia, ib = paired_indices(ctx, ep.mask(model=model, condition=condition),
                                    ep.mask(model=base, condition=condition), "condition")
            if not ia.size:
                continue
            wins, losses, ties = _by_instance(success[ia] - success[ib], ctx.instances[ia])
            table.rows.append([
                model, base, condition, int(ia.size), wins + losses + ties,
                *(ctx.diff_of(ep.col(c), ep.col(c), ia, ib) for c in ("success", "cs", "legal")),
                wins, losses, ties, sign_test_p(wins, losses)])
    return table


def _by_instance(diffs: np.ndarray, instances: np.ndarray) -> tuple[int, int, int]:
    """Instances where the summed paired difference is positive, negative, zero."""
    codes, inverse = np.unique(instances, return_inverse=True)
    per = np.bincount(inverse.ravel(), weights=diffs, minlength=codes.size)
    return int((per > 0).sum()), int((per < 0).sum()), int((per == 0).sum())

"""How reliably each model succeeds when an instance is run several times (`--epochs N`).

Per model and condition: pass^k (all of k fresh trials succeed) and pass@k (at least one
does) for k = 1…N, with the unbiased estimators from each instance's n trials; the share of
instances whose outcome never flips between epochs; and the between-epoch share of the
outcome's variance. Written only when some instance ran at least twice. See
docs/statistics.md.
"""

from __future__ import annotations

import numpy as np

from cocobench_agents.reports.result_tables import ID_COLUMNS, Ctx
from cocobench_agents.reports.stats import (
    Estimate,
    cluster_totals,
    mean_ci,
    pass_at_k,
    pass_hat_k,
    within_share_ci,
)
from cocobench_agents.reports.table import Column, Table

NAME = "reliability"


def epochs_per_instance(ctx: Ctx) -> int:
    """The most episodes any instance (model, condition, task) has."""
    return int(np.bincount(ctx.instances).max()) if ctx.instances.size else 0


def reliability(ctx: Ctx) -> Table:
    """pass^k, pass@k, consistency and the between-epoch variance share per model and
    condition."""
    epochs = epochs_per_instance(ctx)
    ks = range(1, epochs + 1)
    table = Table(
        NAME, "Reliability over epochs",
        "Per instance (task) with n epochs and c successes: pass^k = C(c,k)/C(n,k), the "
        "unbiased estimate of the chance that k fresh trials all succeed (tau-bench), and "
        "pass@k = 1 - C(n-c,k)/C(n,k), that at least one does (the Codex paper); both "
        "averaged over the instances with at least k epochs (pass@1 = pass^1, the success "
        "rate averaged by instance). Consistent = share of the instances run at least twice "
        "whose outcome never flips. Between-epoch var. = share of the outcome's variance "
        "between epochs of one instance rather than between instances (0: each instance "
        "always succeeds or always fails; 1: the instance does not matter). Rates in %; "
        "95% bootstrap intervals resample instances.",
        [*ID_COLUMNS[:2], Column("instances", "Instances", "int"),
         Column("epochs", "Epochs", "int"),
         *(Column(f"pass_hat_{k}", f"pass^{k}", "pct") for k in ks),
         *(Column(f"pass_at_{k}", f"pass@{k}", "pct") for k in ks if k > 1),
         Column("consistent", "Consistent", "pct", show_n=True),
         Column("between_epoch_share", "Between-epoch var.", "score")])
    success = ctx.ep.col("success")
    for model, condition, mask in ctx.cells():
        c, n = cluster_totals(success[mask], ctx.instances[mask])
        table.rows.append([
            model, condition, int(c.size), int(n.max()) if n.size else 0,
            *(_per_instance_mean(pass_hat_k(c, n, k), ctx) for k in ks),
            *(_per_instance_mean(pass_at_k(c, n, k), ctx) for k in ks if k > 1),
            _per_instance_mean(np.where(n >= 2, (c == 0) | (c == n), np.nan), ctx),
            within_share_ci(c, n, ctx.boot)])
    return table


def _per_instance_mean(values: np.ndarray, ctx: Ctx) -> Estimate:
    """The mean over instances of one value each (NaN: left out), resampling instances."""
    return mean_ci(values.astype(np.float64), ctx.boot)

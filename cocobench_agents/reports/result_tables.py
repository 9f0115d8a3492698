"""The paper's result tables, one function each: (ReportData, Bootstrap) -> Table.

Rates and means carry percentile-bootstrap intervals that resample instances: every epoch of
an instance (model, condition, task) is drawn together (a clustered bootstrap, see `stats`;
with one epoch, that is resampling episodes). Missing values (None in a result line, e.g. a
gated construct score) are left out of a mean, and the estimate's n says how many episodes
it rests on. Differences between conditions are paired:
episodes of the same task and epoch under both conditions (see `architecture`).
The failure, legality, cost and correlation tables are in `diagnostics`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from benchmark_adapter.vocabulary import BLIND, IMAGE
from cocobench_agents.reports.load import DIMENSIONS, ReportData
from cocobench_agents.reports.stats import (
    Bootstrap,
    Estimate,
    cluster_codes,
    mean_ci,
    paired_diff_ci,
)
from cocobench_agents.reports.table import Column, Table
from cocobench_agents.runfolder.infra import retry_command
from cocobench_agents.runfolder.result_line import CS_NOTE

BASELINE_ARCH = "C0"
TEAM_SIZES = (2, 3, 4)
GROUPS = (None, *DIMENSIONS)  # None: all dimensions
#: The leading columns of a table with one row per model and condition.
ID_COLUMNS = [Column("model", "Model"), Column("condition", "Condition"),
              Column("n", "n", "int")]


@dataclass
class Ctx:
    """What every table function works from."""

    data: ReportData
    boot: Bootstrap

    @property
    def ep(self):
        return self.data.episodes

    @cached_property
    def instances(self) -> np.ndarray:
        """Each episode's instance (model, condition, task) as an integer code: the cluster
        every interval resamples, all epochs of an instance together."""
        ep = self.ep
        return cluster_codes(np.array(["\x1f".join(key) for key in zip(
            ep.text["model"], ep.text["condition"], ep.text["task_id"])], dtype=object))

    @cached_property
    def clustered(self) -> bool:
        """Whether some instance ran more than once (epochs): intervals then differ from a
        bootstrap over episodes, and the tables say so."""
        return bool(self.instances.size) and int(self.instances.max()) + 1 < self.instances.size

    def mean(self, column: str, mask: np.ndarray) -> Estimate:
        return self.mean_of(self.ep.col(column), mask)

    def mean_of(self, values: np.ndarray, mask: np.ndarray) -> Estimate:
        """The mean of per-episode `values` over `mask`, its interval clustered by instance."""
        return mean_ci(values[mask], self.boot, self.instances[mask])

    def diff_of(self, a: np.ndarray, b: np.ndarray, ia: np.ndarray, ib: np.ndarray
                ) -> Estimate:
        """The paired difference a[ia] − b[ib], its interval clustered by the instance of
        the first of each pair."""
        return paired_diff_ci(a[ia], b[ib], self.boot, self.instances[ia])

    def cells(self) -> Iterator[tuple[str, str, np.ndarray]]:
        """(model, condition, mask) for every pair with episodes, in report order."""
        for model in self.data.models:
            for condition in self.data.conditions:
                mask = self.ep.mask(model=model, condition=condition)
                if mask.any():
                    yield model, condition, mask


def group_prefix(group: str | None) -> tuple[str, str]:
    """(CSV key prefix, Markdown header prefix) of a dimension group."""
    return ("", "") if group is None else (f"{group.lower()}_", f"{group} ")


def sr_cs_columns() -> list[Column]:
    cols = []
    for group in GROUPS:
        key, head = group_prefix(group)
        cols += [Column(f"{key}sr", f"{head or 'Overall '}SR", "pct"),
                 Column(f"{key}cs", f"{head or 'Overall '}CS", "score", show_n=True)]
    return cols


def sr_cs_cells(ctx: Ctx, mask: np.ndarray) -> list[Estimate]:
    out = []
    for group in GROUPS:
        m = mask & ctx.ep.mask(dim=group)
        out += [ctx.mean("success", m), ctx.mean("cs", m)]
    return out


def main_results(ctx: Ctx) -> Table:
    """Overall and per-dimension SR and CS per model and condition (paper Table 1)."""
    table = Table(
        "main_results", "Main results",
        "SR = task success rate (%); CS = mean construct score (0-1) over the episodes whose "
        f"own-dimension score is scored (gated NA scores excluded; n shown). {CS_NOTE} 95% "
        "bootstrap intervals in brackets. The paper's Table 1 is the C0_image rows.",
        [*ID_COLUMNS, *sr_cs_columns()], warnings=infra_warnings(ctx.data))
    for model, condition, mask in ctx.cells():
        table.rows.append([model, condition, int(mask.sum()), *sr_cs_cells(ctx, mask)])
    return table


def infra_warnings(data: ReportData) -> list[str]:
    """What the report says above its main table about infrastructure failures (and how to
    re-run them) and about planner errors (which a re-run would repeat)."""
    if not len(data.episodes):
        return []
    failed = int(data.episodes.col("infra_failure").sum())
    planner = int(data.episodes.col("planner_failure").sum())
    warnings = []
    if failed:
        retries = "; ".join(retry_command(r.path, r.record) for r in data.runs
                            if r.infra_errors)
        warnings.append(
            f"{failed} of {len(data.episodes)} episodes ended on an infrastructure error "
            "(model backend error, timeout, unsupported input, or the harness), not on the "
            f"model's choices; they count as failures in every rate. Re-run them: {retries}")
    if planner:
        warnings.append(
            f"{planner} of {len(data.episodes)} episodes ended on a planner error (the "
            "strategy's own code: each trajectory's stop decision names the node, file and "
            "line); they count as failures in every rate, and running them again unchanged "
            "fails the same way")
    return warnings


def paired_indices(ctx: Ctx, mask_a: np.ndarray, mask_b: np.ndarray, by: str
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Episodes of a and b with the same task, epoch and `by` column (index arrays)."""
    ep = ctx.ep
    task, other = ep.text["task_id"], ep.text[by]
    lookup = {(other[i], task[i], ep.epoch[i]): i for i in np.flatnonzero(mask_b)}
    pairs = [(i, lookup[k]) for i in np.flatnonzero(mask_a)
             if (k := (other[i], task[i], ep.epoch[i])) in lookup]
    if not pairs:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    a, b = zip(*pairs)
    return np.array(a, dtype=np.int64), np.array(b, dtype=np.int64)


def delta_cells(ctx: Ctx, ia: np.ndarray, ib: np.ndarray) -> list[Estimate]:
    """Paired differences a - b of SR and CS, overall and per dimension."""
    dims = ctx.ep.text["dim"][ia]
    out = []
    for group in GROUPS:
        keep = np.ones(ia.size, dtype=bool) if group is None else dims == group
        for column in ("success", "cs"):
            col = ctx.ep.col(column)
            out.append(ctx.diff_of(col, col, ia[keep], ib[keep]))
    return out


def _factor_table(ctx: Ctx, *, name: str, title: str, caption: str, factor: str,
                  header: str, levels: list[str], baseline: str | None, pair_by: str
                  ) -> Table:
    table = Table(name, title, caption,
                  [Column("model", "Model"), Column(factor, header),
                   Column("n", "n", "int"), *sr_cs_columns()])
    ep = ctx.ep
    for model in ctx.data.models:
        in_model = ep.mask(model=model)
        masks = {level: in_model & ep.mask(**{factor: level}) for level in levels}
        for level, mask in masks.items():
            if mask.any():
                table.rows.append([model, level, int(mask.sum()), *sr_cs_cells(ctx, mask)])
        if baseline is None or not masks[baseline].any():
            continue
        for level, mask in masks.items():
            if level == baseline:
                continue
            ia, ib = paired_indices(ctx, mask, masks[baseline], pair_by)
            if ia.size:
                table.rows.append([model, f"{level} - {baseline}", int(ia.size),
                                   *delta_cells(ctx, ia, ib)])
    return table


def architecture(ctx: Ctx) -> Table:
    """SR and CS per planner architecture, pooled over observation modes, and the paired
    change of each decentralized architecture relative to C0 (paper Figure 3)."""
    archs = ctx.data.architectures()
    return _factor_table(
        ctx, name="architecture", title="Architecture effects",
        caption="Rows per architecture pool both observation modes. `X - C0` rows are paired "
                "differences: each episode of X is matched with the C0 episode of the same "
                "task, epoch and observation mode (n = pairs; CS over pairs where both are "
                "scored). SR differences in percentage points.",
        factor="arch", header="Architecture", levels=archs,
        baseline=BASELINE_ARCH if BASELINE_ARCH in archs else None, pair_by="obs")


def observation(ctx: Ctx) -> Table:
    """SR and CS with images versus blind, pooled over architectures, and the paired
    difference blind - image (paper Figure 4)."""
    modes = [m for m in ctx.data.obs_modes() if m]  # conditions without a mode are left out
    return _factor_table(
        ctx, name="observation", title="Observation: image vs blind",
        caption="Rows per observation mode pool all architectures. The `blind - image` row "
                "pairs each blind episode with the image episode of the same task, epoch and "
                "architecture (n = pairs). SR differences in percentage points.",
        factor="obs", header="Observation", levels=modes,
        baseline=IMAGE if IMAGE in modes and BLIND in modes else None, pair_by="arch")


def team_sizes(data: ReportData) -> list[int]:
    counts = data.episodes.col("agent_count")
    found = {int(c) for c in counts[~np.isnan(counts)]}
    return sorted(found | set(TEAM_SIZES))


def team_size(ctx: Ctx) -> Table:
    """SR and CS at each team size per model and condition (paper Figure 5)."""
    sizes = team_sizes(ctx.data)
    columns = [Column("model", "Model"), Column("condition", "Condition")]
    for k in sizes:
        columns += [Column(f"n_{k}", f"n @{k}", "int"), Column(f"sr_{k}", f"SR @{k}", "pct"),
                    Column(f"cs_{k}", f"CS @{k}", "score", show_n=True)]
    table = Table("team_size", "Team size",
                  "SR (%) and CS at each number of agents (columns @k). Sizes without "
                  "episodes are NA.", columns)
    agents = ctx.ep.col("agent_count")
    for model, condition, mask in ctx.cells():
        row: list = [model, condition]
        for k in sizes:
            m = mask & (agents == k)
            row += [int(m.sum()), ctx.mean("success", m), ctx.mean("cs", m)]
        table.rows.append(row)
    return table

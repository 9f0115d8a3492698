"""Failure, legality, cost and construct-correlation tables (paper §Failure analysis,
supplementary Tables 5-6, Figure 2)."""

from __future__ import annotations

import numpy as np

from benchmark_adapter.metrics import FAILURE_KINDS
from cocobench_agents.reports.load import DIMENSIONS, INFRA_KIND, UNRECORDED_KIND
from cocobench_agents.reports.result_tables import ID_COLUMNS, Ctx
from cocobench_agents.reports.stats import correlation_matrix, total
from cocobench_agents.reports.table import Column, Table

FLAGS = (("dep", "Dep"), ("occ", "Occ"), ("aff", "Aff"), ("ill", "Ill"))
POOLED = "(all)"


def failure_diagnostics(ctx: Ctx) -> Table:
    """How failed episodes fail (supplementary Table 5)."""
    table = Table(
        "failure_diagnostics", "Failure diagnostics",
        "Prog. (fail) = mean task progress on failed episodes (%); Steps (succ.) = mean "
        "executed steps on successful episodes; Inv. act. = mean invalid-action ratio over "
        "all episodes (%); Dep/Occ/Aff/Ill = share of failed episodes with at least one "
        "dependency violation / occupancy conflict / affordance failure / illegal skill (%), "
        "pooled over dimensions (not exclusive). Infrastructure failures count as failed "
        "but have no trajectory, so they are left out of the per-episode diagnostics.",
        [*ID_COLUMNS, Column("failed", "Failed", "int"),
         Column("progress_fail", "Prog. (fail)", "pct"),
         Column("steps_success", "Steps (succ.)", "num", show_n=True),
         Column("invalid_ratio", "Inv. act.", "pct"),
         *(Column(key, head, "pct") for key, head in FLAGS)])
    success = ctx.ep.col("success")
    for model, condition, mask in ctx.cells():
        failed = mask & (success == 0)
        table.rows.append([
            model, condition, int(mask.sum()), int(failed.sum()),
            ctx.mean("progress", failed), ctx.mean("steps", mask & (success == 1)),
            ctx.mean("invalid_ratio", mask),
            *(ctx.mean(key, failed) for key, _ in FLAGS)])
    return table


def terminal_kinds(ctx: Ctx) -> list[str]:
    present = set(ctx.ep.text["failure_kind"])
    kinds = [*FAILURE_KINDS, INFRA_KIND]
    return kinds + sorted(present - set(kinds) - {UNRECORDED_KIND}) + (
        [UNRECORDED_KIND] if UNRECORDED_KIND in present else [])


def terminal_states(ctx: Ctx) -> Table:
    """How episodes ended: shares of the failure kinds (paper Figure 6a)."""
    kinds = terminal_kinds(ctx)
    table = Table(
        "terminal_states", "Terminal-state taxonomy",
        "Share of episodes (%) by outcome: success, or the kind of failure from the terminal "
        "reason (protocol_failure = parse error or invalid action id; budget_exhaustion = "
        "step budget; backend_error = a model call got no answer; empty_plan = DONE with "
        "the goal unmet; all_idle = every robot waited; no_actions = no action was taken; "
        "other = another reason; infra_error = the episode could not run; planner_error = "
        "the strategy's own code ended it (a column only when there are some); unrecorded = "
        "failed without a terminal reason).",
        [*ID_COLUMNS, *(Column(k, k, "pct") for k in kinds)])
    kind = ctx.ep.text["failure_kind"]
    for model, condition, mask in ctx.cells():
        table.rows.append([model, condition, int(mask.sum()),
                           *(ctx.mean_of((kind == k).astype(float), mask) for k in kinds)])
    return table


def legality(ctx: Ctx) -> Table:
    """Success rate against legal-plan rate (paper Figure 6b)."""
    table = Table(
        "legality", "Success vs legal plan",
        "Legal = share of episodes whose plan had no illegal skill and no precondition "
        "violation (episodes without steps have no legality and are left out; n shown). "
        "SR - Legal is a paired difference over the same episodes, in percentage points: "
        "positive means goals reached through illegal plans.",
        [*ID_COLUMNS, Column("sr", "SR", "pct"), Column("legal", "Legal", "pct", show_n=True),
         Column("sr_minus_legal", "SR - Legal", "pct")])
    success, legal = ctx.ep.col("success"), ctx.ep.col("legal")
    for model, condition, mask in ctx.cells():
        episodes = np.flatnonzero(mask)  # each episode paired with itself
        table.rows.append([model, condition, int(mask.sum()), ctx.mean("success", mask),
                           ctx.mean("legal", mask),
                           ctx.diff_of(success, legal, episodes, episodes)])
    return table


COST_COLUMNS = (  # key, header, kind, shown in Markdown (all are in CSV)
    ("elapsed_s", "Time (s)", "num", True),
    ("steps", "Steps", "num", True),
    ("planner_calls", "Planner calls", "num", True),
    ("prompt_tokens", "Prompt tok.", "tokens", False),
    ("completion_tokens", "Completion tok.", "tokens", False),
    ("tokens", "Tokens", "tokens", True),
    ("cost_usd", "Cost ($)", "usd", True),
    ("saved_cost_usd", "Saved ($)", "usd", True),
)


def cost(ctx: Ctx) -> Table:
    """Per-episode compute cost: means with intervals, and totals (supplementary Table 6)."""
    columns = list(ID_COLUMNS)
    for key, head, kind, md in COST_COLUMNS:
        columns += [Column(key, head, kind, markdown=md),
                    Column(f"{key}_total", f"{head} total", kind, estimate=False, markdown=md)]
    table = Table(
        "cost", "Per-episode cost",
        "Means per episode (with intervals) and totals. Time = wall-clock seconds of the "
        "episode; Steps = executed action steps; Planner calls = model calls (the "
        "planner's step counter when usage was not recorded); Tokens = prompt + completion; "
        "Cost = the model client's dollar estimate (0 for offline models). Replies reused "
        "from the response cache or replayed from a recorded run made no model call: they "
        "count 0 tokens and 0 cost, and Saved = what their original calls had cost. The CSV "
        "also splits tokens into prompt and completion.", columns)
    ep = ctx.ep
    tokens = ep.col("prompt_tokens") + ep.col("completion_tokens")
    for model, condition, mask in ctx.cells():
        row: list = [model, condition, int(mask.sum())]
        for key, *_ in COST_COLUMNS:
            values = tokens if key == "tokens" else ep.col(key)
            row += [ctx.mean_of(values, mask), total(values[mask])]
        table.rows.append(row)
    return table


def construct_correlation(ctx: Ctx) -> Table:
    """Pearson correlations of the four cross-applied construct scores (paper Figure 2)."""
    table = Table(
        "construct_correlation", "Construct correlations",
        "Pearson r between the cross-applied construct scores C_D1..C_D4 (every scorer "
        "applied to every trajectory), over the episodes where both scores are scored "
        "(n = such episodes), pooled over conditions; (all) pools every model. NA: fewer "
        "than 3 pairs or a constant score.",
        [Column("model", "Model"), Column("construct", "Construct"),
         *(Column(d.lower(), d, "score", show_n=True) for d in DIMENSIONS)])
    blocks = [*ctx.data.models, *([POOLED] if len(ctx.data.models) > 1 else [])]
    scores = [ctx.ep.col(f"cross_{d}") for d in DIMENSIONS]
    for block in blocks:
        mask = ctx.ep.mask(model=None if block == POOLED else block)
        if not mask.any():
            continue
        matrix = correlation_matrix([s[mask] for s in scores], ctx.boot, ctx.instances[mask])
        for d, row in zip(DIMENSIONS, matrix):
            table.rows.append([block, d, *row])
    return table



"""`cocobench run --dry-run`: the estimate as a table, with its counters and the limit."""

from __future__ import annotations

from cocobench_agents.cli.tables import table
from cocobench_agents.engine.costs import CostPlan, CostRange
from cocobench_agents.engine.power import Power


def dry_run_table(plan: CostPlan) -> str:
    """The rows, the total, which token counter each model's prompts were counted with, and
    the comparison with --max-cost."""
    arms = any(row.arm for row in plan.rows)
    headers = ("model", "condition", *(("arm",) if arms else ()), "episodes", "max calls",
               "first-prompt tokens", "cost USD (low – high)")
    rows = [[row.model, row.condition, *((row.arm,) if arms else ()), row.episodes,
             f"{row.max_calls:,}{'*' if row.assumed else ''}", f"{row.prompt_tokens:,}",
             _cost(row.cost_usd)] for row in plan.rows]
    total = plan.total
    rows.append(["total", "", *(("",) if arms else ()), total.episodes,
                 f"{total.max_calls:,}", f"{total.prompt_tokens:,}", _cost(total.cost_usd)])
    notes = [f"tokens of {model}: {counter}" for model, counter in plan.token_counters.items()]
    if any(row.assumed for row in plan.rows):
        notes.append("* a planner of your own: one call per agent per step assumed")
    notes.append(_limit_line(plan))
    if plan.power is not None:
        notes += power_lines(plan.power)
    notes.append("Nothing was called or written (docs/dry-run.md explains each column).")
    return table(headers, rows, caption="\n".join(notes))


def power_lines(power: Power) -> list[str]:
    """The smallest paired SR difference the run detects, where its variance comes from, and
    what --detect needs."""
    if power.mdd is None:
        return ["power: no instances planned"]
    epochs = f"{power.epochs} epoch{'s' if power.epochs != 1 else ''}"
    lines = [f"power: the smallest paired SR difference between two arms (or models) this run "
             f"detects in a condition is {100 * power.mdd:.1f} points ({power.power:.0%} "
             f"power, two-sided α = {power.alpha:g}; {power.instances:,} instances × "
             f"{epochs}); {power.variance.source}"]
    if power.detect is not None:
        wanted = f"--detect {power.detect:g} ({100 * power.detect:.1f} points)"
        at_epochs = (f"{power.instances_needed:,} instance"
                     f"{'s' if power.instances_needed != 1 else ''} at {epochs}")
        if power.epochs_needed is None:
            lines.append(f"{wanted}: no number of epochs at {power.instances:,} instances "
                         f"(the difference varies between instances); {at_epochs}")
        else:
            lines.append(f"{wanted}: {power.epochs_needed:,} epoch"
                         f"{'s' if power.epochs_needed != 1 else ''} at {power.instances:,} "
                         f"instances, or {at_epochs}")
    return lines


def _cost(cost: CostRange) -> str:
    if not cost.known:
        return "unknown (no price)"
    return f"${cost.low:,.4f} – ${cost.high:,.4f}"


def _limit_line(plan: CostPlan) -> str:
    if plan.max_cost_usd is None:
        return "no --max-cost set"
    limit = f"--max-cost ${plan.max_cost_usd:,.2f}"
    if plan.high_exceeds_max_cost is None:
        return f"{limit}: unknown (a model has no price; --max-total-tokens bounds it)"
    if plan.low_exceeds_max_cost:
        return f"{limit}: even the low estimate exceeds it; the run would stop early"
    if plan.high_exceeds_max_cost:
        return f"{limit}: between the low and the high estimate; the run may stop early"
    return f"{limit}: the whole run fits under it"

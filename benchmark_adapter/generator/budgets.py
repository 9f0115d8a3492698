"""Step budgets from the oracle's length, in the proportions of the released configs.

`difficulty.step_budget` (the budget the runner uses) is the oracle length times a per-cell
ratio: the median of `step_budget / oracle_steps` over the released configs of that cell
(the 36 configs in `cocobench-data/tasks`), rounded to two figures, e.g. K_D3 24/19, 36/28,
38/30, 48/37 -> 1.28. The top-level `step_budget`, which no code reads, follows the reference
generators: round(1.5 × oracle_steps), and 2 × optimal_makespan for K.
"""

from __future__ import annotations

import math

BUDGET_RATIO = {
    "A_D1": 1.5,  # 20/14, 22/14
    "G_D1": 2.25,  # 20/9, 30/13, 40/17, 24/17
    "H_D1": 1.65,  # 24/13, 28/19, 28/19, 48/25
    "A_D2": 2.2,  # 24/17, 50/17
    "C_D2": 2.2,  # 50/17, 48/23, 34/23, 64/29, 64/29
    "H_D2": 2.2,  # 48/23, 64/29, 64/29, 50/17
    "K_D3": 1.28,  # 24/19, 36/28, 38/30, 48/37
    "C_D4": 1.35,  # 60/53, 60/49, 66/49, 72/49, 96/65
    "J_D4": 1.35,  # 60/49, 66/49, 66/49, 88/65, 96/65
}


def oracle_steps(calls: int) -> int:
    """`difficulty.oracle_steps`: the plan's calls plus the terminal step, as the reference
    records it."""
    return calls + 1


def step_budget(cell: str, steps: int) -> int:
    """`difficulty.step_budget` for an instance whose oracle takes `steps` steps."""
    return math.ceil(BUDGET_RATIO[cell] * steps - 1e-9)


def legacy_step_budget(steps: int, k_makespan: int | None = None) -> int:
    """The top-level `step_budget` field (unused by any runner; kept for schema parity)."""
    return 2 * k_makespan if k_makespan is not None else round(1.5 * steps)

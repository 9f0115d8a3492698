"""The power of a planned run: the smallest success-rate difference it can detect, before
anything is spent (`plan(request, power_baseline=..., detect=...)`, `run --dry-run`).

The comparison is paired: two arms (prompt suites, planners, or models) on the same instances,
each instance run `epochs` times. With d_i the difference of the two arms' success rates on
instance i, the mean difference over I instances has variance V(E) / I, where

    V(E) = B + W / E

B is the variance between instances of the true per-instance difference (what more epochs
cannot remove) and W = 2 σ²_w the variance of a difference of two single episodes of one
instance (σ²_w: how much an instance's outcome varies between epochs). The minimum detectable
difference at two-sided level α with power 1 − β (normal approximation) is

    MDD = (z_{1−α/2} + z_{1−β}) · sqrt(V(E) / I)

B and σ²_w come from an earlier run (`--power-baseline RUN`), else from a prior: every episode
succeeds with probability 1/2 independently (σ²_w = 1/4, the largest a 0/1 outcome has; B = 0).
See docs/statistics.md for how a baseline run's B and σ²_w are estimated.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist
from typing import Any

from cocobench_agents.engine.errors import RequestError
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import RESULTS, RunFolder

ALPHA = 0.05
POWER = 0.80
PRIOR = ("prior: each episode succeeds with probability 1/2, independently (the largest "
         "variance a success can have; it assumes epochs are independent: for a model whose "
         "instances succeed or fail every time, give --power-baseline RUN)")


def z_sum(alpha: float = ALPHA, power: float = POWER) -> float:
    """z_{1−α/2} + z_{power}: 1.96 + 0.84 = 2.80 at the defaults."""
    normal = NormalDist()
    return normal.inv_cdf(1 - alpha / 2) + normal.inv_cdf(power)


@dataclass(frozen=True)
class Variance:
    """The variance of a paired per-instance difference: V(E) = between + within / E."""

    between: float  # B
    within: float  # W = 2 σ²_w
    source: str  # where the numbers come from, for people

    def at(self, epochs: int) -> float:
        return self.between + self.within / epochs


PRIOR_VARIANCE = Variance(0.0, 2 * 0.25, PRIOR)


@dataclass(frozen=True)
class Power:
    """What a planned run can detect, per condition, between two arms."""

    instances: int
    epochs: int
    variance: Variance
    mdd: float | None  # the minimum detectable SR difference (0-1); None without instances
    alpha: float = ALPHA
    power: float = POWER
    detect: float | None = None  # the difference asked for (--detect)
    epochs_needed: int | None = None  # at the planned instances; None: no number of epochs
    instances_needed: int | None = None  # at the planned epochs

    def to_json(self) -> dict[str, Any]:
        return {"instances": self.instances, "epochs": self.epochs, "mdd": self.mdd,
                "alpha": self.alpha, "power": self.power,
                "variance": {"between": self.variance.between, "within": self.variance.within,
                             "source": self.variance.source},
                "detect": self.detect, "epochs_needed": self.epochs_needed,
                "instances_needed": self.instances_needed}


def power_of(instances: int, epochs: int, variance: Variance = PRIOR_VARIANCE, *,
             detect: float | None = None, alpha: float = ALPHA, power: float = POWER) -> Power:
    """The minimum detectable difference of a paired comparison on `instances` × `epochs`,
    and, given `detect`, the epochs (at these instances) and instances (at these epochs)
    that detect it."""
    if detect is not None and not 0.0 < detect <= 1.0:
        raise RequestError(f"--detect {detect}: a success-rate difference between 0 and 1 "
                           "(0.05 = 5 points)")
    z = z_sum(alpha, power)
    mdd = z * math.sqrt(variance.at(epochs) / instances) if instances else None
    epochs_needed = instances_needed = None
    if detect is not None:
        instances_needed = max(1, math.ceil(z * z * variance.at(epochs) / detect ** 2))
        if instances:
            budget = detect ** 2 * instances / (z * z)  # the largest V(E) that detects it
            if variance.between < budget:
                epochs_needed = max(1, math.ceil(variance.within / (budget - variance.between)
                                                 - 1e-9))
    return Power(instances, epochs, variance, mdd, alpha, power, detect, epochs_needed,
                 instances_needed)


def baseline_variance(run: str | Path) -> Variance:
    """B and W estimated from an earlier run's results (see docs/statistics.md)."""
    path = Path(run)
    if not (path / RESULTS).is_file():
        raise RequestError(f"--power-baseline {path}: not a run folder with results "
                           f"(no {RESULTS})")
    try:
        rows = [row for row in RunFolder(path).scan_results().latest.values()
                if isinstance(row.get("task_success"), (int, float))]
    except RunFolderError as exc:
        raise RequestError(f"--power-baseline {path}: {exc}") from None
    if not rows:
        raise RequestError(f"--power-baseline {path}: no results with a task_success")
    return variance_from_results(rows, str(path))


def variance_from_results(rows: Iterable[Mapping[str, Any]], name: str) -> Variance:
    """B and W from result lines: σ²_w pooled over instances run at least twice; B from the
    spread of per-instance differences between two rows (model or arm) of one condition,
    less their epoch noise, else (one row) 2 σ²_b, as if the arms were uncorrelated."""
    cells: dict[tuple[str, str], dict[str, list[float]]] = {}
    for row in rows:
        cell = cells.setdefault((str(row.get("condition")), _row_label(row)), {})
        cell.setdefault(str(row.get("task_id")), []).append(float(bool(row["task_success"])))
    repeated = [(sum(v), len(v)) for tasks in cells.values() for v in tasks.values()
                if len(v) >= 2]
    sigma_w = (sum(c * (n - c) / (n * (n - 1)) for c, n in repeated) / len(repeated)
               if repeated else None)
    pair_between = _pair_between(cells, sigma_w or 0.0)
    if pair_between is not None:
        between, how = pair_between, "the spread of per-instance differences between its rows"
    else:
        outcomes = [x for tasks in cells.values() for v in tasks.values() for x in v]
        p = sum(outcomes) / len(outcomes)
        between = 2 * max(0.0, p * (1 - p) - (sigma_w or 0.0))
        how = f"its success rate {p:.1%}, the arms assumed uncorrelated"
    epochs = (f"between-epoch variance {sigma_w:.3f} over {len(repeated)} repeated instances"
              if sigma_w is not None else
              "one epoch, so every difference is taken to lie between instances (more epochs "
              "assumed not to help)")
    return Variance(between, 2 * (sigma_w or 0.0), f"observed in {name}: {epochs}; "
                                                      f"between instances from {how}")


def _row_label(row: Mapping[str, Any]) -> str:
    return f"{row.get('model')} @{row['arm']}" if row.get("arm") else str(row.get("model"))


def _pair_between(cells: Mapping[tuple[str, str], Mapping[str, list[float]]],
                  sigma_w: float) -> float | None:
    """The mean over pairs of rows in one condition of Var_i(d_i) − σ²_w (1/n_a + 1/n_b)
    (floored at 0): the between-instance variance of their difference. None without a pair
    sharing three instances."""
    by_condition: dict[str, list[Mapping[str, list[float]]]] = {}
    for (condition, _), tasks in cells.items():
        by_condition.setdefault(condition, []).append(tasks)
    estimates = []
    for rows in by_condition.values():
        for i, a in enumerate(rows):
            for b in rows[i + 1:]:
                shared = [t for t in a if t in b]
                if len(shared) < 3:
                    continue
                d = [sum(a[t]) / len(a[t]) - sum(b[t]) / len(b[t]) for t in shared]
                mean = sum(d) / len(d)
                spread = sum((x - mean) ** 2 for x in d) / (len(d) - 1)
                noise = sum(sigma_w * (1 / len(a[t]) + 1 / len(b[t])) for t in shared)
                estimates.append(max(0.0, spread - noise / len(shared)))
    return sum(estimates) / len(estimates) if estimates else None

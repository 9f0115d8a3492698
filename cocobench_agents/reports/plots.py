"""PNG figures drawn from the report's tables (matplotlib, imported only here).

Figures are drawn on `matplotlib.figure.Figure` objects (no pyplot state, Agg rendering), under
matplotlib's default style (a user's matplotlibrc cannot change them), at a fixed size and DPI,
with no software or date metadata: the same tables give the same bytes with the same
matplotlib version.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from cocobench_agents.reports import paired, reliability
from cocobench_agents.reports.load import DIMENSIONS
from cocobench_agents.reports.render import PlotEntry
from cocobench_agents.reports.result_tables import GROUPS, group_prefix
from cocobench_agents.reports.stats import Estimate
from cocobench_agents.reports.table import Table

DPI = 120
GROUP_LABELS = ("Overall", *DIMENSIONS)  # the labels of result_tables.GROUPS
INSTALL_HINT = ("matplotlib is not installed, so no plots were written: "
                "pip install matplotlib")
METADATA = {"Software": None}


class PlotsUnavailable(RuntimeError):
    """matplotlib cannot be imported."""


def _matplotlib() -> Any:
    try:
        import matplotlib
        import matplotlib.style
        from matplotlib.figure import Figure  # noqa: F401 - checks the install is usable
    except ImportError as exc:
        raise PlotsUnavailable(INSTALL_HINT) from exc
    return matplotlib


def _value(est: Any, scale: float = 1.0) -> tuple[float, float, float]:
    """(value, minus, plus) for an error bar; NaN for NA."""
    if not isinstance(est, Estimate) or est.na:
        return math.nan, 0.0, 0.0
    v = est.value * scale
    return v, v - est.lo * scale, est.hi * scale - v


def _bars(ax: Any, labels: Sequence[str], series: Sequence[tuple[str, Sequence[Any]]],
          scale: float, ylabel: str) -> None:
    """Grouped bars with CI error bars: one group per label, one bar per series."""
    count = max(1, len(series))
    width = 0.8 / count
    colors = _colors(count)
    err_x, err_y, err_lo, err_hi = [], [], [], []
    for k, (name, cells) in enumerate(series):
        vals = [_value(c, scale) for c in cells]
        xs = [i - 0.4 + width * (k + 0.5) for i in range(len(labels))]
        ax.bar(xs, [v[0] for v in vals], width, label=name, color=colors[k])
        for x, (v, minus, plus) in zip(xs, vals):
            if not math.isnan(v):
                err_x.append(x)
                err_y.append(v)
                err_lo.append(minus)
                err_hi.append(plus)
    if err_x:  # one call for all error bars: much faster to draw than one per series
        ax.errorbar(err_x, err_y, yerr=[err_lo, err_hi], fmt="none", ecolor="black",
                    elinewidth=0.8, capsize=min(2.0, 60.0 / max(1, len(err_x))))
    ax.set_xticks(range(len(labels)))
    ax.set_xticklabels(labels)
    ax.set_ylabel(ylabel)
    ax.axhline(0.0, color="black", linewidth=0.6)
    ax.grid(axis="y", alpha=0.3)


def _colors(count: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10" if count <= 10 else "tab20"]
    return [cmap(i % cmap.N) for i in range(count)]


def _figure(width: float, height: float, ncols: int = 1) -> tuple[Any, list[Any]]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI)
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    return fig, list(axes)


def _legend(fig: Any, axes: list[Any], count: int) -> None:
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=min(count, 4), fontsize=8,
                   frameon=False)
        fig.subplots_adjust(bottom=0.12 + 0.05 * math.ceil(count / 4), wspace=0.3)


def _save(fig: Any, path: Path) -> None:
    fig.savefig(path, dpi=DPI, format="png", metadata=METADATA)


def _sr_cs_figure(path: Path, title: str, series: list[tuple[str, dict[str, Any]]],
                  delta: bool) -> None:
    fig, axes = _figure(min(24.0, 9.0 + 0.4 * len(series)), 4.2, 2)
    for ax, metric, (ylabel, scale) in zip(
            axes, ("sr", "cs"), ((("SR change (pp)" if delta else "SR (%)"), 100.0),
                                 (("CS change" if delta else "CS"), 1.0))):
        _bars(ax, GROUP_LABELS,
              [(name, [rec.get(f"{group_prefix(g)[0]}{metric}") for g in GROUPS])
               for name, rec in series], scale, ylabel)
        if not delta:
            ax.set_ylim(0, 105 if metric == "sr" else 1.05)
    fig.suptitle(title)
    _legend(fig, axes, len(series))
    _save(fig, path)


def by_dimension(tables: dict[str, Table], path: Path, condition: str) -> bool:
    rows = [r for r in tables["main_results"].records() if r["condition"] == condition]
    if not rows:
        return False
    _sr_cs_figure(path, f"SR and CS by dimension ({condition})",
                  [(r["model"], r) for r in rows], delta=False)
    return True


def architecture_deltas(tables: dict[str, Table], path: Path, condition: str) -> bool:
    rows = [r for r in tables["architecture"].records() if " - " in r["arch"]]
    if not rows:
        return False
    _sr_cs_figure(path, "Change relative to C0 (paired, pooled over observation modes)",
                  [(f"{r['model']} {r['arch']}", r) for r in rows], delta=True)
    return True


def observation(tables: dict[str, Table], path: Path, condition: str) -> bool:
    rows = [r for r in tables["observation"].records() if " - " not in r["obs"]]
    if len({r["obs"] for r in rows}) < 2:
        return False
    _sr_cs_figure(path, "Image vs blind (pooled over architectures)",
                  [(f"{r['model']} {r['obs']}", r) for r in rows], delta=False)
    return True


def _arms(metric: str, ylabel: str, scale: float, top: float
          ) -> Callable[[dict[str, Table], Path, str], bool]:
    """A figure of one metric for every arm of every model and condition of the arms table,
    arms side by side with their intervals (all conditions: arms are compared in each)."""

    def draw(tables: dict[str, Table], path: Path, condition: str) -> bool:
        table = tables.get(paired.NAME)
        rows = [r for r in table.records() if not r["baseline"]] if table else []
        if not rows:
            return False
        groups = list(dict.fromkeys((r["model"], r["condition"]) for r in rows))
        arms = list(dict.fromkeys(r["arm"] for r in rows))
        cell = {(r["model"], r["condition"], r["arm"]): r[metric] for r in rows}
        fig, axes = _figure(min(24.0, 4.0 + 0.5 * len(groups) * len(arms)), 4.6)
        _bars(axes[0], [f"{m}\n{c}" for m, c in groups],
              [(arm, [cell.get((m, c, arm)) for m, c in groups]) for arm in arms],
              scale, ylabel)
        axes[0].set_ylim(0, top)
        axes[0].set_title(f"{ylabel} per arm (bootstrap intervals)")
        _legend(fig, axes, len(arms))
        _save(fig, path)
        return True

    return draw


def team_size(tables: dict[str, Table], path: Path, condition: str) -> bool:
    table = tables["team_size"]
    rows = [r for r in table.records() if r["condition"] == condition]
    sizes = [int(c.key[3:]) for c in table.columns if c.key.startswith("sr_")]
    if not rows:
        return False
    fig, axes = _figure(10, 4.2, 2)
    colors = _colors(len(rows))
    for ax, metric, ylabel, scale in ((axes[0], "sr", "SR (%)", 100.0),
                                      (axes[1], "cs", "CS", 1.0)):
        for color, r in zip(colors, rows):
            vals = [_value(r.get(f"{metric}_{k}"), scale) for k in sizes]
            ax.errorbar(sizes, [v[0] for v in vals], yerr=[[v[1] for v in vals],
                                                           [v[2] for v in vals]],
                        marker="o", capsize=3, label=r["model"], color=color)
        ax.set_xticks(sizes)
        ax.set_xlabel("agents")
        ax.set_ylabel(ylabel)
        ax.set_ylim(0, 105 if metric == "sr" else 1.05)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Team size ({condition})")
    _legend(fig, axes, len(rows))
    _save(fig, path)
    return True


def pass_hat_k(tables: dict[str, Table], path: Path, condition: str) -> bool:
    """pass^k against k, one line per model, for the shown condition (runs with epochs)."""
    table = tables.get(reliability.NAME)
    rows = [r for r in table.records() if r["condition"] == condition] if table else []
    ks = [int(c.key.rpartition("_")[2]) for c in table.columns
          if c.key.startswith("pass_hat_")] if table else []
    if not rows or len(ks) < 2:
        return False
    fig, axes = _figure(min(24.0, 4.0 + 2.5 * min(4, len(rows))), 4.6)
    ax = axes[0]
    for color, r in zip(_colors(len(rows)), rows):
        vals = [_value(r.get(f"pass_hat_{k}"), 100.0) for k in ks]
        ax.errorbar(ks, [v[0] for v in vals], yerr=[[v[1] for v in vals], [v[2] for v in vals]],
                    marker="o", capsize=3, label=r["model"], color=color)
    ax.set_xticks(ks)
    ax.set_xlabel("k (trials that must all succeed)")
    ax.set_ylabel("pass^k (%)")
    ax.set_ylim(0, 105)
    ax.grid(alpha=0.3)
    ax.set_title(f"pass^k ({condition})")
    _legend(fig, axes, len(rows))
    _save(fig, path)
    return True


def failure_modes(tables: dict[str, Table], path: Path, condition: str) -> bool:
    table = tables["terminal_states"]
    rows = [r for r in table.records() if r["condition"] == condition]
    kinds = [c.key for c in table.columns if c.has_ci
             and any(_value(r.get(c.key))[0] > 0 for r in rows)]
    if not rows:
        return False
    fig, axes = _figure(9, 1.6 + 0.45 * len(rows))
    ax = axes[0]
    left = [0.0] * len(rows)
    for color, kind in zip(_colors(len(kinds)), kinds):
        widths = [(_value(r.get(kind), 100.0)[0]) for r in rows]
        widths = [0.0 if math.isnan(w) else w for w in widths]
        ax.barh(range(len(rows)), widths, left=left, color=color, label=kind)
        left = [a + b for a, b in zip(left, widths)]
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([r["model"] for r in rows])
    ax.invert_yaxis()
    ax.set_xlim(0, 100)
    ax.set_xlabel("share of episodes (%)")
    ax.set_title(f"Terminal states ({condition})")
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    fig.subplots_adjust(left=0.2, right=0.75)
    _save(fig, path)
    return True


def legality(tables: dict[str, Table], path: Path, condition: str) -> bool:
    rows = [r for r in tables["legality"].records() if r["condition"] == condition]
    if not rows:
        return False
    fig, axes = _figure(max(5.0, 1.2 * len(rows) + 2), 4.2)
    _bars(axes[0], [r["model"] for r in rows],
          [("SR", [r["sr"] for r in rows]), ("Legal plan", [r["legal"] for r in rows])],
          100.0, "rate (%)")
    axes[0].set_ylim(0, 105)
    axes[0].legend(fontsize=8)
    axes[0].set_title(f"Success vs legal plan ({condition})")
    _save(fig, path)
    return True


def correlation(tables: dict[str, Table], path: Path, condition: str) -> bool:
    table = tables["construct_correlation"]
    blocks = list(dict.fromkeys(r["model"] for r in table.records()))
    if not blocks:
        return False
    ncols = min(3, len(blocks))
    nrows = math.ceil(len(blocks) / ncols)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0 * ncols + 0.8, 3.6 * nrows), dpi=DPI)
    grid = fig.subplots(nrows, ncols, squeeze=False)
    image = None
    annotate = len(blocks) <= 6  # the values are in the table; many labels are slow to draw
    for index, block in enumerate(blocks):
        ax = grid[index // ncols][index % ncols]
        rows = [r for r in table.records() if r["model"] == block]
        matrix = [[_value(r.get(d.lower()))[0] for d in DIMENSIONS] for r in rows]
        image = ax.imshow(matrix, vmin=-1, vmax=1, cmap="RdBu_r")
        for i, r in enumerate(rows if annotate else []):
            for j, d in enumerate(DIMENSIONS):
                est = r.get(d.lower())
                if est is None or est.na:
                    ax.text(j, i, "NA", ha="center", va="center", fontsize=7, color="grey")
                    continue
                ax.text(j, i, f"{est.value:.2f}\nn={est.n}", ha="center", va="center",
                        fontsize=7, color="white" if abs(est.value) > 0.6 else "black")
        ax.set_xticks(range(len(DIMENSIONS)))
        ax.set_xticklabels(DIMENSIONS)
        ax.set_yticks(range(len(DIMENSIONS)))
        ax.set_yticklabels(DIMENSIONS)
        ax.set_title(block, fontsize=9)
    for index in range(len(blocks), nrows * ncols):
        grid[index // ncols][index % ncols].set_visible(False)
    if image is not None:
        fig.colorbar(image, ax=grid.ravel().tolist(), shrink=0.8, label="Pearson r")
    fig.suptitle("Cross-applied construct score correlations")
    _save(fig, path)
    return True


PLOTS: tuple[tuple[str, str, Callable[[dict[str, Table], Path, str], bool]], ...] = (
    ("fig_by_dimension.png", "SR and CS by dimension", by_dimension),
    ("fig_architecture.png", "Architecture deltas vs C0", architecture_deltas),
    ("fig_observation.png", "Image vs blind", observation),
    ("fig_team_size.png", "Team-size curves", team_size),
    ("fig_failure_modes.png", "Terminal-state taxonomy", failure_modes),
    ("fig_legality.png", "Success vs legal plan", legality),
    ("fig_correlation.png", "Construct correlation heatmap", correlation),
)
#: One figure per metric of the arms table (written when the runs have arms).
ARM_PLOTS: tuple[tuple[str, str, Callable[[dict[str, Table], Path, str], bool]], ...] = (
    ("fig_arms_sr.png", "Success rate per arm", _arms("sr", "SR (%)", 100.0, 105.0)),
    ("fig_arms_cs.png", "Construct score per arm", _arms("cs", "CS", 1.0, 1.05)),
)

#: Figures of runs with repeated epochs (written when the report has a reliability table).
EPOCH_PLOTS: tuple[tuple[str, str, Callable[[dict[str, Table], Path, str], bool]], ...] = (
    ("fig_pass_hat_k.png", "pass^k against k", pass_hat_k),
)


def write_plots(tables: Sequence[Table], out: Path, condition: str) -> list[PlotEntry]:
    """Draw every figure that has data into `out`; raises PlotsUnavailable without
    matplotlib. `condition` is the one the per-condition figures show."""
    matplotlib = _matplotlib()
    by_name = {t.name: t for t in tables}
    written = []
    with matplotlib.style.context("default"), matplotlib.rc_context(
            {"svg.hashsalt": "cocobench", "figure.max_open_warning": 0}):
        for file, title, draw in (*PLOTS, *EPOCH_PLOTS, *ARM_PLOTS):
            if draw(by_name, out / file, condition):
                written.append(PlotEntry(file, title))
    return written

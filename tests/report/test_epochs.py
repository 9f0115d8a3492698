"""Reports of runs with repeated epochs: clustered intervals in every table (and saying so),
reliability.{md,csv} (pass^k, pass@k, consistency, variance share), and compare.{md,csv}
(paired model differences, wins/losses/ties, McNemar's exact p)."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from cocobench_agents.cli.report_cmd import report_command
from cocobench_agents.reports import Bootstrap, build_report, compute_tables, load_runs
from cocobench_agents.reports.build import CLUSTERED_NOTE

from .helpers import CONSISTENT, FLIPPING, RUN_ORACLE, RUN_ORACLE_SHORT, synthetic_run


def _csv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))


@pytest.fixture(scope="module")
def epochs_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("epochs")
    run = synthetic_run(root / "run", {"a": CONSISTENT, "b": FLIPPING})
    build_report([run], root / "report", plots=False, boot=Bootstrap(resamples=500))
    return root / "report"


def test_reliability_has_the_known_pass_k(epochs_report: Path) -> None:
    rows = {r["model"]: r for r in _csv(epochs_report / "reliability.csv")}
    a, b = rows["a"], rows["b"]
    assert (a["instances"], a["epochs"], b["epochs"]) == ("20", "3", "3")
    for k in (1, 2, 3):  # half the instances always succeed, half never
        assert float(a[f"pass_hat_{k}"]) == pytest.approx(50.0)
        if k > 1:
            assert float(a[f"pass_at_{k}"]) == pytest.approx(50.0)
    assert float(a["consistent"]) == 100.0 and float(a["between_epoch_share"]) == 0.0
    # 1 success in 3 epochs everywhere: pass^1 = 1/3, pass^2 = pass^3 = 0,
    # pass@2 = 1 - C(2,2)/C(3,2) = 2/3, pass@3 = 1
    assert float(b["pass_hat_1"]) == pytest.approx(100 / 3, abs=1e-3)
    assert float(b["pass_hat_2"]) == float(b["pass_hat_3"]) == 0.0
    assert float(b["pass_at_2"]) == pytest.approx(200 / 3, abs=1e-3)
    assert float(b["pass_at_3"]) == 100.0
    assert float(b["consistent"]) == 0.0
    assert float(b["between_epoch_share"]) == 1.0  # the instance says nothing


def test_compare_has_paired_differences_wins_and_mcnemar(epochs_report: Path) -> None:
    (row,) = _csv(epochs_report / "compare.csv")
    assert (row["model"], row["baseline"], row["n"], row["instances"]) == ("b", "a", "60", "20")
    assert float(row["sr"]) == pytest.approx(100 * (1 / 3 - 1 / 2), abs=1e-3)
    assert float(row["sr_lo"]) < float(row["sr"]) < float(row["sr_hi"])
    # b is worse on the 10 instances a always solves, better on the 10 it never does
    assert (row["wins"], row["losses"], row["ties"]) == ("10", "10", "0")
    assert float(row["mcnemar_p"]) == 1.0


def test_every_table_says_its_intervals_are_clustered(epochs_report: Path) -> None:
    for md in epochs_report.glob("*.md"):
        text = md.read_text(encoding="utf-8")
        if md.name == "index.md":
            assert "bootstrap over instances" in text and "reliability.md" in text
        else:
            assert CLUSTERED_NOTE in text, md.name


def test_identical_epochs_give_the_one_epoch_interval(tmp_path: Path) -> None:
    """Three copies of every episode hold the information of one: the clustered interval of
    every estimate is about the one-epoch run's (the per-episode one was 1/sqrt(3) of it)."""
    rng = np.random.default_rng(4)
    once = [[bool(ok)] for ok in rng.integers(0, 2, 40)]
    thrice = [row * 3 for row in once]
    boot = Bootstrap(resamples=4000)
    widths = []
    for name, outcomes in (("once", once), ("thrice", thrice)):
        data = load_runs([synthetic_run(tmp_path / name, {"a": outcomes})])
        main = next(t for t in compute_tables(data, boot) if t.name == "main_results")
        sr = main.records()[0]["sr"]
        widths.append(sr.hi - sr.lo)
    assert widths[1] == pytest.approx(widths[0], rel=0.12)


def test_mcnemar_with_one_epoch_matches_a_hand_computed_table(tmp_path: Path) -> None:
    """One epoch, 30 instances: both succeed on 12, a only on 7, b only on 2, neither on 9.
    McNemar's exact p = 2 * P(X <= 2), X ~ Bin(9, 1/2) = 2 * (1 + 9 + 36) / 512."""
    a = [[True]] * 12 + [[True]] * 7 + [[False]] * 2 + [[False]] * 9
    b = [[True]] * 12 + [[False]] * 7 + [[True]] * 2 + [[False]] * 9
    run = synthetic_run(tmp_path / "run", {"a": a, "b": b})
    build_report([run], tmp_path / "rep", plots=False, boot=Bootstrap(resamples=500))
    (row,) = _csv(tmp_path / "rep" / "compare.csv")
    assert (row["wins"], row["losses"], row["ties"]) == ("2", "7", "21")
    assert float(row["mcnemar_p"]) == pytest.approx(92 / 512, abs=1e-6)
    assert float(row["sr"]) == pytest.approx(100 * (14 - 19) / 30, abs=1e-3)
    assert not (tmp_path / "rep" / "reliability.md").exists()  # one epoch: no reliability
    # The reference: the exact two-sided binomial test of 2 wins in 9 discordant pairs
    # (scipy.stats.binomtest(2, 9).pvalue, which is 92/512), summed here by hand.
    exact = min(1.0, 2 * sum(math.comb(9, i) for i in range(3)) / 2**9)
    assert float(row["mcnemar_p"]) == pytest.approx(exact, abs=1e-6)


def test_paired_interval_matches_a_brute_force_cluster_bootstrap(tmp_path: Path) -> None:
    rng = np.random.default_rng(9)
    p = rng.beta(0.5, 0.5, 50)
    a = [[bool(x) for x in rng.random(4) < q] for q in p]
    b = [[bool(x) for x in rng.random(4) < min(1.0, q + 0.1)] for q in p]
    data = load_runs([synthetic_run(tmp_path / "run", {"a": a, "b": b})])
    table = next(t for t in compute_tables(data, Bootstrap(resamples=20000))
                 if t.name == "compare")
    sr = table.records()[0]["sr"]
    diffs = (np.array(b, dtype=float) - np.array(a, dtype=float)).sum(axis=1)
    idx = np.random.default_rng(0).integers(0, 50, size=(20000, 50))
    lo, hi = np.quantile(diffs[idx].sum(axis=1) / 200, [0.025, 0.975])
    assert sr.value == pytest.approx(diffs.sum() / 200)
    assert (sr.lo, sr.hi) == pytest.approx((lo, hi), abs=0.05 * (hi - lo))


def test_a_chosen_baseline_and_an_unknown_one(tmp_path: Path) -> None:
    run = synthetic_run(tmp_path / "run", {"a": CONSISTENT, "b": FLIPPING, "c": FLIPPING})
    result = CliRunner().invoke(report_command, [str(run), "--out", str(tmp_path / "rep"),
                                                 "--no-plots", "--resamples", "100",
                                                 "--baseline", "c"])
    assert result.exit_code == 0, result.output
    rows = _csv(tmp_path / "rep" / "compare.csv")
    assert [(r["model"], r["baseline"]) for r in rows] == [("a", "c"), ("b", "c")]
    assert rows[1]["sr"] == "0.0000" and rows[1]["mcnemar_p"] == ""  # identical: no test
    bad = CliRunner().invoke(report_command, [str(run), "--out", str(tmp_path / "bad"),
                                              "--baseline", "gpt-9"])
    assert bad.exit_code == 2 and "Traceback" not in bad.output
    assert "--baseline gpt-9: no such model" in bad.output and "a, b, c" in bad.output
    assert not (tmp_path / "bad").exists()


def test_pass_k_figure_is_drawn(tmp_path: Path) -> None:
    run = synthetic_run(tmp_path / "run", {"a": CONSISTENT, "b": FLIPPING})
    summary = build_report([run], tmp_path / "rep", boot=Bootstrap(resamples=100))
    assert "fig_pass_hat_k.png" in [p.file for p in summary.plots]
    assert (tmp_path / "rep" / "fig_pass_hat_k.png").stat().st_size > 1000


def test_pass_hat_k_of_uneven_epochs_uses_the_instances_with_k(tmp_path: Path) -> None:
    """An instance that ran fewer than k epochs (a run stopped early) is left out of pass^k
    (its n says so) but counted in pass^1."""
    outcomes = [[True, True, True]] * 3 + [[True]]
    data = load_runs([synthetic_run(tmp_path / "run", {"a": outcomes})])
    table = next(t for t in compute_tables(data, Bootstrap(resamples=100))
                 if t.name == "reliability")
    row = table.records()[0]
    assert (row["pass_hat_1"].n, row["pass_hat_3"].n) == (4, 3)
    assert row["pass_hat_3"].value == 1.0 and not math.isnan(row["pass_hat_1"].value)


def test_runs_given_with_arms_are_compared(tmp_path: Path) -> None:
    """The oracle cut short (1 of 4) against the full oracle (4 of 4), as --arms runs:
    3 losses, 1 tie, McNemar's exact p = 2 * (1/2)^3."""
    build_report([RUN_ORACLE, RUN_ORACLE_SHORT], tmp_path / "rep", plots=False, arms=True,
                 boot=Bootstrap(resamples=200))
    (row,) = _csv(tmp_path / "rep" / "compare.csv")
    assert (row["model"], row["baseline"]) == (f"oracle @{RUN_ORACLE_SHORT}",
                                               f"oracle @{RUN_ORACLE}")
    assert (row["wins"], row["losses"], row["ties"], row["sr"]) == ("0", "3", "1", "-75.0000")
    assert float(row["mcnemar_p"]) == 0.25

"""The dry run's power: the smallest paired SR difference a planned run detects, from a prior
or an earlier run's variances, and the epochs or instances that detect a given difference."""

from __future__ import annotations

import json
import math
from pathlib import Path
from statistics import NormalDist

import pytest

from cocobench_agents.cli import main
from cocobench_agents.engine.dry_run import plan
from cocobench_agents.engine.errors import RequestError
from cocobench_agents.engine.power import (
    PRIOR_VARIANCE,
    Variance,
    baseline_variance,
    power_of,
    variance_from_results,
)
from cocobench_agents.engine.request import RunRequest
from tests.report.helpers import CONSISTENT, FLIPPING, synthetic_run

Z = NormalDist().inv_cdf(0.975) + NormalDist().inv_cdf(0.80)  # 1.960 + 0.842


def demo_request(out: Path, epochs: int = 1) -> RunRequest:
    return RunRequest(out=out, models=["greedy"], selection={"sources": ["demo"]},
                      epochs=epochs)


def test_planned_run_mdd_is_the_normal_approximation(tmp_path: Path) -> None:
    """The demo suite's 4 instances, one epoch, the prior (p = 1/2, independent):
    MDD = (z_.975 + z_.8) * sqrt(2 * 0.25 / 4)."""
    power = plan(demo_request(tmp_path / "run")).power
    assert (power.instances, power.epochs) == (4, 1)
    assert power.mdd == pytest.approx(Z * math.sqrt(0.5 / 4))
    assert not (tmp_path / "run").exists()  # a dry run writes nothing


def test_doubling_epochs_with_independent_outcomes_shrinks_the_mdd_by_sqrt2(
        tmp_path: Path) -> None:
    two, four = (plan(demo_request(tmp_path / "run", e)).power.mdd for e in (2, 4))
    assert two / four == pytest.approx(math.sqrt(2))


def test_detect_gives_the_fewest_epochs_and_instances_that_reach_it() -> None:
    power = power_of(240, 1, detect=0.05)
    assert power.mdd == pytest.approx(Z * math.sqrt(0.5 / 240))  # 12.8 points
    e, i = power.epochs_needed, power.instances_needed
    assert power_of(240, e).mdd <= 0.05 < power_of(240, e - 1).mdd
    assert power_of(i, 1).mdd <= 0.05 < power_of(i - 1, 1).mdd
    assert (e, i) == (math.ceil(Z * Z * 0.5 / (240 * 0.05 ** 2)),
                      math.ceil(Z * Z * 0.5 / 0.05 ** 2))


def test_a_difference_that_varies_between_instances_is_not_bought_with_epochs() -> None:
    variance = Variance(between=0.05, within=0.3, source="test")
    power = power_of(100, 1, variance, detect=0.05)  # B = 0.05 > 0.05² · 100 / z² = 0.032
    assert power.epochs_needed is None and power.instances_needed is not None
    assert power_of(100, 50, variance).mdd > 0.05
    easy = power_of(100, 1, variance, detect=0.1)
    assert easy.epochs_needed is not None and power_of(100, easy.epochs_needed,
                                                       variance).mdd <= 0.1


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.5])
def test_detect_out_of_range_is_refused(bad: float) -> None:
    with pytest.raises(RequestError, match="--detect"):
        power_of(10, 1, detect=bad)


def test_baseline_variances_from_a_run(tmp_path: Path) -> None:
    """a always or never succeeds by instance, b once in 3 epochs everywhere: σ²_w is the mean
    of c(n-c)/(n(n-1)) (0 for a, 1/3 for b's instances: 1/6 pooled); the per-instance
    difference a - b is +2/3 or -1/3, spread 0.2339 (ddof 1), less the epoch noise
    σ²_w (1/3 + 1/3)."""
    run = synthetic_run(tmp_path / "base", {"a": CONSISTENT, "b": FLIPPING})
    variance = baseline_variance(run)
    sigma_w = (0 * 20 + (1 * 2 / 6) * 20) / 40
    spread = 20 * 0.25 / 19  # d is +2/3 on 10 instances, -1/3 on 10: variance 1/4, ddof 1
    assert variance.within == pytest.approx(2 * sigma_w)
    assert variance.between == pytest.approx(spread - sigma_w * 2 / 3)
    assert "repeated instances" in variance.source and str(run) in variance.source


def test_a_deterministic_one_row_baseline_says_epochs_do_not_help(tmp_path: Path) -> None:
    run = synthetic_run(tmp_path / "base", {"a": CONSISTENT})
    variance = baseline_variance(run)
    assert variance.within == 0.0  # every instance gives the same outcome every epoch
    assert variance.between == pytest.approx(2 * 0.25)  # uncorrelated arms, p = 1/2
    assert power_of(20, 1, variance).mdd == power_of(20, 8, variance).mdd


def test_a_one_epoch_baseline_puts_every_difference_between_instances() -> None:
    rows = [{"model": "m", "condition": "C0_image", "task_id": f"t{i}",
             "task_success": i % 4 == 0} for i in range(40)]
    variance = variance_from_results(rows, "runs/x")
    assert variance.within == 0.0 and variance.between == pytest.approx(2 * 0.25 * 0.75)
    assert "one epoch" in variance.source


def test_prior_is_stated() -> None:
    assert "prior" in PRIOR_VARIANCE.source and PRIOR_VARIANCE.at(1) == 0.5


def _cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["run", "--suite", "demo", "--model", "greedy", *args])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_dry_run_prints_the_power_and_what_detect_needs(capsys, tmp_path: Path) -> None:
    base = synthetic_run(tmp_path / "base", {"a": CONSISTENT, "b": FLIPPING})
    code, out, _ = _cli(capsys, "--out", str(tmp_path / "run"), "--dry-run", "--detect",
                        "0.2", "--power-baseline", str(base))
    assert code == 0
    text = " ".join(out.split())  # the caption is wrapped
    assert "the smallest paired SR difference" in text and f"observed in {base}" in text
    assert "--detect 0.2 (20.0 points):" in text
    code, out, _ = _cli(capsys, "--out", str(tmp_path / "run"), "--dry-run", "--json")
    power = json.loads(out)["power"]
    assert power["mdd"] == pytest.approx(Z * math.sqrt(0.5 / 4))
    assert power["variance"]["source"].startswith("prior")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(("args", "said"), [
    (["--dry-run", "--detect", "0"], "--detect"),
    (["--dry-run", "--detect", "2"], "--detect"),
    (["--detect", "0.05"], "go with --dry-run"),
    (["--power-baseline", "somewhere"], "go with --dry-run"),
    (["--dry-run", "--power-baseline", "MISSING"], "not a run folder with results"),
])
def test_bad_power_options_exit_2(capsys, tmp_path: Path, args: list[str], said: str) -> None:
    args = [str(tmp_path / "missing") if a == "MISSING" else a for a in args]
    code, out, err = _cli(capsys, "--out", str(tmp_path / "run"), *args)
    assert code == 2 and said in out + err
    assert not (tmp_path / "run").exists()


def test_a_baseline_without_results_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "base"
    folder.mkdir()
    (folder / "results.jsonl").write_text("not json\n", encoding="utf-8")
    with pytest.raises(RequestError, match="no results"):
        baseline_variance(folder)

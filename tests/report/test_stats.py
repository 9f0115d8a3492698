"""Bootstrap estimates: intervals contain the estimate, degenerate inputs, determinism."""

from __future__ import annotations

import time

import numpy as np
import pytest

from cocobench_agents.reports.stats import (
    Bootstrap,
    correlation_matrix,
    mean_ci,
    paired_diff_ci,
    pearson_ci,
    total,
)

BOOT = Bootstrap()
SAMPLES = {
    "binary": np.random.default_rng(1).integers(0, 2, 37).astype(float),
    "rare_success": np.array([1.0] + [0.0] * 59),
    "few_levels": np.random.default_rng(2).integers(0, 5, 200).astype(float),
    "continuous": np.random.default_rng(3).random(50),
    "skewed": np.array([1e6] + [0.0] * 99),
    "pair": np.array([0.2, 0.9]),
    "paired_diffs": np.random.default_rng(4).integers(-1, 2, 80).astype(float),
}


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_interval_contains_the_point_estimate(name: str) -> None:
    x = SAMPLES[name]
    est = mean_ci(x, BOOT)
    assert est.n == x.size
    assert est.value == pytest.approx(x.mean())
    assert est.lo <= est.value <= est.hi
    assert x.min() <= est.lo and est.hi <= x.max()


@pytest.mark.parametrize("seed", range(5))
def test_interval_contains_the_estimate_for_many_seeds(seed: int) -> None:
    x = np.random.default_rng(seed).random(12) ** 4
    est = mean_ci(x, Bootstrap(seed=seed))
    assert est.lo <= est.value <= est.hi


@pytest.mark.parametrize(("values", "expected"), [
    ([0.0] * 10, 0.0),
    ([1.0] * 10, 1.0),
    ([0.37], 0.37),
])
def test_degenerate_inputs_have_zero_width_intervals(values: list[float],
                                                     expected: float) -> None:
    est = mean_ci(values, BOOT)
    assert (est.value, est.lo, est.hi, est.n) == (expected, expected, expected, len(values))


@pytest.mark.parametrize("values", [[], [None, None], [np.nan]])
def test_no_values_is_na(values: list) -> None:
    est = mean_ci(np.array(values, dtype=float), BOOT)
    assert est.na and est.value is None and est.lo is None and est.hi is None and est.n == 0


def test_missing_values_are_left_out_and_counted() -> None:
    est = mean_ci(np.array([1.0, None, 0.0, np.nan, 1.0], dtype=float), BOOT)
    assert est.n == 3 and est.value == pytest.approx(2 / 3)


def test_same_input_same_interval_whatever_came_before() -> None:
    x = SAMPLES["continuous"]
    first = mean_ci(x, BOOT)
    mean_ci(SAMPLES["binary"], BOOT)  # other estimates in between must not matter
    mean_ci(np.random.default_rng(9).random(777), BOOT)
    assert mean_ci(x, BOOT) == first
    assert mean_ci(x, Bootstrap(seed=BOOT.seed + 1)) != first


def test_known_binary_interval_is_the_binomial_percentile_interval() -> None:
    # 5 successes of 12: the bootstrap distribution of the mean is Binomial(12, 5/12)/12,
    # whose 2.5 and 97.5 percentiles are 2/12 and 8/12.
    est = mean_ci([1.0] * 5 + [0.0] * 7, Bootstrap(resamples=20000))
    assert est.value == pytest.approx(5 / 12)
    assert est.lo == pytest.approx(2 / 12)
    assert est.hi == pytest.approx(8 / 12)


def test_shortcuts_agree_with_an_index_bootstrap() -> None:
    """The binomial/multinomial shortcuts draw from the same distribution as resampling
    indices: their intervals agree with a brute-force index bootstrap."""
    rng = np.random.default_rng(0)
    for x in (SAMPLES["binary"], SAMPLES["few_levels"]):
        brute = x[rng.integers(0, x.size, size=(20000, x.size))].mean(axis=1)
        lo, hi = np.quantile(brute, [0.025, 0.975])
        est = mean_ci(x, Bootstrap(resamples=20000))
        spread = x.std() / np.sqrt(x.size)
        assert est.lo == pytest.approx(lo, abs=0.1 * spread)
        assert est.hi == pytest.approx(hi, abs=0.1 * spread)


def test_width_shrinks_with_more_episodes() -> None:
    small = mean_ci(np.tile([0.0, 1.0], 10), BOOT)
    large = mean_ci(np.tile([0.0, 1.0], 1000), BOOT)
    assert (large.hi - large.lo) < (small.hi - small.lo) / 5


def test_paired_difference() -> None:
    a = np.array([1.0, 1.0, 0.0, np.nan, 1.0])
    b = np.array([0.0, 1.0, 0.0, 1.0, np.nan])
    est = paired_diff_ci(a, b, BOOT)
    assert est.delta and est.n == 3 and est.value == pytest.approx(1 / 3)
    assert est.lo <= est.value <= est.hi
    assert paired_diff_ci([], [], BOOT).na


def test_pearson_matches_numpy_and_contains_the_estimate() -> None:
    rng = np.random.default_rng(5)
    x = rng.random(200)
    y = 0.6 * x + rng.random(200)
    est = pearson_ci(x, y, BOOT)
    assert est.value == pytest.approx(np.corrcoef(x, y)[0, 1])
    assert est.lo <= est.value <= est.hi
    assert est.lo >= -1.0 and est.hi <= 1.0
    assert pearson_ci(x, 2 * x + 1, BOOT).value == pytest.approx(1.0)


def test_pearson_degenerate_cases_are_na() -> None:
    assert pearson_ci([0.1, 0.5], [0.2, 0.4], BOOT).na  # fewer than 3 pairs
    assert pearson_ci([0.1, 0.5, 0.7], [0.3, 0.3, 0.3], BOOT).na  # constant
    est = pearson_ci([0.1, np.nan, 0.7, 0.2], [0.3, 0.5, np.nan, 0.1], BOOT)
    assert est.na and est.n == 2
    assert pearson_ci([], [], BOOT).na


def test_correlation_matrix_pairs_use_their_complete_cases() -> None:
    rng = np.random.default_rng(6)
    a = rng.random(100)
    b = a + 0.3 * rng.random(100)
    c = rng.random(100)
    b[:20] = np.nan
    m = correlation_matrix([a, b, c], BOOT)
    assert m[0][0].value == 1.0 and m[0][0].n == 100
    assert m[0][1] == m[1][0] and m[0][1].n == 80
    keep = ~np.isnan(b)
    assert m[0][1].value == pytest.approx(np.corrcoef(a[keep], b[keep])[0, 1])
    assert m[0][2].n == 100 and m[0][2].lo <= m[0][2].value <= m[0][2].hi
    assert correlation_matrix([a, b, c], BOOT) == m  # deterministic


def test_total() -> None:
    assert total([1.0, np.nan, 2.5]) == 3.5
    assert total([np.nan]) is None


def test_bootstrap_settings_are_checked() -> None:
    with pytest.raises(ValueError):
        Bootstrap(resamples=0)
    with pytest.raises(ValueError):
        Bootstrap(confidence=1.0)
    assert Bootstrap(confidence=0.9).quantiles == pytest.approx((0.05, 0.95))


def test_large_inputs_are_fast() -> None:
    rng = np.random.default_rng(7)
    start = time.perf_counter()
    for _ in range(3):
        mean_ci(rng.random(5000), BOOT)  # 2000 resamples of 5000 values each
        mean_ci(rng.integers(0, 2, 5000).astype(float), BOOT)
    correlation_matrix([rng.random(5000) for _ in range(4)], BOOT)
    assert time.perf_counter() - start < 10.0  # well under a second on an idle core

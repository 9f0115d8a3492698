"""Clustered intervals (all epochs of an instance resampled together) and pass^k / pass@k."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cocobench_agents.reports.stats import (
    Bootstrap,
    cluster_codes,
    cluster_totals,
    correlation_matrix,
    mean_ci,
    paired_diff_ci,
    pass_at_k,
    pass_hat_k,
)

BOOT = Bootstrap()
INSTANCES = 120
#: Per-instance success probabilities: Beta(0.2, 0.3) puts most instances near 0 or 1, so an
#: instance mostly succeeds every time or never (strongly clustered); mean 0.4.
CLUSTERED_MEAN = 0.2 / (0.2 + 0.3)


def _simulate(rng: np.random.Generator, epochs: int, clustered: bool) -> np.ndarray:
    """Outcomes (instances × epochs) with a known mean success probability (0.4)."""
    p = rng.beta(0.2, 0.3, INSTANCES) if clustered else np.full(INSTANCES, 0.4)
    return (rng.random((INSTANCES, epochs)) < p[:, None]).astype(float)


def _coverage(epochs: int, clustered: bool) -> tuple[float, float]:
    """Share of 1,000 simulated datasets whose 95 % interval covers the true mean: the
    clustered interval and the naive one (episodes resampled as if independent)."""
    rng = np.random.default_rng(2024 + epochs + 10 * clustered)
    boot = Bootstrap(resamples=1000)
    ids = np.repeat(np.arange(INSTANCES), epochs)
    truth = CLUSTERED_MEAN if clustered else 0.4
    hits = np.zeros(2)
    for _ in range(1000):
        x = _simulate(rng, epochs, clustered).ravel()
        for i, est in enumerate((mean_ci(x, boot, ids), mean_ci(x, boot))):
            hits[i] += est.lo <= truth <= est.hi
    return hits[0] / 1000, hits[1] / 1000


@pytest.mark.slow
@pytest.mark.parametrize("clustered", [True, False], ids=["clustered", "independent"])
@pytest.mark.parametrize("epochs", [1, 5])
def test_clustered_intervals_cover_the_true_mean(epochs: int, clustered: bool) -> None:
    covered, naive = _coverage(epochs, clustered)
    assert 0.93 <= covered <= 0.97
    if epochs == 5 and clustered:  # the naive interval is about sqrt(5) too narrow
        assert naive < 0.85
    else:  # one epoch (the same interval), or independent epochs: the naive one holds
        assert 0.93 <= naive <= 0.97


def test_one_value_per_cluster_is_the_plain_bootstrap_draw_for_draw() -> None:
    rng = np.random.default_rng(3)
    for x in (rng.integers(0, 2, 50).astype(float), rng.random(40),
              rng.integers(0, 4, 300).astype(float)):
        labels = [f"task{i}" for i in range(x.size)]
        assert mean_ci(x, BOOT, labels) == mean_ci(x, BOOT)
        y = rng.random(x.size)
        assert correlation_matrix([x, y], BOOT, labels) == correlation_matrix([x, y], BOOT)


def test_repeated_epochs_that_agree_do_not_narrow_the_interval() -> None:
    """Five identical epochs hold the information of one: the clustered interval is the
    one-epoch interval (the naive one shrinks by about sqrt(5))."""
    one = np.random.default_rng(5).integers(0, 2, 60).astype(float)
    five = np.repeat(one, 5)
    ids = np.repeat(np.arange(60), 5)
    single, clustered, naive = mean_ci(one, BOOT), mean_ci(five, BOOT, ids), mean_ci(five, BOOT)
    assert clustered.value == single.value
    assert clustered.hi - clustered.lo == pytest.approx(single.hi - single.lo, rel=0.1)
    assert (naive.hi - naive.lo) / (single.hi - single.lo) == pytest.approx(5 ** -0.5,
                                                                            rel=0.15)


def test_clustered_shortcut_agrees_with_a_brute_force_cluster_bootstrap() -> None:
    """The multinomial over (sum, size) pairs draws what resampling cluster indices draws;
    the index path (many distinct pairs) too."""
    rng = np.random.default_rng(11)
    for values in (rng.integers(0, 2, (80, 3)).astype(float), rng.random((80, 3))):
        values[rng.random(values.shape) < 0.1] = np.nan  # missing values: unequal sizes
        sums, sizes = np.nansum(values, axis=1), (~np.isnan(values)).sum(axis=1)
        idx = rng.integers(0, 80, size=(20000, 80))
        brute = sums[idx].sum(axis=1) / sizes[idx].sum(axis=1)
        lo, hi = np.quantile(brute, [0.025, 0.975])
        est = mean_ci(values.ravel(), Bootstrap(resamples=20000), np.repeat(np.arange(80), 3))
        assert est.value == pytest.approx(np.nanmean(values))
        spread = hi - lo
        assert est.lo == pytest.approx(lo, abs=0.05 * spread)
        assert est.hi == pytest.approx(hi, abs=0.05 * spread)


def test_clustered_estimate_is_reproducible_and_labels_any_hashable() -> None:
    x = np.tile([1.0, 0.0, 1.0], 20)
    a = mean_ci(x, BOOT, np.repeat(np.arange(20), 3))
    b = mean_ci(x, BOOT, np.repeat([f"t{i}" for i in range(20)], 3))
    assert a == b and a.n == 60


def test_paired_difference_clusters_pairs() -> None:
    a = np.repeat(np.random.default_rng(2).integers(0, 2, 40).astype(float), 4)
    b = np.zeros(160)
    ids = np.repeat(np.arange(40), 4)
    clustered, naive = paired_diff_ci(a, b, BOOT, ids), paired_diff_ci(a, b, BOOT)
    assert clustered.delta and clustered.value == naive.value == pytest.approx(a.mean())
    assert clustered.hi - clustered.lo > 1.5 * (naive.hi - naive.lo)  # about 2 (sqrt 4)


def test_cluster_codes_and_totals() -> None:
    assert cluster_codes(["b", "a", "b", "c", "a"]).tolist() == [0, 1, 0, 2, 1]
    sums, sizes = cluster_totals([1.0, np.nan, 1.0, 0.0, 0.0], ["b", "a", "b", "c", "a"])
    assert sums.tolist() == [2.0, 0.0, 0.0] and sizes.tolist() == [2.0, 1.0, 1.0]
    assert cluster_totals([np.nan], ["a"])[0].size == 0


@pytest.mark.parametrize(("successes", "trials", "k", "expected"), [
    ([5, 5], [5, 5], 3, [1.0, 1.0]),  # every trial succeeds
    ([0, 0], [5, 5], 1, [0.0, 0.0]),  # never
    ([4, 0], [4, 4], 4, [1.0, 0.0]),  # half the instances always, half never
    ([2], [4], 1, [0.5]),
    ([2], [4], 2, [1 / 6]),  # C(2,2)/C(4,2)
    ([3], [5], 2, [math.comb(3, 2) / math.comb(5, 2)]),
])
def test_pass_hat_k_known_values(successes: list[int], trials: list[int], k: int,
                                 expected: list[float]) -> None:
    assert pass_hat_k(successes, trials, k) == pytest.approx(expected)


def test_pass_hat_k_and_pass_at_k_match_the_binomial_formulas() -> None:
    for n in range(1, 8):
        for c in range(n + 1):
            for k in range(1, n + 1):
                assert pass_hat_k([c], [n], k)[0] == pytest.approx(
                    math.comb(c, k) / math.comb(n, k))
                assert pass_at_k([c], [n], k)[0] == pytest.approx(
                    1 - math.comb(n - c, k) / math.comb(n, k))


def test_pass_hat_k_is_unbiased_for_p_to_the_k() -> None:
    """E[C(c,k)/C(n,k)] = p^k when c ~ Binomial(n, p): the estimator averaged over the
    binomial distribution equals p^k exactly."""
    n, p = 6, 0.7
    for k in range(1, n + 1):
        c = np.arange(n + 1)
        weights = np.array([math.comb(n, i) * p ** i * (1 - p) ** (n - i) for i in c])
        assert weights @ pass_hat_k(c, np.full(n + 1, n), k) == pytest.approx(p ** k)
        assert weights @ pass_at_k(c, np.full(n + 1, n), k) == pytest.approx(1 - (1 - p) ** k)


def test_pass_hat_k_needs_k_trials_and_sane_counts() -> None:
    assert np.isnan(pass_hat_k([1], [2], 3)[0])
    with pytest.raises(ValueError, match="k must be"):
        pass_hat_k([1], [2], 0)
    with pytest.raises(ValueError, match="successes"):
        pass_at_k([3], [2], 1)
    with pytest.raises(ValueError, match="successes"):
        pass_at_k([1, 1], [2], 1)


counts = st.integers(1, 12).flatmap(
    lambda n: st.tuples(st.just(n), st.integers(0, n)))


@settings(max_examples=200, deadline=None)
@given(st.lists(counts, min_size=1, max_size=30), st.integers(1, 12))
def test_pass_k_properties_hold_for_any_counts(instances: list[tuple[int, int]], k: int) -> None:
    """pass^k <= pass@k, both in [0, 1], pass^k falls and pass@k rises with k; NaN exactly
    where an instance has fewer than k trials."""
    n = np.array([i[0] for i in instances], dtype=float)
    c = np.array([i[1] for i in instances], dtype=float)
    hat, at = pass_hat_k(c, n, k), pass_at_k(c, n, k)
    assert np.array_equal(np.isnan(hat), n < k) and np.array_equal(np.isnan(at), n < k)
    ok = n >= k
    assert np.all((hat[ok] >= 0) & (hat[ok] <= at[ok] + 1e-12) & (at[ok] <= 1 + 1e-12))
    ok2 = n >= k + 1
    assert np.all(pass_hat_k(c, n, k + 1)[ok2] <= hat[ok2] + 1e-12)
    assert np.all(pass_at_k(c, n, k + 1)[ok2] >= at[ok2] - 1e-12)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 9), st.one_of(st.none(), st.floats(-1e6, 1e6))),
                min_size=1, max_size=60))
def test_clustered_interval_holds_for_any_values_and_labels(rows: list[tuple[int, float | None]]
                                                            ) -> None:
    """Any labels, values and missing values: the estimate is the mean of the present values,
    inside its interval, and the interval inside their range (NA when none is present)."""
    labels = [r[0] for r in rows]
    values = np.array([np.nan if r[1] is None else r[1] for r in rows])
    est = mean_ci(values, Bootstrap(resamples=200), labels)
    present = values[~np.isnan(values)]
    if not present.size:
        assert est.na and est.n == 0
        return
    assert est.n == present.size and est.value == pytest.approx(present.mean(), abs=1e-6)
    slack = 1e-9 * max(1.0, np.abs(present).max())
    assert present.min() - slack <= est.lo <= est.value <= est.hi <= present.max() + slack

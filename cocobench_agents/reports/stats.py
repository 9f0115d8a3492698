"""Point estimates with percentile-bootstrap confidence intervals.

Every estimate resamples with replacement (`resamples` times, default 2000) and takes the
2.5th and 97.5th percentiles of the resampled statistic. What is resampled is the *cluster*:
given `clusters` (one label per value, e.g. the instance an episode ran), all values of a
cluster are drawn together (a clustered bootstrap, as repeated epochs of one instance are not
independent); without, or when every cluster holds one value (one epoch), each value is its
own cluster and the interval is the plain bootstrap's, draw for draw. Each call starts its own
generator from the same fixed seed, so an interval depends only on the values passed in, never
on which tables were computed before it: reports are byte-for-byte reproducible (NumPy's
legacy `RandomState`, whose streams are frozen across NumPy versions, is used for that).

The resampling is vectorised. For values with few distinct levels (0/1 successes, integer step
counts, paired differences in {-1, 0, 1}) the resampled counts of each level are drawn from a
multinomial distribution, which is exactly the distribution of an index bootstrap but costs
O(levels) instead of O(n) per resample; other values are resampled by index in chunks. A
clustered estimate works from per-cluster sums and sizes, with the same shortcut over the
distinct (sum, size) pairs. See docs/statistics.md.
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

DEFAULT_RESAMPLES = 2000
DEFAULT_SEED = 20240601
DEFAULT_CONFIDENCE = 0.95
_CHUNK_ELEMENTS = 2_000_000  # resampled values held in memory at once
_CACHED_ELEMENTS = 500_000  # index matrices up to this size are reused (see _index_matrix)
_LOCAL = threading.local()  # one reusable generator per thread, reset for every estimate


@dataclass(frozen=True)
class Bootstrap:
    """How intervals are computed: resamples, seed and confidence level."""

    resamples: int = DEFAULT_RESAMPLES
    seed: int = DEFAULT_SEED
    confidence: float = DEFAULT_CONFIDENCE

    def __post_init__(self) -> None:
        if self.resamples < 1:
            raise ValueError("resamples must be at least 1")
        if not 0.0 < self.confidence < 1.0:
            raise ValueError("confidence must be between 0 and 1")

    @property
    def quantiles(self) -> tuple[float, float]:
        tail = (1.0 - self.confidence) / 2.0
        return tail, 1.0 - tail

    def rng(self) -> np.random.RandomState:
        """A fresh generator: every estimate draws the same random stream. NumPy's legacy
        RandomState is used on purpose: its streams are frozen across NumPy versions, so
        intervals (and golden files) do not change when NumPy is upgraded."""
        cache = getattr(_LOCAL, "states", None)
        if cache is None:
            cache = _LOCAL.states = {}
            _LOCAL.rng = np.random.RandomState(0)
        if self.seed not in cache:
            cache[self.seed] = np.random.RandomState(self.seed).get_state()
        _LOCAL.rng.set_state(cache[self.seed])
        return _LOCAL.rng

    def interval(self, stats: np.ndarray) -> tuple[float, float]:
        """Percentile interval of resampled statistics (linear interpolation, as
        `numpy.quantile`'s default)."""
        ordered = np.sort(stats)
        out = []
        for q in self.quantiles:
            pos = q * (ordered.size - 1)
            below = math.floor(pos)
            above = min(below + 1, ordered.size - 1)
            frac = pos - below
            out.append(float(ordered[below] + (ordered[above] - ordered[below]) * frac))
        return out[0], out[1]


@dataclass(frozen=True)
class Estimate:
    """A statistic over `n` episodes with its interval; `value` is None (NA) when n is 0.

    `delta` marks a difference (rendered with an explicit sign).
    """

    value: float | None
    lo: float | None
    hi: float | None
    n: int
    delta: bool = False

    @property
    def na(self) -> bool:
        return self.value is None

    def as_delta(self) -> Estimate:
        return replace(self, delta=True)


NA = Estimate(None, None, None, 0)


def clean(values: Sequence[float] | np.ndarray) -> np.ndarray:
    """The values as float64 with NaN (missing, None) removed."""
    x = np.asarray(values, dtype=np.float64).ravel()
    return x[~np.isnan(x)]


def cluster_codes(labels: Sequence[object] | np.ndarray) -> np.ndarray:
    """Integer codes 0..k-1 of the labels, numbered in order of first appearance (so that
    one value per cluster numbers them 0..n-1 in their own order)."""
    labels = np.asarray(labels).ravel()
    if labels.size == 0:
        return np.zeros(0, dtype=np.int64)
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(first.size, dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    return rank[inverse.ravel()]


def cluster_totals(values: Sequence[float] | np.ndarray, clusters: Sequence[object] | np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Per cluster (in order of first appearance): the sum and the number of its non-missing
    values; clusters with none are left out. For 0/1 successes: successes and trials per
    instance, what `pass_hat_k` and `pass_at_k` take."""
    x = np.asarray(values, dtype=np.float64).ravel()
    keep = ~np.isnan(x)
    codes = cluster_codes(np.asarray(clusters).ravel()[keep])
    k = int(codes.max()) + 1 if codes.size else 0
    return (np.bincount(codes, weights=x[keep], minlength=k),
            np.bincount(codes, minlength=k).astype(np.float64))


def mean_ci(values: Sequence[float] | np.ndarray, boot: Bootstrap | None = None,
            clusters: Sequence[object] | np.ndarray | None = None) -> Estimate:
    """Mean of the non-missing values with its bootstrap interval (NA when none).

    `clusters` (one label per value, e.g. the instance of each episode): the interval
    resamples clusters, each with all its values (the mean is still over values)."""
    boot = boot or Bootstrap()
    if clusters is None:
        x, codes = clean(values), None
    else:
        raw = np.asarray(values, dtype=np.float64).ravel()
        keep = ~np.isnan(raw)
        x, codes = raw[keep], cluster_codes(np.asarray(clusters).ravel()[keep])
    n = x.size
    if n == 0:
        return NA
    value = float(x.mean())
    levels, counts = np.unique(x, return_counts=True)
    if levels.size == 1:
        return Estimate(value, value, value, n)
    if codes is not None and int(codes.max()) + 1 < n:  # some cluster holds several values
        k = int(codes.max()) + 1
        means = _resampled_ratios(np.bincount(codes, weights=x, minlength=k),
                                  np.bincount(codes, minlength=k).astype(np.float64), boot)
    else:
        means = _resampled_means(x, levels, counts, boot)
    lo, hi = boot.interval(means)
    # Percentile intervals of very skewed data can, in rare cases, miss the estimate itself.
    return Estimate(value, min(lo, value), max(hi, value), n)


def _resampled_means(x: np.ndarray, levels: np.ndarray, counts: np.ndarray,
                     boot: Bootstrap) -> np.ndarray:
    n = x.size
    if levels.size == 2:
        hits = boot.rng().binomial(n, counts[1] / n, size=boot.resamples)
        return (levels[0] * (n - hits) + levels[1] * hits) / n
    if levels.size * 4 <= n:
        draws = boot.rng().multinomial(n, counts / n, size=boot.resamples)
        return draws @ levels / n
    if boot.resamples * n <= _CACHED_ELEMENTS:
        return x[_index_matrix(boot.seed, boot.resamples, n)].mean(axis=1)
    rng = boot.rng()
    out = np.empty(boot.resamples)
    step = max(1, _CHUNK_ELEMENTS // n)
    for start in range(0, boot.resamples, step):
        stop = min(boot.resamples, start + step)
        idx = rng.randint(0, n, size=(stop - start, n), dtype=np.int32)
        out[start:stop] = x[idx].mean(axis=1)
    return out


def _resampled_ratios(sums: np.ndarray, sizes: np.ndarray, boot: Bootstrap) -> np.ndarray:
    """Σ sums / Σ sizes over each resample of the clusters (a clustered bootstrap of a mean).
    The statistic depends only on how many clusters of each distinct (sum, size) pair are
    drawn, which is multinomial: with few distinct pairs (0/1 outcomes over a few epochs)
    that is drawn instead of indices."""
    k = sums.size
    pairs, counts = np.unique(sums + 1j * sizes, return_counts=True)  # (sum, size) pairs
    if pairs.size * 4 <= k:
        draws = boot.rng().multinomial(k, counts / k, size=boot.resamples).astype(np.float64)
        return (draws @ pairs.real) / (draws @ pairs.imag)
    rng = boot.rng()
    out = np.empty(boot.resamples)
    step = max(1, _CHUNK_ELEMENTS // k)
    for start in range(0, boot.resamples, step):
        stop = min(boot.resamples, start + step)
        idx = rng.randint(0, k, size=(stop - start, k), dtype=np.int32)
        out[start:stop] = sums[idx].sum(axis=1) / sizes[idx].sum(axis=1)
    return out


@functools.lru_cache(maxsize=32)
def _index_matrix(seed: int, resamples: int, n: int) -> np.ndarray:
    """The resample indices a fresh generator draws for n values (the same for every
    estimate over n values, so they are kept for the next one)."""
    idx = Bootstrap(resamples, seed).rng().randint(0, n, size=(resamples, n), dtype=np.int32)
    idx.setflags(write=False)
    return idx


def paired_diff_ci(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                   boot: Bootstrap | None = None,
                   clusters: Sequence[object] | np.ndarray | None = None) -> Estimate:
    """Mean of a − b over the pairs where both are present (a paired bootstrap; with
    `clusters`, one label per pair, clustered as `mean_ci`)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return mean_ci(a - b, boot, clusters).as_delta()


def pearson_ci(x: Sequence[float] | np.ndarray, y: Sequence[float] | np.ndarray,
               boot: Bootstrap | None = None,
               clusters: Sequence[object] | np.ndarray | None = None) -> Estimate:
    """Pearson correlation over the episodes where both values are present (see
    `correlation_matrix`)."""
    return correlation_matrix([x, y], boot, clusters)[0][1]


def correlation_matrix(columns: Sequence[Sequence[float] | np.ndarray],
                       boot: Bootstrap | None = None,
                       clusters: Sequence[object] | np.ndarray | None = None
                       ) -> list[list[Estimate]]:
    """Pairwise Pearson correlations of equally long columns (one value per episode, NaN for
    missing), each pair over the episodes where both are present (n = those episodes).

    Intervals resample episodes: each resample draws n_total episodes with replacement once
    for all pairs and recomputes every r over the drawn episodes where both values are
    present. Resample weights times per-episode moments give every pair's sums in one matrix
    product. With `clusters` (one label per episode), clusters are resampled instead, each
    with its episodes' summed moments. NA (value None) with fewer than 3 pairs or a constant
    variable; resamples in which r is undefined are left out of the interval. The diagonal is
    exactly 1.
    """
    boot = boot or Bootstrap()
    data = np.column_stack([np.asarray(c, dtype=np.float64).ravel() for c in columns])
    k = data.shape[1]
    present = ~np.isnan(data)
    filled = np.where(present, data, 0.0)
    out = [[NA for _ in range(k)] for _ in range(k)]
    features, valid = [], []
    for i in range(k):
        for j in range(i, k):
            both = present[:, i] & present[:, j]
            n = int(both.sum())
            r = _pearson(data[both, i], data[both, j]) if n >= 3 else None
            if i == j:
                one = None if r is None else 1.0
                out[i][i] = Estimate(one, one, one, n)
                continue
            out[i][j] = out[j][i] = Estimate(r, r, r, n)
            if r is not None:
                m = both.astype(np.float64)
                x, y = filled[:, i] * m, filled[:, j] * m
                features += [m, x, y, x * x, y * y, x * y]
                valid.append((i, j))
    if not valid:
        return out
    moments = np.column_stack(features)
    if clusters is not None:
        codes = cluster_codes(clusters)
        k = int(codes.max()) + 1
        if k < codes.size:  # some cluster holds several episodes
            moments = np.stack([np.bincount(codes, weights=c, minlength=k)
                                for c in moments.T], axis=1)
    sums = _resampled_sums(moments, boot)
    for p, (i, j) in enumerate(valid):
        rs = _r_from_sums(sums[:, 6 * p:6 * p + 6])
        rs = rs[~np.isnan(rs)]
        est = out[i][j]
        if rs.size:
            lo, hi = boot.interval(rs)
            est = Estimate(est.value, min(lo, est.value), max(hi, est.value), est.n)
        out[i][j] = out[j][i] = est
    return out


def _resampled_sums(features: np.ndarray, boot: Bootstrap) -> np.ndarray:
    """Column sums of `features` (episodes × f) under each bootstrap resample of episodes."""
    n = features.shape[0]
    rng = boot.rng()
    out = np.empty((boot.resamples, features.shape[1]))
    step = max(1, _CHUNK_ELEMENTS // n)
    for start in range(0, boot.resamples, step):
        stop = min(boot.resamples, start + step)
        rows = stop - start
        idx = rng.randint(0, n, size=(rows, n), dtype=np.int32)
        flat = (idx + (np.arange(rows, dtype=np.int64) * n)[:, None]).ravel()
        weights = np.bincount(flat, minlength=rows * n).reshape(rows, n)
        out[start:stop] = weights.astype(np.float64) @ features
    return out


def _r_from_sums(s: np.ndarray) -> np.ndarray:
    """Pearson r per row from [count, Σx, Σy, Σx², Σy², Σxy] (NaN where undefined)."""
    w, sx, sy, sxx, syy, sxy = (s[:, c] for c in range(6))
    vx = w * sxx - sx * sx
    vy = w * syy - sy * sy
    cov = w * sxy - sx * sy
    ok = (w >= 2) & (vx > 1e-12 * np.maximum(w * sxx, 1e-300)) & (
        vy > 1e-12 * np.maximum(w * syy, 1e-300))
    r = np.full(s.shape[0], np.nan)
    r[ok] = np.clip(cov[ok] / np.sqrt(vx[ok] * vy[ok]), -1.0, 1.0)
    return r


def _pearson(x: np.ndarray, y: np.ndarray) -> float | None:
    if x.size < 2:
        return None
    dx, dy = x - x.mean(), y - y.mean()
    sxx, syy = float(dx @ dx), float(dy @ dy)
    if sxx <= 1e-12 * max(float(x @ x), 1e-300) or syy <= 1e-12 * max(float(y @ y), 1e-300):
        return None
    return float(np.clip((dx @ dy) / math.sqrt(sxx * syy), -1.0, 1.0))


def pass_hat_k(successes: Sequence[float] | np.ndarray, trials: Sequence[float] | np.ndarray,
               k: int) -> np.ndarray:
    """pass^k per instance: the unbiased estimate, from c successes in n trials, of the
    chance that k fresh trials all succeed, C(c, k) / C(n, k) (tau-bench's pass^k); NaN
    where n < k. The benchmark's pass^k is the mean over instances."""
    c, n = _counts(successes, trials, k)
    out = np.ones(c.shape)
    for i in range(k):
        out *= np.clip(c - i, 0.0, None) / np.maximum(n - i, 1.0)
    out[n < k] = np.nan
    return out


def pass_at_k(successes: Sequence[float] | np.ndarray, trials: Sequence[float] | np.ndarray,
              k: int) -> np.ndarray:
    """pass@k per instance: the unbiased estimate, from c successes in n trials, of the
    chance that at least one of k fresh trials succeeds, 1 − C(n − c, k) / C(n, k) (Chen et
    al. 2021, the Codex paper); NaN where n < k."""
    c, n = _counts(successes, trials, k)
    return 1.0 - pass_hat_k(n - c, n, k)


def _counts(successes: Sequence[float] | np.ndarray, trials: Sequence[float] | np.ndarray,
            k: int) -> tuple[np.ndarray, np.ndarray]:
    if k < 1:
        raise ValueError("k must be at least 1")
    c = np.asarray(successes, dtype=np.float64).ravel()
    n = np.asarray(trials, dtype=np.float64).ravel()
    if c.shape != n.shape or np.any(c < 0) or np.any(c > n):
        raise ValueError("successes and trials must be equally long, with 0 <= successes "
                         "<= trials")
    return c, n


def within_share_ci(successes: Sequence[float] | np.ndarray,
                    trials: Sequence[float] | np.ndarray,
                    boot: Bootstrap | None = None) -> Estimate:
    """The between-epoch share of the variance of 0/1 outcomes: σ²_within / (σ²_within +
    σ²_between) of the one-way random-effects model over instances (1 − the intraclass
    correlation; ANOVA estimators, σ²_between floored at 0), with an interval that
    resamples instances. 0: every instance gives the same outcome every epoch; about 1:
    which instance it is says nothing. NA without two instances, a repeated one, and some
    variance; n = instances."""
    boot = boot or Bootstrap()
    c = np.asarray(successes, dtype=np.float64).ravel()
    n = np.asarray(trials, dtype=np.float64).ravel()
    keep = n > 0
    c, n = c[keep], n[keep]
    # per-instance terms whose sums give the ANOVA: count, Σn, Σc, Σc²/n, Σn²
    terms = np.column_stack([np.ones_like(n), n, c, c * c / np.maximum(n, 1.0), n * n])
    value = float(_within_share(terms.sum(axis=0)[None, :])[0])
    if c.size < 2 or np.isnan(value):
        return Estimate(None, None, None, int(c.size))
    shares = _within_share(_resampled_sums(terms, boot))
    shares = shares[~np.isnan(shares)]
    lo, hi = boot.interval(shares) if shares.size else (value, value)
    return Estimate(value, min(lo, value), max(hi, value), int(c.size))


def _within_share(s: np.ndarray) -> np.ndarray:
    """σ²_w / (σ²_w + σ²_b) per row of sums [instances, Σn, Σc, Σc²/n, Σn²] (NaN where
    undefined)."""
    k, total_n, total_c, c2n, n2 = (s[:, i] for i in range(5))
    with np.errstate(divide="ignore", invalid="ignore"):
        ss_within = total_c - c2n  # Σ n p̂(1 − p̂)
        ss_between = c2n - total_c * total_c / total_n
        ms_within = ss_within / (total_n - k)
        ms_between = ss_between / (k - 1)
        n0 = (total_n - n2 / total_n) / (k - 1)  # epochs per instance, for unequal counts
        between = np.maximum((ms_between - ms_within) / n0, 0.0)
        share = ms_within / (ms_within + between)
    share[(k < 2) | (total_n <= k) | ~np.isfinite(share)] = np.nan
    return np.clip(share, 0.0, 1.0)


def sign_test_p(wins: int, losses: int) -> float | None:
    """Two-sided exact binomial test of wins against losses at p = 1/2 (ties left out): with
    0/1 outcomes paired once, the discordant pairs, this is McNemar's exact test. None when
    there is nothing to test."""
    m = wins + losses
    if m == 0:
        return None
    tail = sum(math.comb(m, i) for i in range(min(wins, losses) + 1))
    return min(1.0, 2 * tail / 2 ** m)


def total(values: Sequence[float] | np.ndarray) -> float | None:
    """Sum of the non-missing values (None when there are none)."""
    x = clean(values)
    return float(x.sum()) if x.size else None

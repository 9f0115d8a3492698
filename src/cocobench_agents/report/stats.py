"""Point estimates with percentile-bootstrap confidence intervals.

Every estimate resamples *episodes* with replacement (`resamples` times, default 2000) and
takes the 2.5th and 97.5th percentiles of the resampled statistic. Each call starts its own
generator from the same fixed seed, so an interval depends only on the values passed in, never
on which tables were computed before it: reports are byte-for-byte reproducible (NumPy's
legacy `RandomState`, whose streams are frozen across NumPy versions, is used for that).

The resampling is vectorised. For values with few distinct levels (0/1 successes, integer step
counts, paired differences in {-1, 0, 1}) the resampled counts of each level are drawn from a
multinomial distribution, which is exactly the distribution of an index bootstrap but costs
O(levels) instead of O(n) per resample; other values are resampled by index in chunks.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

DEFAULT_RESAMPLES = 2000
DEFAULT_SEED = 20240601
DEFAULT_CONFIDENCE = 0.95
_CHUNK_ELEMENTS = 2_000_000  # resampled values held in memory at once
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


def mean_ci(values: Sequence[float] | np.ndarray, boot: Bootstrap | None = None) -> Estimate:
    """Mean of the non-missing values with its bootstrap interval (NA when none)."""
    boot = boot or Bootstrap()
    x = clean(values)
    n = x.size
    if n == 0:
        return NA
    value = float(x.mean())
    levels, counts = np.unique(x, return_counts=True)
    if levels.size == 1:
        return Estimate(value, value, value, n)
    means = _resampled_means(x, levels, counts, boot)
    lo, hi = boot.interval(means)
    # Percentile intervals of very skewed data can, in rare cases, miss the estimate itself.
    return Estimate(value, min(lo, value), max(hi, value), n)


def _resampled_means(x: np.ndarray, levels: np.ndarray, counts: np.ndarray,
                     boot: Bootstrap) -> np.ndarray:
    n, rng = x.size, boot.rng()
    if levels.size == 2:
        hits = rng.binomial(n, counts[1] / n, size=boot.resamples)
        return (levels[0] * (n - hits) + levels[1] * hits) / n
    if levels.size * 4 <= n:
        draws = rng.multinomial(n, counts / n, size=boot.resamples)
        return draws @ levels / n
    out = np.empty(boot.resamples)
    step = max(1, _CHUNK_ELEMENTS // n)
    for start in range(0, boot.resamples, step):
        stop = min(boot.resamples, start + step)
        idx = rng.randint(0, n, size=(stop - start, n), dtype=np.int32)
        out[start:stop] = x[idx].mean(axis=1)
    return out


def paired_diff_ci(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                   boot: Bootstrap | None = None) -> Estimate:
    """Mean of a − b over the pairs where both are present (a paired bootstrap)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return mean_ci(a - b, boot).as_delta()


def pearson_ci(x: Sequence[float] | np.ndarray, y: Sequence[float] | np.ndarray,
               boot: Bootstrap | None = None) -> Estimate:
    """Pearson correlation over the pairs where both are present, bootstrapping pairs.

    NA with fewer than 3 pairs or when either variable is constant; resamples in which a
    variable is constant are left out of the interval.
    """
    boot = boot or Bootstrap()
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    keep = ~(np.isnan(x) | np.isnan(y))
    x, y = x[keep], y[keep]
    n = x.size
    r = _pearson(x, y)
    if n < 3 or r is None:
        return Estimate(None, None, None, n)
    rng = boot.rng()
    rs = np.empty(boot.resamples)
    step = max(1, _CHUNK_ELEMENTS // n)
    for start in range(0, boot.resamples, step):
        stop = min(boot.resamples, start + step)
        idx = rng.randint(0, n, size=(stop - start, n), dtype=np.int32)
        rs[start:stop] = _pearson_rows(x[idx], y[idx])
    rs = rs[~np.isnan(rs)]
    if rs.size == 0:
        return Estimate(r, r, r, n)
    lo, hi = boot.interval(rs)
    return Estimate(r, min(lo, r), max(hi, r), n)


def _pearson(x: np.ndarray, y: np.ndarray) -> float | None:
    if x.size < 2:
        return None
    dx, dy = x - x.mean(), y - y.mean()
    sxx, syy = float(dx @ dx), float(dy @ dy)
    if sxx <= 1e-24 or syy <= 1e-24:
        return None
    return float(np.clip((dx @ dy) / math.sqrt(sxx * syy), -1.0, 1.0))


def _pearson_rows(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    dx = xs - xs.mean(axis=1, keepdims=True)
    dy = ys - ys.mean(axis=1, keepdims=True)
    sxx = np.einsum("ij,ij->i", dx, dx)
    syy = np.einsum("ij,ij->i", dy, dy)
    sxy = np.einsum("ij,ij->i", dx, dy)
    ok = (sxx > 1e-24) & (syy > 1e-24)
    out = np.full(xs.shape[0], np.nan)
    out[ok] = np.clip(sxy[ok] / np.sqrt(sxx[ok] * syy[ok]), -1.0, 1.0)
    return out


def total(values: Sequence[float] | np.ndarray) -> float | None:
    """Sum of the non-missing values (None when there are none)."""
    x = clean(values)
    return float(x.sum()) if x.size else None

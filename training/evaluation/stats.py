"""Paired comparison of two controllers over the same realisations (seeds).

Each realisation is flown by both controllers, so the difference ``a - b`` of a metric on each
realisation removes what the realisation itself does to the metric (its gusts, its noise); the
mean of the differences and its 95 % interval say whether ``a`` is better than ``b``:

- ``method="t"``: the t interval, mean +- t(0.975, n - 1) * s / sqrt(n) (``scipy.stats.t``);
- ``method="bootstrap"``: the percentile interval of the mean over resamples of the pairs
  (fixed generator seed, so a comparison always gives the same interval).

The verdict reads the interval with the metric's direction (``LOWER_IS_BETTER`` for errors,
times and overshoots): "better" when the whole interval lies on the good side of zero, "worse"
when it lies on the bad side, "no difference" (at 95 %) when it contains zero.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

LOWER_IS_BETTER = "lower"
HIGHER_IS_BETTER = "higher"
VERDICTS = ("better", "worse", "no difference")


@dataclass(frozen=True)
class PairedDifference:
    """``a - b`` over ``n`` pairs: its mean, the 95 % interval and the verdict for ``a``."""

    mean: float
    low: float
    high: float
    n: int
    method: str
    direction: str
    verdict: str

    def as_dict(self) -> dict:
        return asdict(self)


def verdict(low: float, high: float, direction: str = LOWER_IS_BETTER) -> str:
    """"better", "worse" or "no difference" for ``a`` from the interval of ``a - b``."""
    if direction not in (LOWER_IS_BETTER, HIGHER_IS_BETTER):
        raise ValueError(f"direction must be {LOWER_IS_BETTER!r} or {HIGHER_IS_BETTER!r}, got {direction!r}")
    if not (math.isfinite(low) and math.isfinite(high)):
        return "no difference"
    if high < 0.0 or low > 0.0:
        below = high < 0.0
        return "better" if below == (direction == LOWER_IS_BETTER) else "worse"
    return "no difference"


def paired_difference(a, b, direction: str = LOWER_IS_BETTER, method: str = "t", confidence: float = 0.95,
                      resamples: int = 10_000, seed: int = 0) -> PairedDifference:
    """The paired difference ``a - b`` (one value of each per realisation, in the same order).
    Pairs where either value is not finite (a flight that ended before the window) are left out;
    with fewer than two pairs the interval is NaN and the verdict "no difference"."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"paired samples need the same length, got {a.shape} and {b.shape}")
    if method not in ("t", "bootstrap"):
        raise ValueError(f"method must be 't' or 'bootstrap', got {method!r}")
    d = (a - b)[np.isfinite(a) & np.isfinite(b)]
    n = int(d.size)
    if n == 0:
        return PairedDifference(math.nan, math.nan, math.nan, 0, method, direction, verdict(math.nan, math.nan,
                                                                                            direction))
    mean = float(d.mean())
    if n < 2:
        low = high = math.nan
    elif method == "t":
        from scipy import stats

        half = float(stats.t.ppf(0.5 + confidence / 2.0, n - 1) * d.std(ddof=1) / math.sqrt(n))
        low, high = mean - half, mean + half
    else:
        rng = np.random.default_rng(seed)
        means = d[rng.integers(0, n, size=(resamples, n))].mean(axis=1)
        low, high = (float(q) for q in np.quantile(means, [0.5 - confidence / 2.0, 0.5 + confidence / 2.0]))
        low, high = min(low, mean), max(high, mean)  # identical pairs: exactly zero width
    return PairedDifference(mean, low, high, n, method, direction, verdict(low, high, direction))


__all__ = ["HIGHER_IS_BETTER", "LOWER_IS_BETTER", "VERDICTS", "PairedDifference", "paired_difference", "verdict"]

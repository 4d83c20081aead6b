"""Where in frequency a controller leaves its attitude errors: the share of each error's power in
frequency bands, over a benchmark turbulence flight's window (``scripts/error_spectrum.py``).

A controller with high gain at low frequency leaves little error power at the slow end; one whose
integral action is too slow, or too strong, leaves it there. The power is a periodogram of the
error with its mean removed (the mean is a steady error, which the calm family scores), so the
shares describe the error's fluctuation and sum to 1.
"""

from __future__ import annotations

import numpy as np

BANDS_HZ = ((0.0, 0.05), (0.05, 0.2), (0.2, 0.5), (0.5, 1.0), (1.0, 3.0), (3.0, float("inf")))


def band_shares(signal, dt_s: float, bands=BANDS_HZ) -> list[float]:
    """The share of ``signal``'s fluctuation power (mean removed) in each band [low, high) Hz;
    ``ValueError`` for fewer than 8 samples, a non-finite sample or a non-positive interval."""
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1 or x.size < 8 or not np.all(np.isfinite(x)):
        raise ValueError(f"need at least 8 finite samples in one dimension, got shape {x.shape}")
    if not 0.0 < dt_s < np.inf:
        raise ValueError(f"sample interval must be positive and finite, got {dt_s}")
    x = x - x.mean()
    power = np.abs(np.fft.rfft(x)) ** 2
    freq = np.fft.rfftfreq(x.size, dt_s)
    total = power.sum()
    if total == 0.0:
        return [0.0] * len(bands)
    return [float(power[(freq >= lo) & (freq < hi)].sum() / total) for lo, hi in bands]


def mean_step_change(signal) -> float:
    """Mean absolute change per sample: how busy a command is."""
    x = np.asarray(signal, dtype=float)
    return float(np.abs(np.diff(x)).mean())


__all__ = ["BANDS_HZ", "band_shares", "mean_step_change"]

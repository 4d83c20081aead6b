"""Disturbances every controller flies through: sensor noise, turbulence, parameter sets.

Each draws only from the generator it is given (the episode's), so the same seed gives the same
disturbance sequence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

# ----------------------------------------------------------------------------- sensor noise


class OrnsteinUhlenbeckNoise:
    """Ornstein-Uhlenbeck noise per observed state element (SPEC Table 3).

    dx = -reversion * x dt + sigma dW, integrated exactly over each step. With the reversion rate
    0 (the value the paper prints) it is a random walk whose increments over dt have standard
    deviation sigma * sqrt(dt). Works on plain lists: the vectors are short and stepped often.
    """

    def __init__(self, sigma, reversion_per_s: float = 0.0):
        self.sigma = [float(x) for x in sigma]
        self.reversion_per_s = float(reversion_per_s)
        self.reset()

    def reset(self, rng: np.random.Generator | None = None, steps: int = 0) -> None:
        """Zero the noise; with ``rng``, draw the white noise of ``steps`` steps now (one call
        instead of one per step; the same values in the same order)."""
        self.state = [0.0] * len(self.sigma)
        self._dt_s = None
        self._drawn = rng.standard_normal((steps, len(self.sigma))).tolist() if rng is not None else []
        self._next = 0

    def step(self, dt_s: float, rng: np.random.Generator) -> list[float]:
        """Advance by ``dt_s`` and return the noise (a list, one value per state element).

        Uses the white noise drawn at ``reset`` while it lasts, then draws from ``rng``.
        """
        if dt_s != self._dt_s:
            k = self.reversion_per_s
            if k > 0.0:
                self._decay = math.exp(-k * dt_s)
                factor = math.sqrt((1.0 - self._decay**2) / (2.0 * k))
            else:
                self._decay, factor = 1.0, math.sqrt(dt_s)
            self._scale = [sig * factor for sig in self.sigma]
            self._dt_s = dt_s
        d = self._decay
        if self._next < len(self._drawn):
            eps = self._drawn[self._next]
            self._next += 1
        else:
            eps = rng.standard_normal(len(self.sigma)).tolist()
        self.state = [d * x + c * e for x, c, e in zip(self.state, self._scale, eps)]
        return self.state


# ----------------------------------------------------------------------------- turbulence

FT = 0.3048
WIND_LIMIT_MPS = 2.0  # SPEC section 3: wind components clipped to +-2 m/s
RATE_LIMIT_RADPS = math.radians(0.3)  # and turbulence angular rates to +-0.3 deg/s


def dryden_scale_lengths_m(altitude_m: float) -> tuple[float, float, float]:
    """MIL-F-8785C scale lengths (L_u, L_v, L_w): low-altitude form below 1000 ft, 1750 ft above
    2000 ft, linear in between."""
    h_ft = max(altitude_m / FT, 10.0)
    if h_ft <= 1000.0:
        l_uv = h_ft / (0.177 + 0.000823 * h_ft) ** 1.2
        return l_uv * FT, l_uv * FT, h_ft * FT
    if h_ft >= 2000.0:
        return (1750.0 * FT,) * 3
    lo = dryden_scale_lengths_m(1000.0 * FT)
    f = (h_ft - 1000.0) / 1000.0
    return tuple(a + f * (1750.0 * FT - a) for a in lo)


def _bilinear(num: np.ndarray, den: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Tustin transform s = (2/dt)(z-1)/(z+1) of a transfer function (coefficients highest power
    first); the same result as ``scipy.signal.bilinear``, without its polynomial objects (100x faster)."""
    n = max(len(num), len(den)) - 1
    c = 2.0 / dt_s
    minus, plus = [np.ones(1)], [np.ones(1)]
    for _ in range(n):
        minus.append(np.convolve(minus[-1], [1.0, -1.0]))
        plus.append(np.convolve(plus[-1], [1.0, 1.0]))

    def transform(poly: np.ndarray) -> np.ndarray:
        out = np.zeros(n + 1)
        for k, coef in enumerate(poly[::-1]):  # coef multiplies s**k
            out += coef * c**k * np.convolve(minus[k], plus[n - k])
        return out

    b, a = transform(num), transform(den)
    return b / a[0], a / a[0]


def dryden_filters(altitude_m: float, airspeed_mps: float, span_m: float, sigma_mps: float,
                   dt_s: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Discrete Dryden shaping filters (MIL-F-8785C) for u, v, w gusts and p, q, r rates.

    Each is driven by unit-variance white noise samples; ``u``, ``v``, ``w`` use independent
    sequences, ``p`` its own, ``q`` shares ``w``'s and ``r`` shares ``v``'s (the rotational gusts
    are the spatial gradients of the vertical and lateral ones). The intensity is the same for the
    three axes (MIL-F-8785C's form above 2000 ft).
    """
    v = max(airspeed_mps, 1.0)
    lu, lv, lw = dryden_scale_lengths_m(altitude_m)
    s = sigma_mps
    # Continuous shaping filters for white noise of unit two-sided spectral density.
    tfs = {
        "u": ([s * math.sqrt(2.0 * lu / (math.pi * v))], [lu / v, 1.0]),
        "v": (np.convolve([math.sqrt(3.0) * lv / v, 1.0], [s * math.sqrt(lv / (math.pi * v))]),
              np.convolve([lv / v, 1.0], [lv / v, 1.0])),
        "w": (np.convolve([math.sqrt(3.0) * lw / v, 1.0], [s * math.sqrt(lw / (math.pi * v))]),
              np.convolve([lw / v, 1.0], [lw / v, 1.0])),
    }
    p_gain = s * math.sqrt(0.8 / v) * (math.pi / (4.0 * span_m)) ** (1.0 / 6.0) / (2.0 * lw) ** (1.0 / 3.0)
    tfs["p"] = ([p_gain], [4.0 * span_m / (math.pi * v), 1.0])
    num_w, den_w = tfs["w"]
    tfs["q"] = (np.convolve([1.0 / v, 0.0], num_w), np.convolve([4.0 * span_m / (math.pi * v), 1.0], den_w))
    num_v, den_v = tfs["v"]
    tfs["r"] = (np.convolve([-1.0 / v, 0.0], num_v), np.convolve([3.0 * span_m / (math.pi * v), 1.0], den_v))
    out = {}
    for name, (num, den) in tfs.items():
        out[name] = _bilinear(np.asarray(num, float), np.asarray(den, float), dt_s)
    return out


@dataclass
class TurbulenceSeries:
    """Body-axis gusts over one episode at the control interval: winds (m/s) and rates (rad/s)."""

    wind_mps: np.ndarray  # (n, 3): u, v, w
    rate_radps: np.ndarray  # (n, 3): p, q, r


def dryden_series(n_steps: int, altitude_m: float, airspeed_mps: float, span_m: float, sigma_mps: float,
                  dt_s: float, rng: np.random.Generator, warmup_steps: int = 400) -> TurbulenceSeries:
    """A clipped Dryden turbulence time series (see ``dryden_filters``).

    The filters are run ``warmup_steps`` ahead so that the series starts in their stationary state.
    MIL-F-8785C writes the spectra one-sided in angular frequency (their integral over 0..inf is
    sigma^2), which is white noise of two-sided density pi: variance pi/dt per sample.
    """
    filters = dryden_filters(altitude_m, airspeed_mps, span_m, sigma_mps, dt_s)
    n = n_steps + warmup_steps
    noise = rng.standard_normal((4, n)) * math.sqrt(math.pi / dt_s)
    drive = {"u": noise[0], "v": noise[1], "w": noise[2], "p": noise[3], "q": noise[2], "r": noise[1]}
    out = {k: signal.lfilter(*filters[k], drive[k])[warmup_steps:] for k in filters}
    wind = np.clip(np.stack([out["u"], out["v"], out["w"]], axis=1), -WIND_LIMIT_MPS, WIND_LIMIT_MPS)
    rate = np.clip(np.stack([out["p"], out["q"], out["r"]], axis=1), -RATE_LIMIT_RADPS, RATE_LIMIT_RADPS)
    return TurbulenceSeries(wind, rate)


def body_to_ned(roll_rad: float, pitch_rad: float, yaw_rad: float, vec: np.ndarray) -> tuple[float, float, float]:
    """Rotate a body-axis vector into north-east-down."""
    cf, sf = math.cos(roll_rad), math.sin(roll_rad)
    ct, st = math.cos(pitch_rad), math.sin(pitch_rad)
    cp, sp = math.cos(yaw_rad), math.sin(yaw_rad)
    x, y, z = vec
    north = ct * cp * x + (sf * st * cp - cf * sp) * y + (cf * st * cp + sf * sp) * z
    east = ct * sp * x + (sf * st * sp + cf * cp) * y + (cf * st * sp - sf * cp) * z
    down = -st * x + sf * ct * y + cf * ct * z
    return north, east, down


# ----------------------------------------------------------------------------- parameter sets

# SPEC Table 4: per-episode draws, each coefficient independently, U(lo*xi, hi*xi).
RANDOMISATION_GROUPS: dict[str, tuple[tuple[str, ...], tuple[float, float]]] = {
    "inertia": (("I",), (0.95, 1.15)),
    "lift": (("CL0", "CLbeta", "CLde", "CLda", "CLdr", "CLq"), (0.8, 1.2)),
    "drag": (("CD0", "CDbeta", "CDda", "CDde", "CDdr"), (0.8, 1.2)),
    "side_force": (("CYbeta", "CYda", "CYdr", "CYp", "CYq"), (0.8, 1.2)),
    "roll": (("Clbeta", "Clda", "Cldr"), (0.8, 1.2)),
    "pitch": (("Cm0", "Cmbeta", "Cmde", "Cmda", "Cmdr"), (0.8, 1.2)),
    "yaw": (("Cnbeta", "Cnda", "Cndr"), (0.8, 1.2)),
    "damping": (("Clp", "Clr", "Cmq", "Cnp", "Cnr"), (0.8, 1.2)),
}

# SPEC Table 9: fixed sets ("positive" and "negative" aircraft) for the perturbation study.
_TABLE9_ROWS = (
    (("I",), 0.95, 1.05),
    (("CL0", "CLbeta", "CLde", "CLda", "CLdr", "CLq"), 1.10, 0.90),
    (("CD0", "CDbeta", "CDda", "CDde", "CDdr"), 0.90, 1.10),
    (("CYbeta", "CYda", "CYdr", "CYp", "CYq"), 1.15, 0.85),
    (("Clbeta", "Cldr", "Cm0", "Cmbeta", "Cmda", "Cmdr", "Cnda", "Cnbeta"), 0.85, 1.15),
    (("Cmde", "Clda", "Cndr"), 1.15, 0.85),
    (("Clp", "Clr", "Cmq", "Cnp", "Cnr"), 0.70, 1.30),
)
PARAMETER_SETS: dict[str, dict[str, float]] = {
    "nominal": {},
    "positive": {t: pos for terms, pos, _ in _TABLE9_ROWS for t in terms},
    "negative": {t: neg for terms, _, neg in _TABLE9_ROWS for t in terms},
}
RANDOMISED = "table4"


def draw_scales(parameters: str, rng: np.random.Generator) -> dict[str, float]:
    """Scale factor per term (missing terms are 1): a Table 4 draw or a named fixed set."""
    if parameters == RANDOMISED:
        scales = {}
        for terms, (lo, hi) in RANDOMISATION_GROUPS.values():
            for term in terms:
                scales[term] = float(rng.uniform(lo, hi))
        return scales
    try:
        return dict(PARAMETER_SETS[parameters])
    except KeyError:
        raise ValueError(f"unknown parameter set {parameters!r}: use {RANDOMISED!r} or one of "
                         f"{sorted(PARAMETER_SETS)}") from None

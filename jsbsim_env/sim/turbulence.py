"""Dryden turbulence (MIL-F-8785C) as the flight core applies it.

Intensities and scale lengths against altitude, the shaping filters, the rotational gusts from the
spatial gradients of the linear ones, and the clips. Each series draws only from the generator it
is given (the episode's), so the same seed gives the same turbulence.

Axes and signs: body axes, x forward, y right, z down. ``u, v, w`` are the wind (the air's velocity)
along them, which the core rotates into JSBSim's ``atmosphere/gust-{north,east,down}-fps``. JSBSim's
airspeed is the body velocity minus the wind, so a positive ``w`` lowers the angle of attack and a
positive ``v`` lowers the sideslip. ``p, q, r`` go to ``atmosphere/gust-{p,q,r}-rad_sec``, which
the model's rate terms subtract from the body rates.

Altitudes are above the ground, which the packaged initial conditions put at sea level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FT_TO_M = 0.3048
KNOT_TO_MPS = 1852.0 / 3600.0

# ----------------------------------------------------------------------------- intensity

PAPER = "paper"  # sigma_mps on every axis at every altitude (the paper's Section 3.4)
# MIL-F-8785C section 3.7.2.3: the probability-of-exceedance curve of Fig. 7 each severity uses
# above 2000 ft, and its wind at 20 ft below 1000 ft.
SEVERITIES: dict[str, tuple[float, float]] = {  # name: (probability of exceedance, W20 in knots)
    "light": (1e-2, 15.0),
    "moderate": (1e-3, 30.0),
    "severe": (1e-5, 45.0),
}
# MIL-F-8785C Fig. 7, medium/high-altitude intensity sigma_u = sigma_v = sigma_w (ft/s) against
# altitude (ft), read at these altitudes for the three curves above.
POE_ALTITUDES_FT = (500.0, 1750.0, 3750.0, 7500.0, 15000.0, 25000.0, 35000.0, 45000.0, 55000.0, 65000.0,
                    75000.0, 80000.0)
POE_SIGMA_FPS: dict[float, tuple[float, ...]] = {
    1e-2: (6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0.0, 0.0, 0.0, 0.0, 0.0),
    1e-3: (8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0.0, 0.0, 0.0),
    1e-5: (15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1),
}
LOW_ALTITUDE_FT = 1000.0  # below: the boundary-layer form; above 2000 ft: isotropic; between: linear
HIGH_ALTITUDE_FT = 2000.0


def _low_altitude_ratio(h_ft: float) -> float:
    """MIL-F-8785C's 0.177 + 0.000823 h of the low-altitude scale lengths and intensities."""
    return 0.177 + 0.000823 * h_ft


def dryden_scale_lengths_m(altitude_m: float) -> tuple[float, float, float]:
    """MIL-F-8785C scale lengths (L_u, L_v, L_w): low-altitude form below 1000 ft, 1750 ft above
    2000 ft, linear in between."""
    h_ft = max(altitude_m / FT_TO_M, 10.0)
    if h_ft <= LOW_ALTITUDE_FT:
        l_uv = h_ft / _low_altitude_ratio(h_ft) ** 1.2
        return l_uv * FT_TO_M, l_uv * FT_TO_M, h_ft * FT_TO_M
    if h_ft >= HIGH_ALTITUDE_FT:
        return (1750.0 * FT_TO_M,) * 3
    lo = dryden_scale_lengths_m(LOW_ALTITUDE_FT * FT_TO_M)
    f = (h_ft - LOW_ALTITUDE_FT) / (HIGH_ALTITUDE_FT - LOW_ALTITUDE_FT)
    return tuple(a + f * (1750.0 * FT_TO_M - a) for a in lo)


def milspec_intensities_mps(altitude_m: float, severity: str) -> tuple[float, float, float]:
    """MIL-F-8785C intensities (sigma_u, sigma_v, sigma_w) of a severity ("light", "moderate",
    "severe"): sigma_w = W20 / 10 and sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4 below
    1000 ft, the probability-of-exceedance curve of Fig. 7 above 2000 ft, linear in between."""
    try:
        poe, w20_kt = SEVERITIES[severity]
    except KeyError:
        raise ValueError(f"unknown turbulence severity {severity!r}: use one of {sorted(SEVERITIES)}") from None
    h_ft = max(altitude_m / FT_TO_M, 10.0)
    sigma_w = 0.1 * w20_kt * KNOT_TO_MPS
    if h_ft <= LOW_ALTITUDE_FT:
        sigma_uv = sigma_w / _low_altitude_ratio(h_ft) ** 0.4
        return sigma_uv, sigma_uv, sigma_w
    high = float(np.interp(max(h_ft, HIGH_ALTITUDE_FT), POE_ALTITUDES_FT, POE_SIGMA_FPS[poe])) * FT_TO_M
    if h_ft >= HIGH_ALTITUDE_FT:
        return (high,) * 3
    f = (h_ft - LOW_ALTITUDE_FT) / (HIGH_ALTITUDE_FT - LOW_ALTITUDE_FT)
    low = milspec_intensities_mps(LOW_ALTITUDE_FT * FT_TO_M, severity)
    return tuple(a + f * (high - a) for a in low)


def intensities_mps(altitude_m: float, intensity: str = PAPER, sigma_mps: float = 0.5) -> tuple[float, float, float]:
    """(sigma_u, sigma_v, sigma_w): ``sigma_mps`` on each axis for ``"paper"``, else a MIL-F-8785C
    severity (``milspec_intensities_mps``)."""
    if intensity == PAPER:
        return (float(sigma_mps),) * 3
    return milspec_intensities_mps(altitude_m, intensity)


# ----------------------------------------------------------------------------- filters

def _bilinear(num, den, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Tustin transform s = (2/dt)(z-1)/(z+1) of a transfer function (coefficients highest power
    first); the same result as ``scipy.signal.bilinear``, without its polynomial objects (100x faster)."""
    num, den = np.asarray(num, float), np.asarray(den, float)
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


def dryden_filters(altitude_m: float, airspeed_mps: float, span_m: float, sigmas_mps: tuple[float, float, float],
                   dt_s: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Discrete MIL-F-8785C Dryden shaping filters for the u, v, w gusts and the roll gust p.

    Each is driven by its own white noise of two-sided density pi (variance pi/dt per sample; see
    ``dryden_series``). The pitch and yaw gusts are not driven by noise of their own: they are the
    gradients of w and v (``gradient_rate_filters``).
    """
    v = max(airspeed_mps, 1.0)
    lu, lv, lw = dryden_scale_lengths_m(altitude_m)
    su, sv, sw = sigmas_mps

    def second_order(sigma: float, length: float):
        tau = length / v
        return np.convolve([math.sqrt(3.0) * tau, 1.0], [sigma * math.sqrt(length / (math.pi * v))]), \
            np.convolve([tau, 1.0], [tau, 1.0])

    # p_g: MIL-F-8785C's spectrum sigma_w^2 / (V L_w) 0.8 (pi L_w / 4b)^(1/3) / (1 + (4b w / pi V)^2).
    p_gain = sw * math.sqrt(0.8 / v) * (math.pi / (4.0 * span_m)) ** (1.0 / 6.0) / lw ** (1.0 / 3.0)
    tfs = {
        "u": ([su * math.sqrt(2.0 * lu / (math.pi * v))], [lu / v, 1.0]),
        "v": second_order(sv, lv),
        "w": second_order(sw, lw),
        "p": ([p_gain], [4.0 * span_m / (math.pi * v), 1.0]),
    }
    return {name: _bilinear(num, den, dt_s) for name, (num, den) in tfs.items()}


def gradient_rate_filters(airspeed_mps: float, span_m: float, dt_s: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Discrete filters from the w series to q_g and from the v series to r_g.

    In a frozen field a point x ahead of the CG (body x forward) meets the air the CG meets x/V
    later, so along the body d/dx = (1/V) d/dt of the series at the CG. The local angle of attack
    is alpha - w(x)/V: the tail (x = -l_t) minus the wing differ by l_t/V * dw/dx, which is what a
    pitch rate q = dw/dx gives. The air therefore acts like a body rate q + dw/dx, and likewise
    (sideslip beta - v(x)/V at the fin) r - dv/dx. The model subtracts the gust rates, so
    q_g = -(1/V) dw/dt and r_g = +(1/V) dv/dt, each low-passed over the span as MIL-F-8785C
    gives (1 / (1 + 4bs/(pi V)) and 1 / (1 + 3bs/(pi V))).
    """
    v = max(airspeed_mps, 1.0)
    return {
        "q": _bilinear([-1.0 / v, 0.0], [4.0 * span_m / (math.pi * v), 1.0], dt_s),
        "r": _bilinear([1.0 / v, 0.0], [3.0 * span_m / (math.pi * v), 1.0], dt_s),
    }


def gradient_rate_gusts(w_mps: np.ndarray, v_mps: np.ndarray, airspeed_mps: float, span_m: float,
                        dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The pitch and yaw gusts (rad/s) of a field whose w and v, as the CG meets them, are the
    series ``w_mps`` and ``v_mps`` sampled every ``dt_s`` (see ``gradient_rate_filters``).

    The filters start at rest, as the series do; any field can be put through, a Dryden one or a
    test's sinusoid.
    """
    from scipy import signal  # here, not at the top: importing the package stays light
    f = gradient_rate_filters(airspeed_mps, span_m, dt_s)
    return signal.lfilter(*f["q"], w_mps), signal.lfilter(*f["r"], v_mps)


def stationary_std(b: np.ndarray, a: np.ndarray, input_variance: float) -> float:
    """Standard deviation of a discrete filter's output in its stationary state, for white noise
    of ``input_variance`` at its input: exact for the discrete filter, from the Lyapunov equation
    P = A P A' + B B' of its controllable canonical form (a few microseconds at these orders)."""
    b, a = np.asarray(b, float) / a[0], np.asarray(a, float) / a[0]
    n = len(a) - 1
    b = np.concatenate([np.zeros(n + 1 - len(b)), b])
    if n == 0:
        return abs(b[0]) * math.sqrt(input_variance)
    a_mat = np.zeros((n, n))
    a_mat[0] = -a[1:]
    a_mat[1:, :-1] = np.eye(n - 1)
    c = b[1:] - b[0] * a[1:]
    q = np.zeros((n, n))
    q[0, 0] = 1.0
    state = np.linalg.solve(np.eye(n * n) - np.kron(a_mat, a_mat), q.ravel()).reshape(n, n)
    return math.sqrt(input_variance * (c @ state @ c + b[0] ** 2))


# ----------------------------------------------------------------------------- series and clips

CLIPS = ("4sigma", "paper")
PAPER_WIND_CLIP_MPS = 2.0  # the paper's Section 3.4: wind components clipped to +-2 m/s
PAPER_RATE_CLIP_RADPS = math.radians(0.3)  # and turbulence angular rates to +-0.3 deg/s
# The paper's wind clip is 4 sigma at its 0.5 m/s (exceeded 0.006 % of the time); "4sigma" clips
# every channel at 4 times its own stationary standard deviation, as rarely.
CLIP_SIGMAS = 4.0
WARMUP_TIME_CONSTANTS = 5.0  # the filters start at rest; 5 of their slowest time constants settle them


@dataclass
class TurbulenceSeries:
    """Body-axis gusts over one episode at the control interval: winds (m/s) and rates (rad/s),
    and the clip each channel had."""

    wind_mps: np.ndarray  # (n, 3): u, v, w
    rate_radps: np.ndarray  # (n, 3): p, q, r
    wind_clip_mps: np.ndarray  # (3,)
    rate_clip_radps: np.ndarray  # (3,)


def clip_limits(altitude_m: float, airspeed_mps: float, span_m: float, dt_s: float, intensity: str = PAPER,
                sigma_mps: float = 0.5, clip: str = "4sigma") -> tuple[np.ndarray, np.ndarray]:
    """Clip of each wind (m/s) and rate (rad/s) channel: the paper's +-2 m/s and +-0.3 deg/s
    (``clip="paper"``), or 4 times each channel's stationary standard deviation (``"4sigma"``;
    +-2 m/s on the winds at the paper's 0.5 m/s)."""
    sigmas = intensities_mps(altitude_m, intensity, sigma_mps)
    return _clip_limits(clip, sigmas, dryden_filters(altitude_m, airspeed_mps, span_m, sigmas, dt_s),
                        gradient_rate_filters(airspeed_mps, span_m, dt_s), dt_s)


def _clip_limits(clip: str, sigmas_mps, linear: dict, gradient: dict, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    if clip == "paper":
        return np.full(3, PAPER_WIND_CLIP_MPS), np.full(3, PAPER_RATE_CLIP_RADPS)
    if clip != "4sigma":
        raise ValueError(f"unknown turbulence clip {clip!r}: use one of {CLIPS}")
    # q and r as the cascade of their gradient filter behind the w and v shaping filters.
    rates = {"p": linear["p"]}
    for rate, source in (("q", "w"), ("r", "v")):
        rates[rate] = tuple(np.convolve(g, f) for g, f in zip(gradient[rate], linear[source]))
    rate_std = [stationary_std(*rates[k], math.pi / dt_s) for k in "pqr"]
    return CLIP_SIGMAS * np.array(sigmas_mps), CLIP_SIGMAS * np.array(rate_std)


def dryden_series(n_steps: int, altitude_m: float, airspeed_mps: float, span_m: float, dt_s: float,
                  rng: np.random.Generator, intensity: str = PAPER, sigma_mps: float = 0.5,
                  clip: str = "4sigma") -> TurbulenceSeries:
    """A clipped Dryden turbulence series of ``n_steps`` samples every ``dt_s``.

    u, v, w and p come from independent white noise through ``dryden_filters``; q and r from the
    w and v series through ``gradient_rate_gusts``. The filters run ahead by five of their slowest
    time constants, so that the series starts in their stationary state. MIL-F-8785C writes the
    spectra one-sided in angular frequency (their integral over 0..inf is sigma^2), which is white
    noise of two-sided density pi: variance pi/dt per sample. ``intensity``, ``sigma_mps``: see
    ``intensities_mps``; ``clip``: see ``clip_limits``.
    """
    from scipy import signal  # here, not at the top: importing the package stays light
    v = max(airspeed_mps, 1.0)
    sigmas = intensities_mps(altitude_m, intensity, sigma_mps)
    filters = dryden_filters(altitude_m, v, span_m, sigmas, dt_s)
    slowest_s = max(*dryden_scale_lengths_m(altitude_m), 4.0 * span_m / math.pi) / v
    warmup = math.ceil(WARMUP_TIME_CONSTANTS * slowest_s / dt_s)
    n = n_steps + warmup
    noise = rng.standard_normal((4, n)) * math.sqrt(math.pi / dt_s)
    u, vg, w, p = (signal.lfilter(*filters[k], e) for k, e in zip("uvwp", noise))
    q, r = gradient_rate_gusts(w, vg, v, span_m, dt_s)
    wind_clip, rate_clip = _clip_limits(clip, sigmas, filters, gradient_rate_filters(v, span_m, dt_s), dt_s)
    wind = np.clip(np.stack([u, vg, w], axis=1)[warmup:], -wind_clip, wind_clip)
    rate = np.clip(np.stack([p, q, r], axis=1)[warmup:], -rate_clip, rate_clip)
    return TurbulenceSeries(wind, rate, wind_clip, rate_clip)


def body_to_ned(roll_rad: float, pitch_rad: float, yaw_rad: float, vec) -> tuple[float, float, float]:
    """Rotate a body-axis vector into north-east-down."""
    cf, sf = math.cos(roll_rad), math.sin(roll_rad)
    ct, st = math.cos(pitch_rad), math.sin(pitch_rad)
    cp, sp = math.cos(yaw_rad), math.sin(yaw_rad)
    x, y, z = vec
    north = ct * cp * x + (sf * st * cp - cf * sp) * y + (cf * st * cp + sf * sp) * z
    east = ct * sp * x + (sf * st * sp + cf * cp) * y + (cf * st * sp - sf * cp) * z
    down = -st * x + sf * ct * y + cf * ct * z
    return north, east, down

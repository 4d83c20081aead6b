"""Disturbances every controller flies through: sensor noise and parameter sets (turbulence:
``jsbsim_env.sim.turbulence``).

Each draws only from the generator it is given (the episode's), so the same seed gives the same
disturbance sequence.
"""

from __future__ import annotations

import math

import numpy as np

# ----------------------------------------------------------------------------- sensor noise


class OrnsteinUhlenbeckNoise:
    """Ornstein-Uhlenbeck noise per observed state element (the paper's Table 3).

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


# ----------------------------------------------------------------------------- parameter sets

# The paper's Table 4: per-episode draws, each coefficient independently, U(lo*xi, hi*xi).
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

# The paper's Table 9: fixed sets ("positive" and "negative" aircraft) for the perturbation study.
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

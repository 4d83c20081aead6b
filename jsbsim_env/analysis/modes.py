"""Linear modes of the trimmed aircraft, linearised on JSBSim's own equations of motion.

The state derivatives come from JSBSim: each perturbed state is set through an initial-condition
pass and JSBSim's body accelerations (``accelerations/udot-ft_sec2`` ... ``rdot-rad_sec2``) are
turned into the derivatives of the classical states by the exact kinematic relations. Central
differences give the Jacobian; the rotors stay at their trimmed speed (JSBSim's initial-condition
pass keeps them), as in the textbook rigid-body modes.

Why not ``jsbsim.FGLinearization``: its ``FGStateSpace::run`` calls
``FGPropulsion::GetSteadyState``, which time-marches every engine to a steady thrust at a fixed
power fraction. Here the power fraction is the output of each motor's speed controller (the
throttle commands rotor speed), so that search drives the rotors to the power limit or to rest:
it takes 20-30 s per point, did not finish in five minutes at 20 km, and leaves the rotors
stopped. ``tests/test_trim_modes.py`` checks the two methods against each other where both work.

Longitudinal block: [V (m/s), alpha (rad), theta (rad), q (rad/s)].
Lateral-directional block: [beta (rad), phi (rad), p (rad/s), r (rad/s)].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jsbsim_env.sim.simulation import FT_TO_M, Simulation, TrimResult

LONGITUDINAL_STATES = ("V", "alpha", "theta", "q")
LATERAL_STATES = ("beta", "phi", "p", "r")
# Central-difference steps: 0.01 m/s, about 0.06 deg, 0.06 deg/s.
PERTURBATION = {"V": 0.01, "alpha": 1e-3, "theta": 1e-3, "q": 1e-3, "beta": 1e-3, "phi": 1e-3, "p": 1e-3, "r": 1e-3}


class LinearisationError(RuntimeError):
    """JSBSim's linear model does not have the expected states or modes."""


@dataclass(frozen=True)
class Mode:
    """One mode: a real eigenvalue or a complex pair (the one with positive imaginary part)."""

    name: str
    eigenvalue: complex

    @property
    def oscillatory(self) -> bool:
        return abs(self.eigenvalue.imag) > 1e-9

    @property
    def stable(self) -> bool:
        return self.eigenvalue.real < 0.0

    def as_dict(self) -> dict[str, float | bool | list[float]]:
        lam = self.eigenvalue
        out: dict[str, float | bool | list[float]] = {"eigenvalue": [lam.real, lam.imag], "stable": self.stable}
        if self.oscillatory:
            wn = abs(lam)
            out.update(natural_frequency_radps=wn, damping_ratio=-lam.real / wn,
                       period_s=2.0 * math.pi / abs(lam.imag))
        elif lam.real != 0.0:
            # A real root: time constant if it decays, time to double if it diverges.
            key = "time_constant_s" if lam.real < 0 else "time_to_double_s"
            out[key] = (1.0 if lam.real < 0 else math.log(2.0)) / abs(lam.real)
        return out


def _pairs(eigs: np.ndarray) -> tuple[list[complex], list[float]]:
    """Split eigenvalues into complex pairs (positive imaginary part kept) and real roots."""
    complex_roots = sorted((complex(e) for e in eigs if e.imag > 1e-9), key=abs)
    real_roots = sorted((float(e.real) for e in eigs if abs(e.imag) <= 1e-9), key=abs)
    return complex_roots, real_roots


def classify(a_long: np.ndarray, a_lat: np.ndarray) -> list[Mode]:
    """Name the modes of the longitudinal and lateral 4x4 blocks.

    Longitudinal: the faster pair is the short period, the slower the phugoid (an overdamped short
    period appears as its two fastest real roots). Lateral: the complex pair is the Dutch roll, the
    fastest real root the roll subsidence, the slowest the spiral.
    """
    modes: list[Mode] = []
    pairs, reals = _pairs(np.linalg.eigvals(a_long))
    if len(pairs) == 2:
        modes += [Mode("short_period", pairs[1]), Mode("phugoid", pairs[0])]
    elif len(pairs) == 1 and len(reals) == 2:
        # Overdamped short period: report its slower real root (the one that sets the response).
        modes += [Mode("short_period", complex(reals[0])), Mode("phugoid", pairs[0])]
    else:
        raise LinearisationError(f"longitudinal eigenvalues {np.linalg.eigvals(a_long)} have no phugoid pair")
    pairs, reals = _pairs(np.linalg.eigvals(a_lat))
    if len(pairs) != 1 or len(reals) != 2:
        raise LinearisationError(f"lateral eigenvalues {np.linalg.eigvals(a_lat)} are not a Dutch roll pair "
                                 "and two real roots")
    modes += [Mode("roll", complex(reals[1])), Mode("spiral", complex(reals[0])), Mode("dutch_roll", pairs[0])]
    return modes


def _derivatives(sim: Simulation, trim: TrimResult, state: dict[str, float]) -> dict[str, float]:
    """Time derivatives of the classical states at ``state`` (SI, radians), from JSBSim."""
    sim.set_initial_conditions(
        trim.altitude_m, state["V"], alpha_deg=math.degrees(state["alpha"]),
        pitch_deg=math.degrees(state["theta"]), roll_deg=math.degrees(state["phi"]),
        beta_deg=math.degrees(state["beta"]), rates_radps=(state["p"], state["q"], state["r"]))
    f = sim.fdm
    u, v, w = (f[f"velocities/{c}-fps"] * FT_TO_M for c in "uvw")
    du, dv, dw = (f[f"accelerations/{c}dot-ft_sec2"] * FT_TO_M for c in "uvw")
    speed = math.sqrt(u * u + v * v + w * w)
    speed_dot = (u * du + v * dv + w * dw) / speed
    phi, theta, p, q, r = state["phi"], state["theta"], state["p"], state["q"], state["r"]
    return {
        "V": speed_dot,
        "alpha": (u * dw - w * du) / (u * u + w * w),
        "beta": (speed * dv - v * speed_dot) / (speed * math.sqrt(u * u + w * w)),
        "theta": q * math.cos(phi) - r * math.sin(phi),
        "phi": p + math.tan(theta) * (q * math.sin(phi) + r * math.cos(phi)),
        "p": f["accelerations/pdot-rad_sec2"], "q": f["accelerations/qdot-rad_sec2"],
        "r": f["accelerations/rdot-rad_sec2"],
    }


def linearise(sim: Simulation, trim: TrimResult) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal and lateral-directional system matrices about ``trim`` (central differences).

    Leaves the aircraft at the trimmed state.
    """
    x0 = {"V": trim.airspeed_tas_mps, "alpha": math.radians(trim.alpha_deg), "theta": math.radians(trim.pitch_deg),
          "q": 0.0, "beta": math.radians(trim.beta_deg), "phi": 0.0, "p": 0.0, "r": 0.0}
    blocks = []
    for names in (LONGITUDINAL_STATES, LATERAL_STATES):
        a = np.empty((4, 4))
        for j, name in enumerate(names):
            h = PERTURBATION[name]
            plus = _derivatives(sim, trim, {**x0, name: x0[name] + h})
            minus = _derivatives(sim, trim, {**x0, name: x0[name] - h})
            a[:, j] = [(plus[n] - minus[n]) / (2.0 * h) for n in names]
        blocks.append(a)
    _derivatives(sim, trim, x0)
    return blocks[0], blocks[1]


CONTROLS = ("aileron_deg", "elevator_deg", "rudder_deg", "throttle")
# Central-difference steps of the controls: 1 deg on the surfaces, 0.02 of throttle.
CONTROL_PERTURBATION = (1.0, 1.0, 1.0, 0.02)


def control_derivatives(sim: Simulation, trim: TrimResult) -> tuple[np.ndarray, np.ndarray]:
    """Input matrices about ``trim``: the derivatives of the longitudinal and lateral states (same
    order as ``linearise``) per unit of each control in ``CONTROLS`` (deg, or throttle fraction).

    Each control is held at trim plus or minus its step until the actuators (and the rotors, for
    the throttle) have settled, then the state derivatives are read at the trimmed state. Leaves
    the aircraft at the trimmed state with the trimmed controls.
    """
    x0 = {"V": trim.airspeed_tas_mps, "alpha": math.radians(trim.alpha_deg), "theta": math.radians(trim.pitch_deg),
          "q": 0.0, "beta": math.radians(trim.beta_deg), "phi": 0.0, "p": 0.0, "r": 0.0}
    base = np.array([trim.aileron_deg, trim.elevator_deg, trim.rudder_deg, trim.throttle])
    columns = []
    for j, h in enumerate(CONTROL_PERTURBATION):
        derivs = []
        for sign in (1.0, -1.0):
            u = base.copy()
            u[j] += sign * h
            sim.set_controls(*u)
            sim.settle_actuators()
            derivs.append(_derivatives(sim, trim, x0))
        columns.append({k: (derivs[0][k] - derivs[1][k]) / (2.0 * h) for k in x0})
    sim.set_controls(*base)
    sim.settle_actuators()
    _derivatives(sim, trim, x0)
    b_long = np.array([[col[n] for col in columns] for n in LONGITUDINAL_STATES])
    b_lat = np.array([[col[n] for col in columns] for n in LATERAL_STATES])
    return b_long, b_lat


def linear_modes(sim: Simulation, trim: TrimResult) -> dict[str, dict]:
    """Name the linear modes about ``trim``; the aircraft must be in that trim (just after ``Simulation.trim``)."""
    a_long, a_lat = linearise(sim, trim)
    return {m.name: m.as_dict() for m in classify(a_long, a_lat)}


def jsbsim_linearisation(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The same two blocks from ``jsbsim.FGLinearization`` (slow here; see the module docstring).

    JSBSim's states are in feet and radians; V is converted to m/s. Leaves the time step restored
    but the rotors stopped: trim again before flying.
    """
    import jsbsim

    dt_s = sim.fdm.get_delta_t()
    try:
        lin = jsbsim.FGLinearization(sim.fdm)
    finally:
        sim.fdm.set_dt(dt_s)
    names = tuple(lin.x_names)
    a = np.asarray(lin.system_matrix, dtype=float)
    out = []
    for wanted in (("Vt", "Alpha", "Theta", "Q"), ("Beta", "Phi", "P", "R")):
        idx = [names.index(n) for n in wanted]
        out.append(a[np.ix_(idx, idx)])
    # Vt rows are ft/s^2 per state and columns per ft/s: only the mixed entries change with units.
    out[0][0, 1:] *= FT_TO_M
    out[0][1:, 0] /= FT_TO_M
    return out[0], out[1]


__all__ = ["CONTROLS", "LinearisationError", "Mode", "classify", "control_derivatives", "jsbsim_linearisation",
           "linear_modes", "linearise"]

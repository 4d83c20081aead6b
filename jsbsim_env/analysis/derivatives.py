"""Stability and control derivatives measured through JSBSim itself.

An independent check of the aerodynamic model: instead of reading the tables, the aircraft is
trimmed and placed in perturbed states through JSBSim's initial-condition pass, and the
derivatives are central differences of the total aerodynamic forces and moments JSBSim computes
(``forces/fw*-aero-lbs`` in wind axes, ``moments/*-aero-lbsft`` in body axes about the CG).

Conventions: forces as coefficients in wind axes (CL, CD, CY), moments in body axes (Cl, Cm, Cn),
angles in radians, rates non-dimensional (p b/2V, q c/2V, r b/2V, alpha-dot c/2V), controls per
radian of deflection in the the paper's sign conventions (elevator trailing edge down, rudder trailing
edge left, aileron right surface down).

JSBSim computes alpha-dot from the body accelerations, so every perturbed state also carries an
alpha-dot. Its effect is measured on its own first (states that differ only in bank angle differ
only in the gravity components along the body y and z axes, hence only in beta-dot, which no term
of the model uses, and alpha-dot) and removed from the other differences, so that each derivative
is a partial one.
"""

from __future__ import annotations

import math

import numpy as np

from jsbsim_env.sim.simulation import FT_TO_M, Simulation, TrimResult

# Central-difference half-steps: small enough to stay linear, large enough for JSBSim's round-off.
ANGLE_STEP_RAD = math.radians(0.5)
RATE_HAT_STEP = 0.005
CONTROL_STEP_DEG = 1.0
BANK_FOR_ALPHADOT_DEG = 30.0

COEFFICIENTS = ("CL", "CD", "CY", "Cl", "Cm", "Cn")


def coefficients(sim: Simulation) -> dict[str, float]:
    """Total aerodynamic coefficients of the present state (forces in wind axes, moments in body axes)."""
    f = sim.fdm
    qs = f["aero/qbar-psf"] * f["metrics/Sw-sqft"]
    span, chord = f["metrics/bw-ft"], f["metrics/cbarw-ft"]
    return {"CD": f["forces/fwx-aero-lbs"] / qs, "CY": f["forces/fwy-aero-lbs"] / qs,
            "CL": f["forces/fwz-aero-lbs"] / qs, "Cl": f["moments/l-aero-lbsft"] / (qs * span),
            "Cm": f["moments/m-aero-lbsft"] / (qs * chord), "Cn": f["moments/n-aero-lbsft"] / (qs * span)}


def _alphadot_hat(sim: Simulation) -> float:
    f = sim.fdm
    return f["aero/alphadot-rad_sec"] * f["metrics/cbarw-ft"] / (2.0 * f["velocities/vt-fps"])


def measure(sim: Simulation, altitude_m: float, airspeed_eas_mps: float) -> dict[str, float]:
    """Trim at the condition and return the derivatives (see the module docstring for units).

    Keys: ``<coefficient><variable>`` with variable in ``a`` (alpha), ``b`` (beta), ``p``, ``q``,
    ``r``, ``adot``, ``da`` (aileron), ``de`` (elevator), ``dr`` (rudder); for example ``CLq``,
    ``Cnda``. Leaves the aircraft trimmed.
    """
    trim = sim.trim(altitude_m, airspeed_eas_mps)
    tas = trim.airspeed_tas_mps
    span_m = sim["metrics/bw-ft"] * FT_TO_M
    chord_m = sim["metrics/cbarw-ft"] * FT_TO_M
    rate_per_hat = {"p": 2.0 * tas / span_m, "q": 2.0 * tas / chord_m, "r": 2.0 * tas / span_m}

    def at(alpha_deg=trim.alpha_deg, beta_deg=trim.beta_deg, roll_deg=0.0, rates=(0.0, 0.0, 0.0)) -> tuple[dict, float]:
        sim.set_initial_conditions(altitude_m, tas, alpha_deg=alpha_deg, pitch_deg=trim.pitch_deg,
                                   roll_deg=roll_deg, beta_deg=beta_deg, rates_radps=rates)
        return coefficients(sim), _alphadot_hat(sim)

    def difference(plus: tuple[dict, float], minus: tuple[dict, float], step: float,
                   alphadot: dict[str, float] | None) -> dict[str, float]:
        d_adot = plus[1] - minus[1]
        return {c: (plus[0][c] - minus[0][c] - (alphadot[c] * d_adot if alphadot else 0.0)) / step
                for c in COEFFICIENTS}

    out: dict[str, float] = {}
    # Alpha-dot first: only the gravity component, hence only alpha-dot, differs between banks.
    level, banked = at(), at(roll_deg=BANK_FOR_ALPHADOT_DEG)
    d_adot = banked[1] - level[1]
    alphadot = {c: (banked[0][c] - level[0][c]) / d_adot for c in COEFFICIENTS}
    out.update({f"{c}adot": v for c, v in alphadot.items()})

    step_deg = math.degrees(ANGLE_STEP_RAD)
    d = difference(at(alpha_deg=trim.alpha_deg + step_deg), at(alpha_deg=trim.alpha_deg - step_deg),
                   2.0 * ANGLE_STEP_RAD, alphadot)
    out.update({f"{c}a": v for c, v in d.items()})
    d = difference(at(beta_deg=trim.beta_deg + step_deg), at(beta_deg=trim.beta_deg - step_deg), 2.0 * ANGLE_STEP_RAD,
                   alphadot)
    out.update({f"{c}b": v for c, v in d.items()})
    for k, axis in enumerate("pqr"):
        rates = [0.0, 0.0, 0.0]
        rates[k] = RATE_HAT_STEP * rate_per_hat[axis]
        plus = at(rates=tuple(rates))
        rates[k] = -rates[k]
        d = difference(plus, at(rates=tuple(rates)), 2.0 * RATE_HAT_STEP, alphadot)
        out.update({f"{c}{axis}": v for c, v in d.items()})
    out.update(_control_derivatives(sim, trim, alphadot))
    sim.trim(altitude_m, airspeed_eas_mps)  # leave it trimmed, actuators included
    return out


def _control_derivatives(sim: Simulation, trim: TrimResult, alphadot: dict[str, float]) -> dict[str, float]:
    base = [trim.aileron_deg, trim.elevator_deg, trim.rudder_deg]
    out = {}
    for k, name in enumerate(("da", "de", "dr")):
        measured = []
        for sign in (1.0, -1.0):
            surfaces = list(base)
            surfaces[k] += sign * CONTROL_STEP_DEG
            sim.place_with_controls(trim.altitude_m, trim.airspeed_tas_mps, trim.alpha_deg, *surfaces, trim.throttle,
                                    beta_deg=trim.beta_deg)
            measured.append((coefficients(sim), _alphadot_hat(sim)))
        d_adot = measured[0][1] - measured[1][1]
        step_rad = math.radians(2.0 * CONTROL_STEP_DEG)
        out.update({f"{c}{name}": (measured[0][0][c] - measured[1][0][c] - alphadot[c] * d_adot) / step_rad
                    for c in COEFFICIENTS})
    return out


def to_stability_axes(derivs: dict[str, float], alpha_rad: float) -> dict[str, float]:
    """Rolling and yawing-moment derivatives with respect to sideslip and the controls, rotated
    from body to stability axes (x along the projection of the airflow):
    Cl_s = Cl cos a + Cn sin a, Cn_s = Cn cos a - Cl sin a. (Rate derivatives would need the rates
    rotated too, and are left out.)"""
    ca, sa = math.cos(alpha_rad), math.sin(alpha_rad)
    out = {}
    for variable in ("b", "da", "de", "dr"):
        cl, cn = derivs["Cl" + variable], derivs["Cn" + variable]
        out["Cl" + variable] = cl * ca + cn * sa
        out["Cn" + variable] = cn * ca - cl * sa
    return out


def aileron_step_adverse_yaw(sim: Simulation, altitude_m: float, airspeed_eas_mps: float,
                             aileron_deg: float = 5.0, duration_s: float = 4.0) -> dict[str, float]:
    """Hold an aileron step from trim and return the largest yaw rate against the roll (deg/s).

    Adverse yaw turns the nose away from the roll until the sideslip it builds up turns it back.
    Also returns the roll rate at that moment and the time it happens.
    """
    trim = sim.trim(altitude_m, airspeed_eas_mps)
    sim.set_controls(trim.aileron_deg + aileron_deg, trim.elevator_deg, trim.rudder_deg, trim.throttle)
    f = sim.fdm
    p, r = [], []
    for _ in range(round(duration_s / sim.dt_s)):
        f.run()
        p.append(f["velocities/p-rad_sec"])
        r.append(f["velocities/r-rad_sec"])
    p_degps, r_degps = np.degrees(p), np.degrees(r)
    roll_sign = np.sign(np.mean(p_degps))
    against = -roll_sign * r_degps
    i = int(np.argmax(against))
    return {"adverse_yaw_rate_degps": float(against[i]), "roll_rate_degps": float(abs(p_degps[i])),
            "time_s": float((i + 1) * sim.dt_s)}

"""Actuator effectiveness against altitude at a fixed equivalent airspeed (the paper's Fig. 10).

At each altitude the aircraft is trimmed; then, at the trimmed state,

* the control moment per degree of each surface (aileron -> roll, elevator -> pitch,
  rudder -> yaw) is its control derivative measured through JSBSim (central differences of the
  aerodynamic moment over +-1 deg, ``jsbsim_env.analysis.derivatives``);
* the rate authority per degree is that moment over the axis inertia, divided by the axis's
  rate damping (Lp, Mq, Nr from ``jsbsim_env.analysis.modes.linearise``): the steady rate one degree holds
  against the damping, which sets how fast the attitude follows;
* the thrust available is the total thrust at full throttle at the trimmed airspeed.

At a fixed EAS the dynamic pressure is fixed, so the moments change only through Reynolds and
Mach number; the damping falls as 1/TAS, so the rate authority grows with altitude while the
power-limited thrust falls.
"""

from __future__ import annotations

import math

import numpy as np

from jsbsim_env.analysis import derivatives
from jsbsim_env.analysis.modes import linearise
from jsbsim_env.sim.simulation import FT_TO_M, Simulation

FT_LBF_TO_N_M = 1.3558179483314
PSF_TO_PA = 47.880258889
SURFACE_AXES = {"aileron": ("Clda", "bw-ft", 0), "elevator": ("Cmde", "cbarw-ft", 1), "rudder": ("Cndr", "bw-ft", 2)}


def effectiveness_at(sim: Simulation, altitude_m: float, airspeed_eas_mps: float = 10.0) -> dict[str, float]:
    """Effectiveness figures at one altitude (SI units; see the module docstring).

    The moments per degree are the surfaces' own control derivatives measured through JSBSim
    (``jsbsim_env.analysis.derivatives``, the alpha-dot a deflection causes set apart).
    """
    control = derivatives.measure(sim, altitude_m, airspeed_eas_mps)
    trim = sim.trim(altitude_m, airspeed_eas_mps)
    a_long, a_lat = linearise(sim, trim)
    damping = {"aileron": -a_lat[2, 2], "elevator": -a_long[3, 3], "rudder": -a_lat[3, 3]}  # 1/s
    inertia = np.diag(np.asarray(sim.fdm.get_mass_balance().get_J())) * FT_LBF_TO_N_M  # kg m^2
    qbar_s = sim["aero/qbar-psf"] * PSF_TO_PA * sim["metrics/Sw-sqft"] * FT_TO_M**2
    out = {"altitude_m": altitude_m, "airspeed_tas_mps": trim.airspeed_tas_mps}
    for surface, (name, length, k) in SURFACE_AXES.items():
        moment = control[name] * qbar_s * sim[f"metrics/{length}"] * FT_TO_M * math.pi / 180.0
        out[f"{surface}_moment_nm_per_deg"] = float(moment)
        out[f"{surface}_rate_degps_per_deg"] = float(math.degrees(moment / inertia[k] / damping[surface]))
    sim.place_with_controls(altitude_m, trim.airspeed_tas_mps, trim.alpha_deg, trim.aileron_deg, trim.elevator_deg,
                            trim.rudder_deg, 1.0, beta_deg=trim.beta_deg)
    out["thrust_full_throttle_n"] = sim.thrust_n()
    out["thrust_trim_n"] = trim.thrust_n
    sim.trim(altitude_m, airspeed_eas_mps)
    return out


def effectiveness(altitudes_m, airspeed_eas_mps: float = 10.0, aircraft=None) -> list[dict[str, float]]:
    """``effectiveness_at`` for every altitude of ``aircraft`` (the paper's by default), each figure
    also normalised to the first altitude."""
    sim = Simulation(aircraft)
    rows = [effectiveness_at(sim, h, airspeed_eas_mps) for h in altitudes_m]
    for row in rows:
        for key in [k for k in row if k.endswith(("_per_deg", "_n"))]:
            row[f"{key}_normalised"] = row[key] / rows[0][key]
    return rows


PANELS = (("aileron", "roll"), ("elevator", "pitch"), ("rudder", "yaw"))


def plot_effectiveness(rows: list[dict], path) -> None:
    """The paper's Fig. 10 from ``effectiveness`` rows, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h_km = np.array([r["altitude_m"] for r in rows]) / 1000.0
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for ax, (surface, axis), letter in zip(axes.flat, PANELS, "abc"):
        ax.plot(h_km, [r[f"{surface}_moment_nm_per_deg_normalised"] for r in rows], "o-",
                label=f"{axis} moment per degree")
        ax.plot(h_km, [r[f"{surface}_rate_degps_per_deg_normalised"] for r in rows], "s--",
                label=f"steady {axis} rate per degree")
        ax.set_title(f"({letter}) {surface}")
    ax = axes.flat[3]
    ax.plot(h_km, [r["thrust_full_throttle_n_normalised"] for r in rows], "o-", label="thrust at full throttle")
    ax.plot(h_km, [r["thrust_trim_n_normalised"] for r in rows], "s--", label="thrust in trim (= drag)")
    ax.set_title("(d) propulsion")
    for ax in axes.flat:
        ax.axhline(1.0, color="0.6", lw=0.8)
        ax.set_ylabel("relative to 0 km")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("altitude, km")
    fig.suptitle("Actuator effectiveness against altitude, EAS 10 m/s")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)

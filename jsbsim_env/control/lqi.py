"""Gain-scheduled discrete LQI attitude controller: the model-based baseline beside the PID.

Designed on the package's own linear models (``tuning.LinearPlant``: ``jsbsim_env.analysis.modes``'s
linearisation and control derivatives) at each altitude of ``pid.DESIGN_ALTITUDES_M`` at EAS 10 m/s,
per block, at the design control rate (25 Hz, zero-order hold, ``tuning.discretise``):

| block | augmented state | inputs |
|---|---|---|
| longitudinal | V, alpha, theta, q; elevator and throttle actuators (first-order lags); the delayed command (one step); integrals of the pitch and EAS errors | elevator, throttle |
| lateral | beta, phi, p, r; aileron and rudder actuators; the delayed command; integrals of the roll and sideslip errors | aileron, rudder |

The gains come from the discrete algebraic Riccati equation (``scipy.linalg.solve_discrete_are``)
with Bryson's-rule weights (``LONG_MAX_STATE`` ..., the inverse squares of acceptable sizes in the
units stated there). Two degrees of freedom: the steady state (states and inputs) for the reference
is solved from the discrete model, so the command is

    u = u_ss(r) - K_x (x - x_ss(r)) - K_u (u_prev - u_ss(r)) - K_z z

and a step is not left to the integrators. The design must pass the PID's robustness cases
(``tuning``: stable with every gain doubled and with two more steps of delay, analysed with
``tuning.closed_loop``); where the plain design fails them, R is raised (x2 at a time) until it
passes, and the factor is recorded. ``scripts/tune_lqi.py`` writes the table, with the verified
spectral radii, to ``lqi_gains.json``.

In flight the gains are interpolated in altitude; the surface channels are normalised by
q_s = (10 m/s / V_eas)^2 as the PID's gains are (the model's surface input is q_s times
smaller; its command is q_s times larger). Each integrator stops while the actuator it mainly drives
(pitch: elevator, EAS: throttle, roll: aileron, sideslip: rudder) is saturated in the direction it
would push, and is bounded so that it alone cannot move that actuator more than the PID's integrator
limits. The actuator states are the measured positions; the delay state is the previous command.
"""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from pathlib import Path

import numpy as np

from aircraft import load_aircraft
from jsbsim_env.control import gain_files, tuning
from jsbsim_env.control.pid import (
    DESIGN_ALTITUDES_M,
    DESIGN_EAS_MPS,
    MIN_EAS_FOR_SCALING_MPS,
    SURFACE_INTEGRATOR_LIMIT_DEG,
    THROTTLE_INTEGRATOR_LIMIT,
    altitude_points,
    check_trims,
    design_eas_of,
    read_gain_file,
)
from jsbsim_env.sim.simulation import Simulation

GAINS_PATH = gain_files.PACKAGED_DIR / gain_files.FILES["lqi"]  # the paper's aircraft's
DT_S = 1.0 / tuning.CONTROL_RATE_HZ

# Bryson's rule: Q_ii = 1 / (acceptable size)^2, R_jj = 1 / (acceptable input)^2.
# Longitudinal state: V_tas m/s, alpha rad, theta rad, q rad/s, elevator deg, throttle (actuators),
# elevator deg, throttle (delayed command), pitch-error integral rad s, EAS-error integral m.
LONG_MAX_STATE = (1.0, math.radians(2.0), math.radians(1.0), math.radians(5.0), math.inf, math.inf,
                  math.inf, math.inf, math.radians(1.0), 1.0)
LONG_MAX_INPUT = (5.0, 0.2)  # elevator deg, throttle
# Lateral state: beta rad, phi rad, p rad/s, r rad/s, aileron deg, rudder deg (actuators), the same
# delayed, roll-error integral rad s, sideslip-error integral rad s.
LAT_MAX_STATE = (math.radians(1.0), math.radians(1.0), math.radians(10.0), math.radians(5.0), math.inf, math.inf,
                 math.inf, math.inf, math.radians(1.0), math.radians(3.0))
LAT_MAX_INPUT = (5.0, 5.0)  # aileron deg, rudder deg
DETUNE_FACTOR = 2.0  # R times this per detuning pass
MAX_DETUNE_PASSES = 12
STABLE_RADIUS = 0.999  # the PID tuning's bound on the spectral radius


def bryson_sizes() -> dict[str, tuple[float, ...]]:
    """The acceptable sizes of the shipped design (``LONG_MAX_STATE`` ...), by the gain table's key."""
    return {"long_max_state": LONG_MAX_STATE, "long_max_input": LONG_MAX_INPUT,
            "lat_max_state": LAT_MAX_STATE, "lat_max_input": LAT_MAX_INPUT}


class RobustnessError(RuntimeError):
    """An LQI design that fails the robustness cases (and is not to be detuned)."""


def _weights(max_values) -> np.ndarray:
    return np.diag([0.0 if math.isinf(v) else 1.0 / v ** 2 for v in max_values])


class BlockDesign:
    """One block (``lateral`` or longitudinal) of a plant: its discrete model, LQI gains, feedforward
    and robustness. The measured outputs y are the six plant and actuator states, with V as EAS;
    the integrated (and tracked) outputs are pitch and EAS, or roll and sideslip."""

    def __init__(self, plant: tuning.LinearPlant, lateral: bool, dt_s: float = DT_S, r_factor: float = 1.0,
                 feedforward: bool = True, sizes: dict | None = None):
        """``sizes``: Bryson's acceptable sizes by the keys of ``bryson_sizes`` (default: those)."""
        self.lateral, self.dt_s = lateral, dt_s
        sizes = bryson_sizes() if sizes is None else sizes
        if lateral:
            a, b, lags = plant.a_lat, plant.b_lat[:, [0, 2]], (tuning.SURFACE_LAG_S, tuning.SURFACE_LAG_S)
            self.c_y = np.eye(6)
            tracked = (1, 0)  # phi, beta
            q, r = _weights(sizes["lat_max_state"]), _weights(sizes["lat_max_input"])
        else:
            a, b, lags = plant.a_long, plant.b_long[:, [1, 3]], (tuning.SURFACE_LAG_S, tuning.THROTTLE_LAG_S)
            self.c_y = np.diag([plant.eas_mps / plant.tas_mps, 1.0, 1.0, 1.0, 1.0, 1.0])
            tracked = (2, 0)  # theta, V_eas
            q, r = _weights(sizes["long_max_state"]), _weights(sizes["long_max_input"])
        self.ad, self.bd = tuning.discretise(a, b, lags, dt_s)
        self.c_z = self.c_y[list(tracked)]  # tracked outputs from the 6 states (2 x 6)
        self.r_factor = r_factor

        # Augmented: s = [x (6), u_prev (2), z (2)]; u_prev+ = u; z+ = z + dt (C_z x - ref).
        aa = np.zeros((10, 10))
        aa[:6, :6], aa[:6, 6:8] = self.ad, self.bd
        aa[8:, :6], aa[8:, 8:] = dt_s * self.c_z, np.eye(2)
        ba = np.zeros((10, 2))
        ba[6:8] = np.eye(2)
        from scipy.linalg import solve_discrete_are  # here, not at the top: importing the package stays light
        rr = r * r_factor
        p = solve_discrete_are(aa, ba, q, rr)
        self.k = np.linalg.solve(rr + ba.T @ p @ ba, ba.T @ p @ aa)  # u = -K s

        # Steady state for the tracked references: x = A x + B u, C_z x = ref.
        m = np.zeros((8, 8))
        m[:6, :6], m[:6, 6:] = self.ad - np.eye(6), self.bd
        m[6:, :6] = self.c_z
        sol = np.linalg.solve(m, np.vstack([np.zeros((6, 2)), np.eye(2)]))
        self.nx, self.nu = sol[:6], sol[6:]
        kx, ku = self.k[:, :6], self.k[:, 6:8]
        self.n_ff = (self.nu + kx @ self.nx + ku @ self.nu) if feedforward else np.zeros((2, 2))
        # Gains on the measured outputs (V as EAS): K_x x = K_y y with y = c_y x.
        self.k_y = kx @ np.linalg.inv(self.c_y)

    def controller(self) -> tuning.LinearController:
        """The law as ``tuning.LinearController``: states [u_prev (2), z (2)], y the six states, r the
        two tracked references. ``scaled`` then scales the command (the loop gain) but not what the
        controller remembers of it, as a gain error at the plant input would."""
        ku, kz = self.k[:, 6:8], self.k[:, 8:]
        cc = np.hstack([-ku, -kz])
        ac = np.zeros((4, 4))
        ac[:2], ac[2:, 2:] = cc, np.eye(2)
        bc = np.vstack([-self.k_y, self.dt_s * self.c_z @ np.linalg.inv(self.c_y)])
        br = np.vstack([self.n_ff, -self.dt_s * np.eye(2)])
        return tuning.LinearController(ac, bc, br, cc, -self.k_y, self.n_ff)

    def closed(self, delay_steps: int = tuning.DESIGN_DELAY_STEPS, factor: float = 1.0):
        return tuning.closed_loop(self.ad, self.bd, self.c_y, self.controller().scaled(factor), delay_steps)

    def radii(self) -> dict:
        """Spectral radii: nominal, every gain doubled, two more steps of delay."""
        return {"nominal": tuning.spectral_radius(self.closed()[0]),
                "gain_x2": tuning.spectral_radius(self.closed(factor=tuning.ROBUST_GAIN_FACTOR)[0]),
                "delay_plus2": tuning.spectral_radius(
                    self.closed(tuning.DESIGN_DELAY_STEPS + tuning.ROBUST_EXTRA_DELAY_STEPS)[0])}


def robust_block(plant: tuning.LinearPlant, lateral: bool, dt_s: float = DT_S, sizes: dict | None = None,
                 detune: bool = True) -> BlockDesign:
    """The LQI design of one block, with R raised until the robustness cases pass; without
    ``detune``, the plain design or ``RobustnessError``."""
    factor = 1.0
    for _ in range(MAX_DETUNE_PASSES + 1 if detune else 1):
        design = BlockDesign(plant, lateral, dt_s, r_factor=factor, sizes=sizes)
        if max(design.radii().values()) < STABLE_RADIUS:
            return design
        factor *= DETUNE_FACTOR
    block = f"LQI design at {plant.altitude_m:g} m ({'lateral' if lateral else 'longitudinal'})"
    if not detune:
        raise RobustnessError(f"{block} fails the robustness cases (gain x2, +2 delay steps) with its R (not detuned)")
    raise RobustnessError(f"{block} meets the robustness cases at no R tried")


# Names of the stored columns, in the order update() reads them.
GAIN_COLUMNS = (
    [f"long_k_{i}{j}" for i in range(2) for j in range(10)] + [f"long_ff_{i}{j}" for i in range(2) for j in range(2)]
    + [f"lat_k_{i}{j}" for i in range(2) for j in range(10)] + [f"lat_ff_{i}{j}" for i in range(2) for j in range(2)]
    + ["elevator_trim_deg", "throttle_trim", "pitch_trim_deg", "alpha_trim_deg"])


def design_point(sim: Simulation, altitude_m: float, eas_mps: float = DESIGN_EAS_MPS, sizes: dict | None = None,
                 detune: bool = True) -> dict:
    """Both blocks at one flight condition: a row of the gain table, with the margins verified
    (``sizes`` and ``detune`` as ``robust_block``'s)."""
    plant = tuning.LinearPlant.at(sim, altitude_m, eas_mps)
    trim = sim.trim(altitude_m, eas_mps)
    long_d = robust_block(plant, lateral=False, sizes=sizes, detune=detune)
    lat_d = robust_block(plant, lateral=True, sizes=sizes, detune=detune)
    row = {"altitude_m": float(altitude_m)}
    for prefix, d in (("long", long_d), ("lat", lat_d)):
        row.update({f"{prefix}_k_{i}{j}": float(d.k_y[i, j] if j < 6 else d.k[i, j]) for i in range(2) for j in range(10)})
        row.update({f"{prefix}_ff_{i}{j}": float(d.n_ff[i, j]) for i in range(2) for j in range(2)})
    row.update({"elevator_trim_deg": float(plant.elevator_trim_deg), "throttle_trim": float(plant.throttle_trim),
                "pitch_trim_deg": float(plant.pitch_trim_deg), "alpha_trim_deg": float(trim.alpha_deg)})
    row["margins"] = {"long": {**long_d.radii(), "r_factor": long_d.r_factor},
                      "lat": {**lat_d.radii(), "r_factor": lat_d.r_factor}}
    return row


def gain_table(sim: Simulation, altitudes_m=DESIGN_ALTITUDES_M, progress=None, sizes: dict | None = None,
               detune: bool = True, eas_mps: float = DESIGN_EAS_MPS) -> dict:
    """The gain table (``write_gain_table``'s layout) designed at every altitude at ``eas_mps`` with
    Bryson's ``sizes`` (default: ``bryson_sizes()``); ``detune`` as ``robust_block``'s."""
    sizes = bryson_sizes() if sizes is None else sizes
    rows = []
    for h in altitudes_m:
        rows.append(design_point(sim, h, eas_mps, sizes=sizes, detune=detune))
        if progress:
            progress(rows[-1])
    return {"controller": "lqi", "design_eas_mps": float(eas_mps), "control_rate_hz": tuning.CONTROL_RATE_HZ,
            "method": "jsbsim_env.control.lqi", **{k: tuple(v) for k, v in sizes.items()}, "points": rows}


def write_gain_table(path: Path = GAINS_PATH, altitudes_m=DESIGN_ALTITUDES_M, progress=None, aircraft=None,
                     eas_mps: float = DESIGN_EAS_MPS) -> dict:
    """Design ``aircraft`` (the paper's by default) at every altitude at ``eas_mps`` and write the
    table as JSON; returns it."""
    table = gain_table(Simulation(aircraft), altitudes_m, progress, eas_mps=eas_mps)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(table, indent=1))  # inf is written as Infinity, which json reads back
    tmp.replace(path)
    return table


class LQIGainSchedule:
    """The stored LQI table (``GAIN_COLUMNS``), interpolated linearly in altitude, held beyond its ends."""

    def __init__(self, path: Path | str = GAINS_PATH):
        self._load(read_gain_file(path, "LQI"), path)

    @classmethod
    def from_table(cls, table: dict, source: str = "(in memory)") -> LQIGainSchedule:
        """The schedule of a gain table already read (``gain_table``'s layout); ``source`` names it
        in errors."""
        schedule = cls.__new__(cls)
        schedule._load(table, source)
        return schedule

    def _load(self, table: dict, path: Path | str) -> None:
        self.altitudes_m, self.values = altitude_points(table, GAIN_COLUMNS, path, "LQI")
        self.design_eas_mps = design_eas_of(table, path, "LQI")
        check_trims(table, path, "LQI")
        self.margins = [p.get("margins") for p in table["points"]]
        self._altitudes = self.altitudes_m.tolist()
        self._rows = self.values.tolist()

    def at(self, altitude_m: float) -> list[float]:
        alts, x = self._altitudes, float(altitude_m)
        if not x < alts[-1]:  # beyond the top, or NaN (rejected before)
            return self._rows[-1]
        if x <= alts[0]:
            return self._rows[0]
        j = bisect_right(alts, x) - 1
        w = (x - alts[j]) / (alts[j + 1] - alts[j])
        lo, hi = self._rows[j], self._rows[j + 1]
        return [a + w * (b - a) for a, b in zip(lo, hi)]


_N_LONG = 24  # columns of the longitudinal block (K 2x10, feedforward 2x2)


def _block(g: list[float], base: int, y: tuple, u_prev: tuple, z: tuple, ref: tuple) -> tuple[float, float]:
    """u_i = -K_i [y, u_prev, z] + ff_i ref for i = 0, 1 (row-major K 2x10, ff 2x2 from ``base``)."""
    s = y + u_prev + z
    out = []
    for i in range(2):
        k = g[base + 10 * i: base + 10 * i + 10]
        ff = g[base + 20 + 2 * i: base + 22 + 2 * i]
        out.append(-sum(a * b for a, b in zip(k, s)) + ff[0] * ref[0] + ff[1] * ref[1])
    return out[0], out[1]


class LQIAttitudeController:
    """Gain-scheduled LQI with reference feedforward (module docstring); the
    ``controllers.base.AttitudeController`` interface."""

    def __init__(self, schedule: LQIGainSchedule | None = None, feedforward: bool = True,
                 gains_path: Path | str | None = None, aircraft=None):
        """``schedule``, or the gain table at ``gains_path`` (a tuned one), or ``aircraft``'s table
        (``gain_files.gain_file``; the paper's aircraft's ``lqi_gains.json`` by default). Commands
        are clipped to ``aircraft``'s travel (the paper's aircraft's by default), whichever table flies."""
        if schedule is not None and gains_path is not None:
            raise ValueError("give a schedule or a gain file, not both")
        self.schedule = schedule or LQIGainSchedule(gain_files.gain_file("lqi", aircraft) if gains_path is None
                                                    else gains_path)
        flown = load_aircraft(aircraft)
        self._command_low, self._command_high = list(flown.command_low), list(flown.command_high)
        self.feedforward = feedforward
        self.reset()

    def reset(self) -> None:
        self.z_pitch = self.z_eas = self.z_roll = self.z_beta = 0.0  # rad s, m, rad s, rad s
        self.last_command: list[float] | None = None

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"control interval must be positive and finite, got {dt_s}")
        m = [float(v) for v in measurement]
        sp = [float(v) for v in setpoint]
        if len(m) != 13 or len(sp) != 3 or not all(math.isfinite(v) for v in m + sp):
            raise ValueError(f"measurement (13,) and setpoint (3,) must be finite; got {measurement} and {setpoint}")
        alt, roll, pitch, p, q, r, eas, alpha, beta, ail, elev, rud, thr = m
        g = self.schedule.at(alt)
        e_trim, t_trim, th_trim, a_trim = g[-4], g[-3], math.radians(g[-2]), math.radians(g[-1])
        v_design = self.schedule.design_eas_mps
        q_s = (v_design / max(eas, MIN_EAS_FOR_SCALING_MPS)) ** 2
        deg = 180.0 / math.pi
        last = self.last_command or [0.0, e_trim, 0.0, t_trim]
        ff = 1.0 if self.feedforward else 0.0

        # Surface channels in the model's units: deflection from trim over q_s.
        elev_cmd, thr_cmd = _block(
            g, 0, (eas - v_design, alpha - a_trim, pitch - th_trim, q, (elev * deg - e_trim) / q_s, thr - t_trim),
            ((last[1] - e_trim) / q_s, last[3] - t_trim), (self.z_pitch, self.z_eas),
            (ff * (sp[1] - th_trim), ff * (sp[2] - v_design)))
        ail_cmd, rud_cmd = _block(g, _N_LONG, (beta, roll, p, r, ail * deg / q_s, rud * deg / q_s),
                                  (last[0] / q_s, last[2] / q_s), (self.z_roll, self.z_beta), (ff * sp[0], 0.0))
        raw = [q_s * ail_cmd, e_trim + q_s * elev_cmd, q_s * rud_cmd, t_trim + thr_cmd]
        clipped = [min(max(v, a), b) for v, a, b in zip(raw, self._command_low, self._command_high)]

        # Anti-windup: each integrator against the actuator its own gain drives (the diagonal of K_z).
        lim_s, lim_t = SURFACE_INTEGRATOR_LIMIT_DEG / q_s, THROTTLE_INTEGRATOR_LIMIT
        self.z_pitch = _integrate(self.z_pitch, (pitch - sp[1]) * dt_s, -g[8], raw[1], clipped[1], lim_s)
        self.z_eas = _integrate(self.z_eas, (eas - sp[2]) * dt_s, -g[19], raw[3], clipped[3], lim_t)
        self.z_roll = _integrate(self.z_roll, (roll - sp[0]) * dt_s, -g[_N_LONG + 8], raw[0], clipped[0], lim_s)
        self.z_beta = _integrate(self.z_beta, beta * dt_s, -g[_N_LONG + 19], raw[2], clipped[2], lim_s)
        self.last_command = clipped
        return np.array(clipped)


def _integrate(state: float, increment: float, gain: float, command: float, clipped: float, limit: float) -> float:
    """``state + increment`` unless that pushes (through ``gain``, command per unit state) an actuator
    saturated that way; bounded so that ``|gain * state| <= limit``."""
    push = gain * increment
    if (command > clipped and push > 0.0) or (command < clipped and push < 0.0):
        return state
    bound = limit / abs(gain) if gain != 0.0 else math.inf
    return min(max(state + increment, -bound), bound)


__all__ = ["GAINS_PATH", "GAIN_COLUMNS", "BlockDesign", "LQIAttitudeController", "LQIGainSchedule", "RobustnessError",
           "bryson_sizes", "design_point", "gain_table", "robust_block", "write_gain_table"]

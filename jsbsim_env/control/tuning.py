"""Tuning the PID baseline on this aircraft's linear models.

At a design point (altitude, EAS) the aircraft is trimmed and linearised on JSBSim's equations
(``jsbsim_env.analysis.modes``: the longitudinal and lateral-directional 4x4 blocks and their input
columns). Each block gets the actuators as first-order lags (the paper's Eq. 11), is discretised with a
zero-order hold at the controller's rate, and is closed with the discrete PID laws of
``pid.PIDAttitudeController`` and a transport delay of whole control steps. The gains minimise

* the integral of time-weighted absolute error (ITAE) of reference steps: 2 deg of pitch and
  1 m/s of EAS for the longitudinal loops, 5 deg of roll for the lateral ones, with the
  sideslip of the roll step weighted in too;
* plus the actuator motion the sensor noise of the paper's Table 3 would cause through the gains, so
  that rate gains do not grow without bound,

subject to robustness: the closed loop stays stable (spectral radius below 1) with every gain
doubled (6 dB gain margin) and with two more control steps of delay (80 ms at 25 Hz). Gains are
searched in the logarithm of their size by Nelder-Mead from a hand-set start; the sideslip gain
may take either sign.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jsbsim_env.analysis.modes import control_derivatives, linearise
from jsbsim_env.sim.simulation import Simulation

SURFACE_LAG_S = 0.02  # the paper's Eq. 11
THROTTLE_LAG_S = 0.2
WASHOUT_S = 2.0  # yaw damper washout: it damps the Dutch roll but lets steady turns be
CONTROL_RATE_HZ = 25.0
DESIGN_DELAY_STEPS = 1  # one control step of transport delay in the design model
ROBUST_EXTRA_DELAY_STEPS = 2
ROBUST_GAIN_FACTOR = 2.0
STEP_PITCH_RAD = math.radians(2.0)
STEP_EAS_MPS = 1.0
STEP_ROLL_RAD = math.radians(5.0)
RESPONSE_S = 20.0
NOISE_RAD = 1e-3  # the paper's Table 3: attitude, rate and flow-angle noise sigma
NOISE_EAS_MPS = 0.01
NOISE_WEIGHT = 20.0  # cost per deg (or per 0.1 throttle) of noise-driven command
SIDESLIP_WEIGHT = 0.5  # cost per deg s of sideslip during the roll step, against roll ITAE

# Longitudinal gains: pitch (deg per rad), pitch rate (deg per rad/s), pitch integral (deg per
# rad s), EAS (throttle per m/s), EAS integral (throttle per m s). Names as in ``pid.DesignPoint``.
LONG_GAIN_NAMES = ("k_pitch", "k_q", "k_pitch_i", "k_eas", "k_eas_i")
LONG_START = np.array([150.0, 40.0, 30.0, 0.1, 0.02])
# Lateral gains: roll (deg per rad), roll rate (deg per rad/s), roll integral (deg per rad s),
# yaw-rate damper (deg per rad/s), sideslip (deg per rad, either sign).
LAT_GAIN_NAMES = ("k_roll", "k_p", "k_roll_i", "k_r", "k_beta")
LAT_START = np.array([150.0, 20.0, 20.0, 100.0, -50.0])


@dataclass(frozen=True)
class LinearPlant:
    """Linear models about one trim (SI units, radians; controls per deg or per throttle)."""

    altitude_m: float
    eas_mps: float
    tas_mps: float
    a_long: np.ndarray  # states V (TAS), alpha, theta, q
    b_long: np.ndarray  # columns aileron, elevator, rudder, throttle
    a_lat: np.ndarray  # states beta, phi, p, r
    b_lat: np.ndarray
    elevator_trim_deg: float
    throttle_trim: float
    pitch_trim_deg: float

    @classmethod
    def at(cls, sim: Simulation, altitude_m: float, eas_mps: float) -> LinearPlant:
        trim = sim.trim(altitude_m, eas_mps)
        a_long, a_lat = linearise(sim, trim)
        b_long, b_lat = control_derivatives(sim, trim)
        return cls(altitude_m, eas_mps, trim.airspeed_tas_mps, a_long, b_long, a_lat, b_lat,
                   trim.elevator_deg, trim.throttle, trim.pitch_deg)


def discretise(a: np.ndarray, b: np.ndarray, lags_s: tuple[float, ...], dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Plant with first-order actuators (states: plant, then actuator positions), zero-order hold."""
    from scipy.linalg import expm  # here, not at the top: importing the package stays light
    n, m = b.shape
    ac = np.zeros((n + m, n + m))
    ac[:n, :n] = a
    ac[:n, n:] = b
    bc = np.zeros((n + m, m))
    for j, lag in enumerate(lags_s):
        ac[n + j, n + j] = -1.0 / lag
        bc[n + j, j] = 1.0 / lag
    # Zero-order hold through the exponential of the augmented matrix.
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[: n + m, : n + m] = ac
    big[: n + m, n + m:] = bc
    e = expm(big * dt_s)
    return e[: n + m, : n + m], e[: n + m, n + m:]


@dataclass(frozen=True)
class LinearController:
    """c+ = Ac c + Bc y + Br r;  u = Cc c + Dc y + Dr r  (discrete, one control step)."""

    ac: np.ndarray
    bc: np.ndarray
    br: np.ndarray
    cc: np.ndarray
    dc: np.ndarray
    dr: np.ndarray

    def scaled(self, factor: float) -> LinearController:
        """Every gain (the output equations) times ``factor``."""
        return LinearController(self.ac, self.bc, self.br, self.cc * factor, self.dc * factor, self.dr * factor)


def longitudinal_controller(gains: np.ndarray, dt_s: float) -> LinearController:
    """The longitudinal PID laws on y = [V_eas, alpha, theta, q], r = [theta_cmd, V_eas_cmd],
    u = [elevator deg, throttle], integrator states [int(theta - theta_cmd), int(V_eas - V_cmd)].
    Positive elevator pitches the nose down, so a pitch above its command gives positive elevator."""
    k_th, k_q, k_thi, k_v, k_vi = gains
    ac = np.eye(2)
    bc = np.zeros((2, 4))
    bc[0, 2] = dt_s
    bc[1, 0] = dt_s
    br = -dt_s * np.eye(2)
    cc = np.array([[k_thi, 0.0], [0.0, -k_vi]])
    dc = np.zeros((2, 4))
    dc[0, 2], dc[0, 3] = k_th, k_q
    dc[1, 0] = -k_v
    dr = np.array([[-k_th, 0.0], [0.0, k_v]])
    return LinearController(ac, bc, br, cc, dc, dr)


def lateral_controller(gains: np.ndarray, dt_s: float) -> LinearController:
    """The lateral PID laws on y = [beta, phi, p, r], r = [phi_cmd], u = [aileron deg, rudder deg],
    states [int(phi - phi_cmd), low-passed yaw rate (the washout's complement)]. Positive aileron
    rolls left, positive rudder yaws left."""
    k_phi, k_p, k_phii, k_r, k_beta = gains
    a = dt_s / WASHOUT_S
    ac = np.array([[1.0, 0.0], [0.0, 1.0 - a]])
    bc = np.zeros((2, 4))
    bc[0, 1] = dt_s
    bc[1, 3] = a
    br = np.array([[-dt_s], [0.0]])
    cc = np.array([[k_phii, 0.0], [0.0, -k_r]])
    dc = np.zeros((2, 4))
    dc[0, 1], dc[0, 2] = k_phi, k_p
    dc[1, 0], dc[1, 3] = k_beta, k_r
    dr = np.array([[-k_phi], [0.0]])
    return LinearController(ac, bc, br, cc, dc, dr)


def closed_loop(ad: np.ndarray, bd: np.ndarray, c_out: np.ndarray, ctrl: LinearController,
                delay_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop (A, B from the references) of plant x+ = ad x + bd u_applied, y = c_out x,
    with the command applied ``delay_steps`` control steps late. State: plant, controller, delay line."""
    nx, nu = bd.shape
    nc = ctrl.ac.shape[0]
    nr = ctrl.br.shape[1]
    d = delay_steps
    n = nx + nc + d * nu
    a = np.zeros((n, n))
    b = np.zeros((n, nr))
    u_x, u_c, u_r = ctrl.dc @ c_out, ctrl.cc, ctrl.dr  # u_k in terms of x, c, r
    xs, cs = slice(0, nx), slice(nx, nx + nc)
    a[xs, xs] = ad
    if d == 0:
        a[xs, xs] += bd @ u_x
        a[xs, cs] = bd @ u_c
        b[xs] = bd @ u_r
    else:
        last = slice(nx + nc + (d - 1) * nu, nx + nc + d * nu)
        a[xs, last] = bd
        first = slice(nx + nc, nx + nc + nu)
        a[first, xs], a[first, cs], b[first] = u_x, u_c, u_r
        for j in range(1, d):
            a[nx + nc + j * nu: nx + nc + (j + 1) * nu, nx + nc + (j - 1) * nu: nx + nc + j * nu] = np.eye(nu)
    a[cs, xs] = ctrl.bc @ c_out
    a[cs, cs] = ctrl.ac
    b[cs] = ctrl.br
    return a, b


def spectral_radius(a: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(a))))


def step_response(a: np.ndarray, b: np.ndarray, r: np.ndarray, steps: int) -> np.ndarray:
    """Closed-loop states after a reference step ``r`` at step 0, from rest: (steps, n)."""
    x = np.zeros(a.shape[0])
    out = np.empty((steps, a.shape[0]))
    br = b @ r
    for k in range(steps):
        x = a @ x + br
        out[k] = x
    return out


class LoopDesign:
    """One block (longitudinal or lateral) of a plant, ready for gain evaluation."""

    def __init__(self, plant: LinearPlant, lateral: bool, dt_s: float = 1.0 / CONTROL_RATE_HZ):
        self.lateral, self.dt_s = lateral, dt_s
        if lateral:
            a, b = plant.a_lat, plant.b_lat[:, [0, 2]]
            self.c_out = np.hstack([np.eye(4), np.zeros((4, 2))])
            lags = (SURFACE_LAG_S, SURFACE_LAG_S)
        else:
            a, b = plant.a_long, plant.b_long[:, [1, 3]]
            # The throttle loop measures EAS: V_eas = sqrt(rho/rho0) V_tas = (EAS/TAS) V_tas.
            self.c_out = np.hstack([np.diag([plant.eas_mps / plant.tas_mps, 1.0, 1.0, 1.0]), np.zeros((4, 2))])
            lags = (SURFACE_LAG_S, THROTTLE_LAG_S)
        self.ad, self.bd = discretise(a, b, lags, dt_s)
        self.steps = int(RESPONSE_S / dt_s)
        self.t = (np.arange(self.steps) + 1) * dt_s

    def controller(self, gains: np.ndarray) -> LinearController:
        return (lateral_controller if self.lateral else longitudinal_controller)(gains, self.dt_s)

    def closed(self, gains: np.ndarray, delay_steps: int = DESIGN_DELAY_STEPS, factor: float = 1.0):
        return closed_loop(self.ad, self.bd, self.c_out, self.controller(gains).scaled(factor), delay_steps)

    def worst_spectral_radius(self, gains: np.ndarray) -> float:
        """Largest spectral radius over the nominal and the robustness cases."""
        return max(spectral_radius(self.closed(gains)[0]),
                   spectral_radius(self.closed(gains, factor=ROBUST_GAIN_FACTOR)[0]),
                   spectral_radius(self.closed(gains, DESIGN_DELAY_STEPS + ROBUST_EXTRA_DELAY_STEPS)[0]))

    def cost(self, gains: np.ndarray) -> float:
        """ITAE of the reference steps plus the noise-driven command (module docstring)."""
        a, b = self.closed(gains)
        y = self.c_out
        if self.lateral:
            x = step_response(a, b, np.array([STEP_ROLL_RAD]), self.steps)
            roll_err = np.abs(x[:, 1] - STEP_ROLL_RAD) / STEP_ROLL_RAD
            beta_deg = np.abs(np.degrees(x[:, 0]))
            itae = np.sum(self.t * roll_err) * self.dt_s + SIDESLIP_WEIGHT * np.sum(beta_deg) * self.dt_s
            noise = NOISE_RAD * math.hypot(gains[0], gains[1], gains[3], gains[4])
        else:
            x1 = step_response(a, b, np.array([STEP_PITCH_RAD, 0.0]), self.steps)
            x2 = step_response(a, b, np.array([0.0, STEP_EAS_MPS]), self.steps)
            pitch_err = np.abs(x1[:, 2] - STEP_PITCH_RAD) / STEP_PITCH_RAD + np.abs((y @ x1[:, :6].T)[0]) / STEP_EAS_MPS
            eas_err = np.abs((y @ x2[:, :6].T)[0] - STEP_EAS_MPS) / STEP_EAS_MPS + np.abs(x2[:, 2]) / STEP_PITCH_RAD
            itae = np.sum(self.t * (pitch_err + eas_err)) * self.dt_s
            noise = NOISE_RAD * math.hypot(gains[0], gains[1]) + 10.0 * NOISE_EAS_MPS * gains[3]
        return float(itae + NOISE_WEIGHT * noise)


def tune(design: LoopDesign, start: np.ndarray | None = None, max_evaluations: int = 1500) -> np.ndarray:
    """Gains that minimise ``LoopDesign.cost`` subject to the robustness cases (module docstring)."""
    from scipy.optimize import minimize  # here, not at the top: importing the package stays light
    start = (LAT_START if design.lateral else LONG_START) if start is None else np.asarray(start, float)
    signed = 4 if design.lateral else None  # the sideslip gain may take either sign

    def unpack(z: np.ndarray) -> np.ndarray:
        g = np.exp(z)
        if signed is not None:
            g[signed] = z[signed]
        return g

    def objective(z: np.ndarray) -> float:
        g = unpack(z)
        radius = design.worst_spectral_radius(g)
        if not np.isfinite(radius) or radius >= 0.999:
            return 1e6 * (1.0 + radius)
        return design.cost(g)

    z0 = np.log(np.maximum(start, 1e-6))
    if signed is not None:
        z0[signed] = start[signed]
    result = minimize(objective, z0, method="Nelder-Mead",
                      options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-4, "adaptive": True})
    gains = unpack(result.x)
    if design.worst_spectral_radius(gains) >= 0.999:
        raise RuntimeError("PID tuning found no gains meeting the robustness cases")
    return gains

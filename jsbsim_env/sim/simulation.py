"""The one place that owns JSBSim: loading the solar UAV, initial conditions, trim, stepping.

JSBSim works in imperial units; this module converts to SI once, and everything above it uses
names with units (``altitude_m``, ``airspeed_eas_mps``, ``roll_rad``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from aircraft import SURFACES, Aircraft, load_aircraft
from jsbsim_env.sim.model_check import ModelError, validate_loaded_model

FT_TO_M = 0.3048
M_TO_FT = 1.0 / FT_TO_M
LBF_TO_N = 4.4482216152605
SLUG_FT2_TO_KG_M2 = 1.3558179483314
RHO0_KG_M3 = 1.225  # sea-level density of the 1976 standard atmosphere
RHO0_SLUG_FT3 = 0.0023768907688269184  # the same in JSBSim's units
SLUG_FT3_TO_KG_M3 = 515.378818

# The paper's aircraft's flight envelope (its Section 2 and Table 1; 3.4 for the EAS), as its
# aircraft/solar_uav/envelope.json records it; each aircraft's is ``Simulation.aircraft``'s.
ALTITUDE_RANGE_M = (0.0, 20000.0)
EAS_RANGE_MPS = (8.0, 12.0)
# The ground under every simulation: 100 m below the envelope's floor, so that the aircraft trims
# and flies at its floor with its landing gear clear, and an episode started there still has the
# flight core's 50 m ground-strike margin (core.Envelope) before it ends.
TERRAIN_BELOW_FLOOR_M = 100.0
TERRAIN_ELEVATION_M = ALTITUDE_RANGE_M[0] - TERRAIN_BELOW_FLOOR_M  # the paper's aircraft's
DEFAULT_SIM_RATE_HZ = 120.0
# Trim's first guess of the rotor speed per m/s of true airspeed: cruise trims lie at 24-26 rpm per
# m/s (about a constant advance ratio at constant EAS). The full-throttle speed turns it into a throttle.
ROTOR_RPM_GUESS_PER_TAS_MPS = 25.0
_TRIM_BOUNDS = (np.array([-10.0, -30.0, 0.0]), np.array([14.0, 30.0, 1.0]))  # alpha deg, elevator deg, throttle
# The lateral trim's sideslip bound (deg); the aileron and rudder are bounded by the aircraft's travel.
LATERAL_TRIM_BETA_DEG = 10.0
# Rounds of the longitudinal and the lateral solution in turn (their coupling is weak: two suffice).
MAX_TRIM_ROUNDS = 4


# The six residual accelerations: udot, wdot (m/s²), qdot (rad/s²), vdot (m/s²), pdot, rdot (rad/s²).
LONGITUDINAL, LATERAL = slice(0, 3), slice(3, 6)
_TRANSLATIONAL = np.array([True, True, False, True, False, False])


def _trimmed(r: np.ndarray, part: slice, tighter: float = 1.0) -> bool:
    """Whether the ``part`` of the six residual accelerations ``r`` is that of a trim: 1e-3 m/s²
    and 1e-4 rad/s², ``tighter`` times less."""
    linear, residual = _TRANSLATIONAL[part], np.abs(r[part])
    return bool(np.all(residual[linear] < 1e-3 / tighter) and np.all(residual[~linear] < 1e-4 / tighter))


def _converged(r: np.ndarray, part: slice) -> bool:
    """Where the Newton iteration stops: ten times inside ``_trimmed``."""
    return _trimmed(r, part, tighter=10.0)


# Rotor reference lag during a fast settle: a tenth of a 120 Hz step, well inside the Tustin
# filter's stable range, so the rotors follow their speed controllers' own 0.03 s loop.
FAST_SETTLE_LAG_PER_S = 50.0

# Initial-condition passes until alpha-dot is the state's own (each cuts the change 80- to 10,000-fold).
MAX_ALPHADOT_PASSES = 6
ALPHADOT_TOL_RADPS = 1e-9

# JSBSim's FCS inputs, normalised to +-1 (aileron, elevator, rudder) or 0..1 (throttle).
CONTROL_INPUTS = ("fcs/aileron-cmd-norm", "fcs/elevator-cmd-norm", "fcs/rudder-cmd-norm",
                  "fcs/throttle-cmd-norm[0]")
# The commands' range (the paper's Table 2, its aircraft's travel); an aircraft whose surfaces travel
# less (``Simulation.surface_limits_deg``) holds them at its own limits beyond.
SURFACE_LIMITS_DEG = {"aileron": 30.0, "elevator": 30.0, "rudder": 20.0}


class TrimError(RuntimeError):
    """No trimmed state exists (or none was found) at the requested flight condition."""


@dataclass(frozen=True)
class TrimResult:
    """A steady, wings-level, constant-altitude flight condition.

    The lateral trim (sideslip, aileron, rudder) is zero for a symmetric aircraft; one whose
    propeller torque is not cancelled (a single rotor) holds it with aileron and rudder and a
    small sideslip, wings level.
    """

    altitude_m: float
    airspeed_eas_mps: float
    airspeed_tas_mps: float
    alpha_deg: float
    pitch_deg: float
    elevator_deg: float
    throttle: float
    rotor_rpm: float
    thrust_n: float
    residual_accel_mps2: float  # largest remaining translational acceleration
    residual_ang_accel_radps2: float  # largest remaining angular acceleration
    aileron_deg: float = 0.0
    rudder_deg: float = 0.0
    beta_deg: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """Plain dict, for JSON output."""
        return dict(self.__dict__)


class Inertia(NamedTuple):
    """Moments and product of inertia about the CG in body axes (x forward, y right, z down).

    Flight-dynamics convention: ``ixz_kg_m2`` is the product of inertia, the integral of x z dm
    (the paper's Table 1: +37 kg m²); the inertia tensor holds -Ixz off its diagonal, so at zero body
    rates Ixx pdot - Ixz rdot = L and Izz rdot - Ixz pdot = N. Ixy and Iyz, zero for this
    symmetric aircraft, are left out.
    """

    ixx_kg_m2: float
    iyy_kg_m2: float
    izz_kg_m2: float
    ixz_kg_m2: float


def _quiet_jsbsim() -> None:
    # JSBSim prints a banner and model notes to stdout unless its debug level is 0 before loading.
    os.environ.setdefault("JSBSIM_DEBUG", "0")


class Simulation:
    """A JSBSim instance flying one aircraft (the paper's solar UAV by default).

    The terrain lies ``TERRAIN_BELOW_FLOOR_M`` below the aircraft's envelope floor
    (``terrain_elevation_m``; below sea level for the paper's), so ``position/h-agl-ft`` is the
    height above that, and an initial-condition file's ``<altitude>`` (which JSBSim reads as
    height above the terrain) places the aircraft that much lower than the same ``<altitudeMSL>``.

    Args:
        aircraft: the aircraft (``aircraft.load_aircraft``: a name, a built aircraft's folder or
            JSBSim root, or an ``Aircraft``); the paper's by default.
        sim_rate_hz: integration rate of the flight dynamics.
    """

    def __init__(self, aircraft: Aircraft | Path | str | None = None, sim_rate_hz: float = DEFAULT_SIM_RATE_HZ):
        import jsbsim

        _quiet_jsbsim()
        self.aircraft = load_aircraft(aircraft)
        self.root = self.aircraft.root
        name = self.aircraft.name
        self.surface_limits_deg = dict(zip(SURFACES, self.aircraft.surface_limits_deg))
        self.terrain_elevation_m = self.aircraft.altitude_range_m[0] - TERRAIN_BELOW_FLOOR_M
        self.fdm = jsbsim.FGFDMExec(str(self.root), None)
        self.fdm.set_debug_level(0)
        self.fdm.set_dt(1.0 / sim_rate_hz)
        try:
            loaded = self.fdm.load_model(name)
        except Exception as err:  # JSBSim raises BaseError or RuntimeError on malformed XML
            raise ModelError(f"JSBSim could not load aircraft {name!r} from {self.root}: {err}") from err
        if not loaded:
            raise ModelError(f"JSBSim could not load aircraft {name!r} from {self.root}/aircraft")
        self.dt_s = 1.0 / sim_rate_hz
        self._rpm_per_tas_mps: float | None = None  # a trim's first guess, once learned (``trim``)
        self.engine_count = self.fdm.get_propulsion().get_num_engines()
        self.fdm["ic/terrain-elevation-ft"] = self.terrain_elevation_m * M_TO_FT
        # JSBSim 1.3 leaves a propeller's absorbed power uninitialised until the propeller's first
        # step, and the motors' speed controllers (Systems/rotor_speed.xml) read it in the flight
        # control, which runs before the propulsion: whatever the heap held (at times a NaN) would
        # reach the rotors and, through them, every state. Found with valgrind's memcheck.
        for i in range(self.engine_count):
            self.fdm[f"propulsion/engine[{i}]/propeller-power-ftlbps"] = 0.0
        # JSBSim flies a model with missing elements (reading them as 0); refuse it here. This
        # also runs the first initial-condition pass.
        validate_loaded_model(self.fdm, self.aircraft.folder / f"{name}.xml")
        # Start the motors once: JSBSim's engine start re-initialises the rotors, which must keep
        # their speed across the initial-condition passes of a trim.
        self.fdm["propulsion/set-running"] = -1

    # ------------------------------------------------------------------ properties
    def __getitem__(self, name: str) -> float:
        return self.fdm[name]

    def __setitem__(self, name: str, value: float) -> None:
        self.fdm[name] = value

    def set_controls(self, aileron_deg: float, elevator_deg: float, rudder_deg: float, throttle: float) -> None:
        """Command the surfaces (degrees, the paper's sign conventions) and the throttle (0..1)."""
        limits = self.surface_limits_deg
        values = (aileron_deg / limits["aileron"], elevator_deg / limits["elevator"], rudder_deg / limits["rudder"],
                  throttle)
        for name, value in zip(CONTROL_INPUTS, values):
            self.fdm[name] = value

    def density_kg_m3(self, altitude_m: float) -> float:
        """Air density at ``altitude_m`` from JSBSim's atmosphere (US 1976 standard by default)."""
        self.fdm["ic/h-sl-ft"] = altitude_m * M_TO_FT
        self.fdm.run_ic()
        return self.fdm["atmosphere/rho-slugs_ft3"] * SLUG_FT3_TO_KG_M3

    def airspeed_eas_mps(self) -> float:
        """Equivalent airspeed sqrt(rho/rho0) * V_true."""
        rho = self.fdm["atmosphere/rho-slugs_ft3"]
        return math.sqrt(rho / RHO0_SLUG_FT3) * self.fdm["velocities/vt-fps"] * FT_TO_M

    # ------------------------------------------------------------------ initial conditions
    def set_initial_conditions(self, altitude_m: float, airspeed_tas_mps: float, alpha_deg: float = 0.0,
                               pitch_deg: float | None = None, roll_deg: float = 0.0, heading_deg: float = 0.0,
                               beta_deg: float = 0.0, rates_radps=(0.0, 0.0, 0.0)) -> None:
        """Place the aircraft and run JSBSim's initial-condition pass.

        JSBSim takes alpha-dot from the accelerations of the pass before, and the model's alpha-dot
        terms feed it back into the accelerations; the pass is repeated until alpha-dot changes by
        less than ``ALPHADOT_TOL_RADPS`` (each pass cuts the change 80- to 10,000-fold; a 30° bank
        change takes five), so that the accelerations do not depend on the state placed before.
        """
        f = self.fdm
        f["ic/h-sl-ft"] = altitude_m * M_TO_FT
        f["ic/vt-fps"] = airspeed_tas_mps * M_TO_FT
        f["ic/alpha-deg"] = alpha_deg
        f["ic/beta-deg"] = beta_deg
        f["ic/theta-deg"] = alpha_deg if pitch_deg is None else pitch_deg
        f["ic/phi-deg"] = roll_deg
        f["ic/psi-true-deg"] = heading_deg
        f["ic/p-rad_sec"], f["ic/q-rad_sec"], f["ic/r-rad_sec"] = rates_radps
        if not self.fdm.run_ic():
            raise TrimError("JSBSim rejected the initial conditions")
        for _ in range(MAX_ALPHADOT_PASSES):
            alphadot = f["aero/alphadot-rad_sec"]
            f.run_ic()
            if abs(f["aero/alphadot-rad_sec"] - alphadot) < ALPHADOT_TOL_RADPS:
                break
        # JSBSim keeps any difference between its stored airspeed and ground velocity as a wind
        # (loading an initial-condition file into a used instance leaves one); that wind would
        # silently shift alpha and stay in the atmosphere.
        alpha_err = f["aero/alpha-deg"] - alpha_deg
        if abs(alpha_err) > 1e-6 or abs(f["aero/beta-deg"] - beta_deg) > 1e-6:
            raise TrimError(f"JSBSim's initial conditions carry a wind (alpha off by {alpha_err:.3g} deg); "
                            "set initial conditions on an instance that has not loaded an initial-condition file")

    def settle_actuators(self, max_time_s: float = 8.0, tol_deg: float = 1e-4, tol_rpm: float = 0.05,
                         fast: bool = False) -> None:
        """Fly on until the servos, the rotor-speed reference and the rotors reach their commands.

        Used to bring the actuator states to a new command before the initial conditions are set
        again: JSBSim's initial-condition pass keeps the actuator and rotor states. ``fast`` lifts
        the rotor reference's 0.2 s lag and rate limit meanwhile (a start from rest then takes
        about 0.3 s instead of 3 s of simulated flight); the flight values come back afterwards.
        """
        f = self.fdm
        if fast:
            lag, rate = f["fcs/rotor-lag-per-s"], f["fcs/rotor-rate-limit-rpm_s"]
            f["fcs/rotor-lag-per-s"], f["fcs/rotor-rate-limit-rpm_s"] = FAST_SETTLE_LAG_PER_S, 1e9
            try:
                self.settle_actuators(max_time_s, tol_deg, tol_rpm)
            finally:
                f["fcs/rotor-lag-per-s"], f["fcs/rotor-rate-limit-rpm_s"] = lag, rate
            return
        rpm_prev = None
        for _ in range(int(max_time_s / self.dt_s)):
            f.run()
            ref = f["fcs/rotor-speed-ref-rpm"]
            rpm = f["propulsion/engine[0]/propeller-rpm"]
            surfaces_done = all(abs(f[f"fcs/{s}-cmd-deg"] - f[f"fcs/{s}-pos-deg"]) < tol_deg
                                for s in ("elevator", "aileron", "rudder"))
            # At full motor power the rotor cannot reach the reference: settled once it stops moving.
            power_limited = f["fcs/throttle-pos-norm[0]"] >= 1.0 - 1e-9 and rpm_prev is not None \
                and abs(rpm - rpm_prev) < tol_rpm * self.dt_s
            if surfaces_done and abs(ref - f["fcs/rotor-speed-cmd-rpm"]) < tol_rpm \
                    and (abs(rpm - ref) < tol_rpm or power_limited):
                return
            rpm_prev = rpm

    def place_with_controls(self, altitude_m: float, tas_mps: float, alpha_deg: float, aileron_deg: float,
                            elevator_deg: float, rudder_deg: float, throttle: float, beta_deg: float = 0.0) -> None:
        """Wings-level, level flight at the given condition with the actuators and rotors settled
        at the given controls (JSBSim's initial-condition pass keeps actuator states, so they are
        brought to the controls first, then the aircraft is placed again)."""
        self.set_initial_conditions(altitude_m, tas_mps, alpha_deg=alpha_deg, beta_deg=beta_deg)
        self.set_controls(aileron_deg, elevator_deg, rudder_deg, throttle)
        self.settle_actuators()
        self.set_initial_conditions(altitude_m, tas_mps, alpha_deg=alpha_deg, beta_deg=beta_deg)

    def inertia_kg_m2(self) -> Inertia:
        """The inertia JSBSim integrates with.

        JSBSim's tensor (``get_mass_balance().get_J()``), its ``inertia/ixz-slugs_ft2`` property
        and its mass-properties report all give the tensor element, -Ixz (-37 kg m² here); this
        returns the product of inertia +Ixz. ``aero/scale/I`` is not included: the model applies
        it as a factor 1/s on the aerodynamic moments (``Systems/scaling.xml``).
        """
        f = self.fdm
        return Inertia(f["inertia/ixx-slugs_ft2"] * SLUG_FT2_TO_KG_M2, f["inertia/iyy-slugs_ft2"] * SLUG_FT2_TO_KG_M2,
                       f["inertia/izz-slugs_ft2"] * SLUG_FT2_TO_KG_M2, -f["inertia/ixz-slugs_ft2"] * SLUG_FT2_TO_KG_M2)

    def thrust_n(self) -> float:
        """Total thrust of all propellers."""
        return float(sum(self.fdm[f"propulsion/engine[{i}]/thrust-lbs"] for i in range(self.engine_count)) * LBF_TO_N)

    def shaft_power_w(self) -> float:
        """Total shaft power the propellers absorb (JSBSim's ft lbf/s, in W)."""
        return float(sum(self.fdm[f"propulsion/engine[{i}]/propeller-power-ftlbps"] for i in range(self.engine_count))
                     * LBF_TO_N * FT_TO_M)

    # ------------------------------------------------------------------ trim
    def _newton(self, altitude_m: float, tas_mps: float, x: np.ndarray, lateral: bool,
                max_iterations: int) -> tuple[np.ndarray, np.ndarray]:
        """Newton iteration from the trim vector ``x`` (alpha deg, elevator deg, throttle, beta deg,
        aileron deg, rudder deg) on its longitudinal three, or with ``lateral`` its lateral three,
        the other three held: where it ends and its six residual accelerations (both vectors whole)."""
        free = LATERAL if lateral else LONGITUDINAL
        if lateral:
            travel = np.array([self.surface_limits_deg["aileron"], self.surface_limits_deg["rudder"]])
            bounds = (np.array([-LATERAL_TRIM_BETA_DEG, *-travel]), np.array([LATERAL_TRIM_BETA_DEG, *travel]))
            steps, step_limit = np.array([0.05, 0.05, 0.05]), np.array([2.0, 5.0, 5.0])
        else:
            bounds = _TRIM_BOUNDS
            steps, step_limit = np.array([0.05, 0.05, 0.002]), np.array([3.0, 5.0, 0.2])
        scale = np.array([1.0, 1.0, 10.0])  # weight the angular acceleration like the translational ones
        x = x.copy()
        r_all = self._residuals(altitude_m, tas_mps, x)
        for _ in range(max_iterations):
            if _converged(r_all, free):
                break
            r = r_all[free]
            jac = np.empty((3, 3))
            for k in range(3):
                dx = np.zeros(6)
                dx[free.start + k] = steps[k]
                jac[:, k] = (self._residuals(altitude_m, tas_mps, x + dx)[free] - r) / steps[k]
            delta = np.linalg.lstsq(jac * scale[:, None], -r * scale, rcond=None)[0]
            delta = np.clip(delta, -step_limit, step_limit)
            x_new = x.copy()
            x_new[free] = np.clip(x[free] + delta, *bounds)
            r_new_all = self._residuals(altitude_m, tas_mps, x_new)
            if (np.linalg.norm(r_new_all[free] * scale) > np.linalg.norm(r * scale)
                    and np.any(x_new[free] != x[free] + delta)):
                # Pinned at a limit and not improving: the trim needs a control beyond its range.
                break
            x, r_all = x_new, r_new_all
        return x, r_all

    def _residuals(self, altitude_m, tas_mps, x) -> np.ndarray:
        """Body accelerations of steady level flight at the trim vector ``x`` (see ``_newton``):
        udot, wdot (m/s²), qdot (rad/s²), then vdot (m/s²), pdot, rdot (rad/s²)."""
        alpha_deg, elevator_deg, throttle, beta_deg, aileron_deg, rudder_deg = x
        self.place_with_controls(altitude_m, tas_mps, alpha_deg, aileron_deg, elevator_deg, rudder_deg, throttle,
                                 beta_deg=beta_deg)
        f = self.fdm
        return np.array([f["accelerations/udot-ft_sec2"] * FT_TO_M, f["accelerations/wdot-ft_sec2"] * FT_TO_M,
                         f["accelerations/qdot-rad_sec2"], f["accelerations/vdot-ft_sec2"] * FT_TO_M,
                         f["accelerations/pdot-rad_sec2"], f["accelerations/rdot-rad_sec2"]])

    def _trim_both(self, altitude_m: float, tas_mps: float, throttle: float,
                   max_iterations: int) -> tuple[np.ndarray, np.ndarray]:
        """The longitudinal trim from (0, 0, ``throttle``); then, where the lateral accelerations
        are not those of a trim (propeller torque), the lateral and longitudinal trims in turn.
        A symmetric aircraft's lateral trim stays exactly zero."""
        x, r = self._newton(altitude_m, tas_mps, np.array([0.0, 0.0, throttle, 0.0, 0.0, 0.0]), False, max_iterations)
        for _ in range(MAX_TRIM_ROUNDS):
            if _converged(r, LATERAL) or not _trimmed(r, LONGITUDINAL):
                break
            x, _ = self._newton(altitude_m, tas_mps, x, True, max_iterations)
            x, r = self._newton(altitude_m, tas_mps, x, False, max_iterations)
        return x, r

    def trim(self, altitude_m: float, airspeed_eas_mps: float, check_envelope: bool = True,
             max_iterations: int = 30) -> TrimResult:
        """Find steady, wings-level, level flight and leave the aircraft in it.

        Newton iteration on angle of attack, elevator and throttle with the residual body
        accelerations computed by JSBSim (the rotors at the speed the throttle commands); where
        the lateral accelerations are not zero by symmetry (a single propeller's torque), on
        sideslip, aileron and rudder too, wings level.

        Raises:
            TrimError: outside the flight envelope, or no trim with the controls inside their limits.
        """
        if not (math.isfinite(altitude_m) and math.isfinite(airspeed_eas_mps)):
            raise TrimError(f"altitude {altitude_m} m and EAS {airspeed_eas_mps} m/s must be finite")
        if check_envelope:
            lo, hi = self.aircraft.altitude_range_m
            if not lo <= altitude_m <= hi:
                raise TrimError(f"altitude {altitude_m:g} m is outside the flight envelope {lo:g}-{hi:g} m")
            lo, hi = self.aircraft.eas_range_mps
            if not lo <= airspeed_eas_mps <= hi:
                raise TrimError(f"equivalent airspeed {airspeed_eas_mps:g} m/s is outside the flight envelope "
                                f"{lo:g}-{hi:g} m/s")
        tas_mps = airspeed_eas_mps * math.sqrt(RHO0_KG_M3 / self.density_kg_m3(altitude_m))
        # Start where the rotor speed scales with true airspeed (constant advance ratio at constant
        # EAS): away from the motor's power limit, where the throttle has no effect on thrust.
        rpm_per_tas = self._rpm_per_tas_mps or ROTOR_RPM_GUESS_PER_TAS_MPS
        throttle_guess = rpm_per_tas * tas_mps / self.fdm["fcs/rotor-speed-full-rpm"]
        x, r = self._trim_both(altitude_m, tas_mps, float(np.clip(throttle_guess, 0.05, 0.9)), max_iterations)
        restarted = not _trimmed(r, LONGITUDINAL)
        if restarted:
            # That start suits the paper's propellers; another aircraft's may windmill there. Start
            # again at zero angle of attack from the highest throttle where the speed stops falling
            # (at lower throttles a windmilling or idling rotor's drag can balance too).
            scan = np.linspace(0.05, 0.95, 19)
            udot = np.array([self._residuals(altitude_m, tas_mps, np.array([0.0, 0.0, t, 0.0, 0.0, 0.0]))[0]
                             for t in scan])
            crossings = np.flatnonzero((udot[:-1] < 0.0) & (udot[1:] >= 0.0))
            start = scan[crossings[-1] + 1] if crossings.size else scan[int(np.argmin(np.abs(udot)))]
            x, r = self._trim_both(altitude_m, tas_mps, float(start), max_iterations)
        if not (_trimmed(r, LONGITUDINAL) and _trimmed(r, LATERAL)):
            names = ("angle of attack", "elevator", "throttle", "sideslip", "aileron", "rudder")
            travel = [self.surface_limits_deg[s] for s in ("aileron", "rudder")]
            lows = [*_TRIM_BOUNDS[0], -LATERAL_TRIM_BETA_DEG, *(-t for t in travel)]
            highs = [*_TRIM_BOUNDS[1], LATERAL_TRIM_BETA_DEG, *travel]
            pinned = [n for n, v, lo, hi in zip(names, x, lows, highs) if v <= lo + 1e-9 or v >= hi - 1e-9]
            why = f"{', '.join(pinned)} at its limit" if pinned else "no convergence"
            raise TrimError(f"no trim at {altitude_m:g} m, EAS {airspeed_eas_mps:g} m/s: {why} "
                            f"(residual accelerations {np.array2string(r, precision=4)})")
        self._residuals(altitude_m, tas_mps, x)  # leave the aircraft in the trimmed state
        f = self.fdm
        if restarted:  # this aircraft's rotor speed per m/s: its next trims start there (20 times faster)
            self._rpm_per_tas_mps = f["propulsion/engine[0]/propeller-rpm"] / tas_mps
        return TrimResult(
            altitude_m=altitude_m, airspeed_eas_mps=airspeed_eas_mps, airspeed_tas_mps=tas_mps,
            alpha_deg=float(x[0]), pitch_deg=float(f["attitude/theta-deg"]), elevator_deg=float(x[1]),
            throttle=float(x[2]), rotor_rpm=float(f["propulsion/engine[0]/propeller-rpm"]),
            thrust_n=self.thrust_n(),
            residual_accel_mps2=float(np.max(np.abs(r[[0, 1, 3]]))),
            residual_ang_accel_radps2=float(np.max(np.abs(r[[2, 4, 5]]))),
            aileron_deg=float(x[4]), rudder_deg=float(x[5]), beta_deg=float(x[3]),
        )

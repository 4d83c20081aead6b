"""Route missions: TECS and L1 guidance feeding an attitude controller around a rectangle.

A mission starts in trimmed level flight at the route's altitude, at the first waypoint, heading
along the first leg, and flies the closed route of ``RouteConfig.waypoints_ne_m`` (by default a
rectangle of ``leg_north_m`` x ``leg_east_m``, grown above 10 km with the turn radius, see
``RouteConfig.rectangle_scale``) until ``duration_s``. Every control step (25 Hz by
default):

1. L1 guidance gives the roll demand for the current leg; the next leg starts once the aircraft
   is within one turn radius (at the roll limit) of the leg's end.
2. TECS gives the pitch demand and the throttle for the route altitude and EAS.
3. The attitude controller (PID, trained policy, ...) turns the measurement and the demands
   (roll, pitch, EAS) into surface and throttle commands; TECS's throttle replaces its throttle,
   as in the paper. Since TECS flies the speed, the attitude controller's EAS demand is by default
   its measured EAS (``RouteConfig.attitude_eas_demand``): it has no airspeed error to act on, as
   in the speed-free training episodes (``TaskConfig.external_throttle``). The PID's surfaces do not
   depend on the EAS demand; the paper's setting passes TECS's EAS demand on.
4. The flight core applies the commands with its delay, actuator lag and rate limits, backlash,
   turbulence (on the chosen legs only), sensor noise and parameter set.

The result holds the time histories and the metrics of ``jsbsim_env.task.metrics``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from aircraft import AIRCRAFT_NAME
from jsbsim_env.control.base import AttitudeController
from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.control.l1 import G_MPS2, L1Guidance, L1Params
from jsbsim_env.control.pid import GainSchedule
from jsbsim_env.control.tecs import TECS, TECSParams
from jsbsim_env.sim.core import CoreConfig, FlightCore
from jsbsim_env.task.attitude import EAS_INDEX
from jsbsim_env.task.metrics import actuator_smoothness, rmse

ATTITUDE_EAS_DEMANDS = ("measured", "route")
RECTANGLE_ALTITUDE_M = 10_000.0  # the default rectangle's legs are drawn for this altitude (the paper's route)


def standard_density_kg_m3(altitude_m: float) -> float:
    """Air density of the 1976 standard atmosphere up to 20 km (troposphere, then the isothermal
    layer from 11 km), within 1 % of JSBSim's; it sizes routes, the flight core flies JSBSim's."""
    if altitude_m <= 11_000.0:
        return 1.225 * (1.0 - 2.25577e-5 * altitude_m) ** 4.25588
    return 0.36392 * math.exp(-(altitude_m - 11_000.0) / 6341.62)


@dataclass(frozen=True)
class RouteConfig:
    """One route flight. Distances in m, times in s, speeds in m/s, angles in degrees; ``aircraft``
    as ``CoreConfig.aircraft``."""

    aircraft: str = AIRCRAFT_NAME
    altitude_m: float = 10_000.0
    eas_mps: float = 10.0
    leg_north_m: float = 6_000.0
    leg_east_m: float = 3_000.0
    # Above RECTANGLE_ALTITUDE_M the rectangle grows with the turn radius (``rectangle_scale``).
    scale_with_altitude: bool = True
    waypoints_ne_m: tuple[tuple[float, float], ...] | None = None  # None: the rectangle above
    duration_s: float = 2_400.0
    control_rate_hz: float = 25.0
    delay_s: float = 0.04  # one control step: measurement to actuator, as on the loop bench
    turbulence_legs: tuple[int, ...] = ()  # leg numbers (0 = first leg flown) with turbulence on
    turbulence_intensity: str = "paper"  # or a MIL-F-8785C severity (CoreConfig.turbulence_intensity)
    turbulence_sigma_mps: float = 0.5
    turbulence_clip: str = "4sigma"  # or "paper" (CoreConfig.turbulence_clip)
    parameters: str = "nominal"  # or "positive", "negative" (the paper's Table 9), or dist.RANDOMISED
    backlash_deg: float = 0.0
    sensor_noise: bool = True
    # The paper's Table 3 sigmas, but mean-reverting: the training setting's rate 0 is a random walk that
    # drifts about 1 deg of attitude in 40 minutes, where an INS (Table 5: within 0.1 deg) does
    # not drift. At 1/s the stationary attitude noise is sigma / sqrt(2) = 0.04 deg.
    noise_reversion_per_s: float = 1.0
    seed: int = 0
    tecs: TECSParams = field(default_factory=TECSParams)
    l1: L1Params = field(default_factory=L1Params)
    # The EAS demand the attitude controller gets: "measured" (no airspeed error; TECS flies the
    # speed) or "route" (the route's EAS, as the paper). The metrics always score the route's EAS.
    attitude_eas_demand: str = "measured"

    def __post_init__(self):
        if self.attitude_eas_demand not in ATTITUDE_EAS_DEMANDS:
            raise ValueError(f"attitude_eas_demand must be one of {ATTITUDE_EAS_DEMANDS}, "
                             f"got {self.attitude_eas_demand!r}")

    def waypoints(self) -> np.ndarray:
        if self.waypoints_ne_m is not None:
            wp = np.asarray(self.waypoints_ne_m, dtype=float)
        else:
            n, e = self.leg_north_m * self.rectangle_scale(), self.leg_east_m * self.rectangle_scale()
            wp = np.array([[0.0, 0.0], [n, 0.0], [n, e], [0.0, e]])
        if wp.ndim != 2 or wp.shape[1] != 2 or len(wp) < 2 or not np.all(np.isfinite(wp)):
            raise ValueError(f"route needs at least two finite (north, east) waypoints, got {wp.tolist()}")
        if np.any(np.hypot(*(np.roll(wp, -1, axis=0) - wp).T) < 1.0):
            raise ValueError("route has a leg shorter than 1 m")
        return wp

    def rectangle_scale(self) -> float:
        """How much larger than drawn the default rectangle is at this altitude: the turn radius at
        the roll limit, V_true^2 / (g tan 5 deg), against its value at ``RECTANGLE_ALTITUDE_M`` (at
        the same EAS, the density ratio), and 1 below it or with ``scale_with_altitude`` False.
        At 20 km the turn radius is 1.7 km, 4.7 times that at 10 km: the 3 km legs drawn for 10 km
        would be all turn, with the roll demand at its limit throughout, and no level flight to measure."""
        if not self.scale_with_altitude:
            return 1.0
        return max(1.0, standard_density_kg_m3(RECTANGLE_ALTITUDE_M) / standard_density_kg_m3(self.altitude_m))

    def core_config(self) -> CoreConfig:
        """The flight core for this mission: fixed interval and delay, no start perturbation."""
        interval = 1.0 / self.control_rate_hz
        return CoreConfig(
            aircraft=self.aircraft, control_interval_s=(interval, interval), delay_s=(self.delay_s, self.delay_s),
            sensor_noise=self.sensor_noise, noise_reversion_per_s=self.noise_reversion_per_s, parameters=self.parameters, turbulence=bool(self.turbulence_legs),
            turbulence_intensity=self.turbulence_intensity, turbulence_sigma_mps=self.turbulence_sigma_mps,
            turbulence_clip=self.turbulence_clip, backlash_deg=self.backlash_deg,
            perturb_attitude_deg=0.0, perturb_rate_degps=0.0, perturb_eas_mps=0.0,
            max_steps=math.ceil(self.duration_s * self.control_rate_hz) + 1,
        )


@dataclass
class MissionResult:
    """Time histories (one row per control step) and the mission's settings."""

    config: RouteConfig
    arrays: dict[str, np.ndarray]
    ended_early: str | None

    def window(self, start_s: float = 0.0, end_s: float = math.inf) -> np.ndarray:
        t = self.arrays["time_s"]
        return (t >= start_s) & (t < end_s)

    def metrics(self, start_s: float = 0.0, end_s: float = math.inf, only: np.ndarray | None = None) -> dict[str, float]:
        """RMSE and mean absolute error of roll, pitch (deg), EAS (m/s) against their demands and
        of sideslip (deg) against zero, and Sm of each actuator command (``metrics.actuator_smoothness``),
        over [start_s, end_s), and of those samples only where ``only`` (one bool per sample) is True."""
        a, w = self.arrays, self.window(start_s, end_s)
        if only is not None:
            w = w & only
        if not np.any(w):
            raise ValueError(f"no samples between {start_s} s and {end_s} s" + (" where asked" if only is not None else ""))
        errors = {
            "roll_deg": np.degrees(a["roll_rad"][w] - a["roll_cmd_rad"][w]),
            "pitch_deg": np.degrees(a["pitch_rad"][w] - a["pitch_cmd_rad"][w]),
            "airspeed_eas_mps": a["eas_mps"][w] - a["eas_cmd_mps"][w],
            "beta_deg": np.degrees(a["beta_rad"][w]),
        }
        out: dict[str, float] = {}
        for name, e in errors.items():
            out[f"rmse_{name}"] = rmse(e)
            out[f"mae_{name}"] = float(np.mean(np.abs(e)))
        out.update(actuator_smoothness(a["command"][w], self.config.control_rate_hz))
        out["max_cross_track_m"] = float(np.max(np.abs(a["cross_track_m"][w])))
        out["max_altitude_error_m"] = float(np.max(np.abs(a["altitude_m"][w] - self.config.altitude_m)))
        return out


_ROW_NAMES = ("time_s", "north_m", "east_m", "altitude_m", "roll_rad", "pitch_rad", "heading_rad", "eas_mps",
              "beta_rad", "roll_cmd_rad", "pitch_cmd_rad", "eas_cmd_mps", "cross_track_m", "leg", "turbulence")


class RouteFlight:
    """One route flight, a control step at a time: ``demand()`` gives the measurement and the
    attitude demands of the step, ``advance(command)`` flies it. ``fly_route`` loops over them in
    one process; the loop bench (``jsbsim_env.bench``) puts a serial link between the two calls.
    """

    def __init__(self, config: RouteConfig | None = None):
        cfg = self.config = config or RouteConfig()
        self.waypoints = cfg.waypoints()
        self.dt_s = 1.0 / cfg.control_rate_hz
        self.steps = math.ceil(cfg.duration_s * cfg.control_rate_hz)
        self.core = FlightCore(cfg.core_config())
        first_leg = self.waypoints[1] - self.waypoints[0]
        heading_deg = math.degrees(math.atan2(first_leg[1], first_leg[0]))
        self.measurement = self.core.reset(cfg.seed, altitude_m=cfg.altitude_m, airspeed_eas_mps=cfg.eas_mps,
                                           heading_deg=heading_deg)
        self.schedule = GainSchedule(gain_file("pid", self.core.aircraft))  # TECS's trim data
        self.tecs, self.l1 = TECS(cfg.tecs), L1Guidance(cfg.l1)
        self.tecs.reset()
        self.leg = 0
        self.k = 0  # control steps flown
        self.ended: str | None = None
        self._rows = np.full((self.steps, len(_ROW_NAMES)), np.nan)
        self._commands = np.full((self.steps, 4), np.nan)
        self._surfaces = np.full((self.steps, 4), np.nan)
        self._pending: tuple | None = None  # this step's demands, between demand() and advance()
        self.navigation = None  # the navigation the last demand() read

    @property
    def done(self) -> bool:
        return self.ended is not None or self.k >= self.steps

    def demand(self) -> tuple[np.ndarray, np.ndarray]:
        """The step's measurement (``core.STATE_NAMES``) and attitude demands (roll, pitch in rad,
        EAS in m/s, as ``RouteConfig.attitude_eas_demand`` says): L1 guidance and TECS, once per step."""
        if self.done:
            raise RuntimeError("the route flight is over")
        cfg, nav, wp = self.config, self.core.navigation(), self.waypoints
        a_wp, b_wp = wp[self.leg % len(wp)], wp[(self.leg + 1) % len(wp)]
        ground_speed = math.hypot(nav.v_north_mps, nav.v_east_mps)
        turn_radius = ground_speed ** 2 / (G_MPS2 * math.tan(cfg.l1.roll_limit_rad))
        if math.hypot(b_wp[0] - nav.north_m, b_wp[1] - nav.east_m) < turn_radius:
            self.leg += 1
            a_wp, b_wp = wp[self.leg % len(wp)], wp[(self.leg + 1) % len(wp)]
        guidance = self.l1.update((nav.north_m, nav.east_m), (nav.v_north_mps, nav.v_east_mps), a_wp, b_wp)
        m = self.measurement
        point = self.schedule.at(m[0])
        energy = self.tecs.update(self.dt_s, m[0], -nav.v_down_mps, nav.tas_mps, nav.eas_to_tas, m[2],
                                  cfg.altitude_m, cfg.eas_mps, point.throttle_trim, point.tas_accel_per_throttle_mps2,
                                  math.radians(point.pitch_trim_deg))
        setpoint = np.array([guidance.roll_rad, energy.pitch_rad, cfg.eas_mps])
        self.navigation = nav
        self._pending = (nav, guidance.cross_track_m, setpoint, energy.throttle)
        if cfg.attitude_eas_demand == "measured":
            setpoint = np.array([setpoint[0], setpoint[1], m[EAS_INDEX]])
        return m, setpoint

    def advance(self, command) -> str | None:
        """Fly the step with the attitude controller's ``command`` (aileron, elevator, rudder in
        deg, throttle), TECS's throttle replacing its throttle; returns why the flight ended early,
        or None."""
        if self._pending is None:
            raise RuntimeError("advance() needs demand() first")
        nav, cross_track_m, setpoint, throttle = self._pending
        self._pending = None
        command = np.array(command, dtype=float)
        command[3] = throttle  # TECS's throttle replaces the attitude controller's
        k, cfg = self.k, self.config
        turbulent = self.leg in cfg.turbulence_legs
        self.core.turbulence_gain = 1.0 if turbulent else 0.0
        s = self.core.last_true_state
        self._rows[k] = (k * self.dt_s, nav.north_m, nav.east_m, s[0], s[1], s[2], nav.heading_rad, s[6], s[8],
                         setpoint[0], setpoint[1], setpoint[2], cross_track_m, self.leg, float(turbulent))
        self._commands[k] = command
        self._surfaces[k] = (math.degrees(s[9]), math.degrees(s[10]), math.degrees(s[11]), s[12])
        self.measurement = self.core.step(command)
        self.k = k + 1
        self.ended = self.core.envelope_violation()
        return self.ended

    def result(self) -> MissionResult:
        """The time histories flown so far."""
        n = self.k
        arrays = {name: self._rows[:n, j] for j, name in enumerate(_ROW_NAMES)}
        arrays["command"] = self._commands[:n]
        arrays["actuator"] = self._surfaces[:n]
        return MissionResult(self.config, arrays, self.ended)


def fly_route(controller: AttitudeController, config: RouteConfig | None = None,
              progress: Callable[[float], None] | None = None) -> MissionResult:
    """Fly ``config``'s route with ``controller`` for attitude; ``progress(fraction)`` is called
    about once per simulated 10 s."""
    flight = RouteFlight(config)
    controller.reset()
    every = int(10 * flight.config.control_rate_hz)
    while not flight.done:
        measurement, setpoint = flight.demand()
        flight.advance(controller.update(flight.dt_s, measurement, setpoint))
        if progress is not None and (flight.k - 1) % every == 0:
            progress((flight.k - 1) / flight.steps)
    return flight.result()


def result_to_npz(result: MissionResult, path) -> None:
    """Save a mission's time histories (and its settings as a JSON string)."""
    import json

    np.savez_compressed(path, config=json.dumps(asdict(result.config)), **result.arrays)

"""Route missions: TECS and L1 guidance feeding an attitude controller around a rectangle.

A mission starts in trimmed level flight at the route's altitude, at the first waypoint, heading
along the first leg, and flies the closed route of ``RouteConfig.waypoints_ne_m`` (by default a
rectangle of ``leg_north_m`` x ``leg_east_m``) until ``duration_s``. Every control step (25 Hz by
default):

1. L1 guidance gives the roll demand for the current leg; the next leg starts once the aircraft
   is within one turn radius (at the roll limit) of the leg's end.
2. TECS gives the pitch demand and the throttle for the route altitude and EAS.
3. The attitude controller (PID, trained policy, ...) turns the measurement and the demands
   (roll, pitch, EAS) into surface and throttle commands; TECS's throttle replaces its throttle,
   as in the paper.
4. The flight core applies the commands with its delay, actuator lag and rate limits, backlash,
   turbulence (on the chosen legs only), sensor noise and parameter set.

The result holds the time histories and the metrics of ``jsbsim_env.metrics``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from jsbsim_env.controllers.base import AttitudeController
from jsbsim_env.controllers.l1 import G_MPS2, L1Guidance, L1Params
from jsbsim_env.controllers.pid import GainSchedule
from jsbsim_env.controllers.tecs import TECS, TECSParams
from jsbsim_env.core import CoreConfig, FlightCore
from jsbsim_env.metrics import actuator_smoothness, rmse


@dataclass(frozen=True)
class RouteConfig:
    """One route flight. Distances in m, times in s, speeds in m/s, angles in degrees."""

    altitude_m: float = 10_000.0
    eas_mps: float = 10.0
    leg_north_m: float = 6_000.0
    leg_east_m: float = 3_000.0
    waypoints_ne_m: tuple[tuple[float, float], ...] | None = None  # None: the rectangle above
    duration_s: float = 2_400.0
    control_rate_hz: float = 25.0
    delay_s: float = 0.04  # one control step: measurement to actuator, as on the loop bench
    turbulence_legs: tuple[int, ...] = ()  # leg numbers (0 = first leg flown) with turbulence on
    turbulence_intensity: str = "paper"  # or a MIL-F-8785C severity (CoreConfig.turbulence_intensity)
    turbulence_sigma_mps: float = 0.5
    turbulence_clip: str = "4sigma"  # or "paper" (CoreConfig.turbulence_clip)
    parameters: str = "nominal"  # or "positive", "negative" (SPEC Table 9), or dist.RANDOMISED
    backlash_deg: float = 0.0
    sensor_noise: bool = True
    # SPEC Table 3 sigmas, but mean-reverting: the training setting's rate 0 is a random walk that
    # drifts about 1 deg of attitude in 40 minutes, where an INS (Table 5: within 0.1 deg) does
    # not drift. At 1/s the stationary attitude noise is sigma / sqrt(2) = 0.04 deg.
    noise_reversion_per_s: float = 1.0
    seed: int = 0
    tecs: TECSParams = field(default_factory=TECSParams)
    l1: L1Params = field(default_factory=L1Params)

    def waypoints(self) -> np.ndarray:
        if self.waypoints_ne_m is not None:
            wp = np.asarray(self.waypoints_ne_m, dtype=float)
        else:
            n, e = self.leg_north_m, self.leg_east_m
            wp = np.array([[0.0, 0.0], [n, 0.0], [n, e], [0.0, e]])
        if wp.ndim != 2 or wp.shape[1] != 2 or len(wp) < 2 or not np.all(np.isfinite(wp)):
            raise ValueError(f"route needs at least two finite (north, east) waypoints, got {wp.tolist()}")
        if np.any(np.hypot(*(np.roll(wp, -1, axis=0) - wp).T) < 1.0):
            raise ValueError("route has a leg shorter than 1 m")
        return wp

    def core_config(self) -> CoreConfig:
        """The flight core for this mission: fixed interval and delay, no start perturbation."""
        interval = 1.0 / self.control_rate_hz
        return CoreConfig(
            control_interval_s=(interval, interval), delay_s=(self.delay_s, self.delay_s),
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

    def metrics(self, start_s: float = 0.0, end_s: float = math.inf) -> dict[str, float]:
        """RMSE and mean absolute error of roll, pitch (deg), EAS (m/s) against their demands and
        of sideslip (deg) against zero, and Sm of each actuator command (``metrics.actuator_smoothness``),
        over [start_s, end_s)."""
        a, w = self.arrays, self.window(start_s, end_s)
        if not np.any(w):
            raise ValueError(f"no samples between {start_s} s and {end_s} s")
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


def fly_route(controller: AttitudeController, config: RouteConfig | None = None,
              progress: Callable[[float], None] | None = None) -> MissionResult:
    """Fly ``config``'s route with ``controller`` for attitude; ``progress(fraction)`` is called
    about once per simulated 10 s."""
    cfg = config or RouteConfig()
    waypoints = cfg.waypoints()
    dt = 1.0 / cfg.control_rate_hz
    steps = math.ceil(cfg.duration_s * cfg.control_rate_hz)
    core = FlightCore(cfg.core_config())
    first_leg = waypoints[1] - waypoints[0]
    heading_deg = math.degrees(math.atan2(first_leg[1], first_leg[0]))
    measurement = core.reset(cfg.seed, altitude_m=cfg.altitude_m, airspeed_eas_mps=cfg.eas_mps,
                             heading_deg=heading_deg)
    schedule = GainSchedule()
    tecs, l1 = TECS(cfg.tecs), L1Guidance(cfg.l1)
    tecs.reset()
    controller.reset()
    leg = 0
    names = ("time_s", "north_m", "east_m", "altitude_m", "roll_rad", "pitch_rad", "heading_rad", "eas_mps",
             "beta_rad", "roll_cmd_rad", "pitch_cmd_rad", "eas_cmd_mps", "cross_track_m", "leg", "turbulence")
    rows = np.full((steps, len(names)), np.nan)
    commands = np.full((steps, 4), np.nan)
    surfaces = np.full((steps, 4), np.nan)
    ended = None
    n_done = 0
    for k in range(steps):
        nav = core.navigation()
        a_wp, b_wp = waypoints[leg % len(waypoints)], waypoints[(leg + 1) % len(waypoints)]
        ground_speed = math.hypot(nav.v_north_mps, nav.v_east_mps)
        turn_radius = ground_speed ** 2 / (G_MPS2 * math.tan(cfg.l1.roll_limit_rad))
        to_b = math.hypot(b_wp[0] - nav.north_m, b_wp[1] - nav.east_m)
        if to_b < turn_radius:
            leg += 1
            a_wp, b_wp = waypoints[leg % len(waypoints)], waypoints[(leg + 1) % len(waypoints)]
        guidance = l1.update((nav.north_m, nav.east_m), (nav.v_north_mps, nav.v_east_mps), a_wp, b_wp)
        point = schedule.at(measurement[0])
        energy = tecs.update(dt, measurement[0], -nav.v_down_mps, nav.tas_mps, nav.eas_to_tas, measurement[2],
                             cfg.altitude_m, cfg.eas_mps, point.throttle_trim, point.tas_accel_per_throttle_mps2,
                             math.radians(point.pitch_trim_deg))
        setpoint = np.array([guidance.roll_rad, energy.pitch_rad, cfg.eas_mps])
        command = np.array(controller.update(dt, measurement, setpoint), dtype=float)
        command[3] = energy.throttle  # TECS's throttle replaces the attitude controller's
        turbulent = leg in cfg.turbulence_legs
        core.turbulence_gain = 1.0 if turbulent else 0.0
        s = core.last_true_state
        rows[k] = (k * dt, nav.north_m, nav.east_m, s[0], s[1], s[2], nav.heading_rad, s[6], s[8], setpoint[0],
                   setpoint[1], setpoint[2], guidance.cross_track_m, leg, float(turbulent))
        commands[k] = command
        surfaces[k] = (math.degrees(s[9]), math.degrees(s[10]), math.degrees(s[11]), s[12])
        measurement = core.step(command)
        n_done = k + 1
        ended = core.envelope_violation()
        if ended:
            break
        if progress is not None and k % int(10 * cfg.control_rate_hz) == 0:
            progress(k / steps)
    arrays = {name: rows[:n_done, j] for j, name in enumerate(names)}
    arrays["command"] = commands[:n_done]
    arrays["actuator"] = surfaces[:n_done]
    return MissionResult(cfg, arrays, ended)


def result_to_npz(result: MissionResult, path) -> None:
    """Save a mission's time histories (and its settings as a JSON string)."""
    import json

    np.savez_compressed(path, config=json.dumps(asdict(result.config)), **result.arrays)

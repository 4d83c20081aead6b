"""The flight core: one aircraft in JSBSim with every disturbance, flown one control interval at a time.

Every controller (the SAC policy, the PID baseline, the TECS/L1 missions) flies through this class,
so all see the same delay, noise, turbulence, parameter sets and backlash. It knows nothing about
goals or rewards (``jsbsim_env.task.attitude``); it takes actuator commands and returns measurements.

Timing, per episode (the paper's Section 3.4):

* the control interval is drawn from ``control_interval_s`` and then fixed; control instant k is
  at k * interval exactly, and the simulation (fixed rate ``sim_rate_hz``, because JSBSim's
  actuator filters are discretised for the rate they were loaded with) runs to the step nearest it;
* a command given at control instant k reaches the actuators ``delay`` later, at the first
  simulation step at or after that time, not at a whole control step;
* the measurement returned at instant k is the state at k plus Ornstein-Uhlenbeck noise.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from aircraft import AIRCRAFT_NAME, AircraftError, load_aircraft
from jsbsim_env.sim import disturbances as dist
from jsbsim_env.sim import turbulence as turb
from jsbsim_env.sim.model_check import SCALED_TERMS
from jsbsim_env.sim.simulation import (
    CONTROL_INPUTS,
    FT_TO_M,
    M_TO_FT,
    RHO0_KG_M3,
    RHO0_SLUG_FT3,
    SURFACE_LIMITS_DEG,
    Simulation,
)
from jsbsim_env.sim.trim_table import TrimTable

# The measured state (the paper's Eq. 18) in SI units: angles in rad, rates in rad/s, the three
# surfaces as positions in rad, the throttle as the rotor-speed reference over the full-throttle speed (0..1).
STATE_NAMES = ("altitude_m", "roll_rad", "pitch_rad", "p_radps", "q_radps", "r_radps", "airspeed_eas_mps",
               "alpha_rad", "beta_rad", "aileron_rad", "elevator_rad", "rudder_rad", "throttle")
N_STATE = len(STATE_NAMES)
# The paper's Table 3: OU noise sigma per state element (same order).
NOISE_SIGMA = np.array([0.0, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 0.01, 1e-3, 1e-3, 0.0, 0.0, 0.0, 0.0])
# Command order and the paper's aircraft's limits (its Table 2): aileron, elevator, rudder in
# degrees, throttle 0..1. Another aircraft's are its own travel (``FlightCore.command_low``/``high``,
# ``Aircraft.command_low``/``high``).
COMMAND_LOW = np.array([-SURFACE_LIMITS_DEG["aileron"], -SURFACE_LIMITS_DEG["elevator"], -SURFACE_LIMITS_DEG["rudder"],
                        0.0])
COMMAND_HIGH = -COMMAND_LOW + np.array([0.0, 0.0, 0.0, 1.0])
DEG_TO_RAD = math.pi / 180.0
EARTH_RADIUS_M = 6_371_000.0  # mean radius: local north/east over a route of tens of km


@dataclass(frozen=True)
class Envelope:
    """Where an episode ends early (a documented flight envelope: the paper's Section 2 and Table 1, and beyond)."""

    max_abs_roll_deg: float = 60.0
    max_abs_pitch_deg: float = 45.0
    alpha_range_deg: tuple[float, float] = (-20.0, 25.0)
    # None: the flown aircraft's EAS range widened as the paper's is (``ends_for``, which the flight
    # core applies: ``FlightCore.ends``): 8-12 m/s gives 4-25 m/s, 17-23 m/s gives 8.5-47.9 m/s.
    eas_range_mps: tuple[float, float] | None = None
    # Lower bound: height above the terrain (below it, a ground strike). The terrain lies
    # sim.TERRAIN_BELOW_FLOOR_M (100 m) below the envelope's floor (sea level for the paper's
    # aircraft), so an episode may start at the floor and ends 50 m below it. Upper bound: altitude
    # above sea level.
    altitude_range_m: tuple[float, float] = (50.0, 22000.0)


# Where the paper's aircraft's episodes end (4 and 25 m/s EAS) against its EAS range (8-12 m/s).
PAPER_EAS_ENDS_MPS, PAPER_EAS_RANGE_MPS = (4.0, 25.0), (8.0, 12.0)


def ends_for(envelope: Envelope, aircraft) -> Envelope:
    """``envelope`` with its EAS range the aircraft's (an ``aircraft.Aircraft``) where it gives none:
    its lowest and highest EAS scaled as the paper's aircraft's are (half its lowest, 25/12 of its
    highest; exactly 4 and 25 m/s for the paper's)."""
    if envelope.eas_range_mps is not None:
        return envelope
    low, high = aircraft.eas_range_mps
    return replace(envelope, eas_range_mps=(low * PAPER_EAS_ENDS_MPS[0] / PAPER_EAS_RANGE_MPS[0],
                                            high * PAPER_EAS_ENDS_MPS[1] / PAPER_EAS_RANGE_MPS[1]))


@dataclass(frozen=True)
class CoreConfig:
    """The aircraft, disturbances and episode start. Defaults are the paper's training setting (its
    aircraft, all disturbances on), but for the clip of the turbulence rates (``turbulence_clip``).

    ``aircraft`` is a name or path ``aircraft.load_aircraft`` reads; ``altitude_range_m`` and
    ``eas_range_mps``, where episodes start, are the aircraft's own (its description's
    ``[randomisation]``) when None."""

    aircraft: str = AIRCRAFT_NAME
    sim_rate_hz: float = 120.0
    control_interval_s: tuple[float, float] = (0.040, 0.060)
    delay_s: tuple[float, float] = (0.080, 0.120)
    sensor_noise: bool = True
    noise_reversion_per_s: float = 0.0  # "mean-reversion rate 0 (as printed)"
    parameters: str = dist.RANDOMISED  # Table 4 draw, or a fixed set: "nominal", "positive", "negative"
    turbulence: bool = True
    # "paper": turbulence_sigma_mps on each axis at every altitude (the paper); or a MIL-F-8785C
    # severity, "light", "moderate" or "severe", whose intensity falls with altitude.
    turbulence_intensity: str = turb.PAPER
    turbulence_sigma_mps: float = 0.5
    # "4sigma": each wind and rate channel clipped at 4 of its standard deviations, as rarely as
    # the paper's +-2 m/s wind clip at 0.5 m/s; "paper": +-2 m/s and +-0.3 deg/s, which holds the
    # rates at the clip 15-36 % of the time.
    turbulence_clip: str = "4sigma"
    backlash_deg: float = 0.0
    # Every surface servo's rate limit; None: the aircraft's own (its description's
    # actuators.surface_rate_limit_deg_per_s in its FlightControl.xml; the paper's: 100).
    servo_rate_limit_degps: float | None = None
    # Each episode's servo rate limit is the one above times a draw, uniform in its logarithm, from
    # this range (training on slow servos as well as the nominal one); (1, 1): no draw.
    servo_rate_scale: tuple[float, float] = (1.0, 1.0)
    noise_scale: float = 1.0  # multiplies every sigma of the paper's Table 3 (robustness sweeps)
    parameter_strength: float = 1.0  # multiplies each Table 4 draw's distance from 1 (0: nominal aircraft)
    altitude_range_m: tuple[float, float] | None = None  # None: the aircraft's start range
    eas_range_mps: tuple[float, float] | None = None  # None: the aircraft's start range
    # Start perturbation about the trim: uniform within +- these.
    perturb_attitude_deg: float = 5.0
    perturb_rate_degps: float = 2.0
    perturb_eas_mps: float = 1.0
    max_steps: int = 500  # turbulence is generated for this many control intervals
    envelope: Envelope = field(default_factory=Envelope)

    def __post_init__(self):
        if isinstance(self.aircraft, Path):  # a path is kept as text: the configuration is written as JSON
            object.__setattr__(self, "aircraft", str(self.aircraft))
        try:
            load_aircraft(self.aircraft)
        except AircraftError as err:
            raise ValueError(f"CoreConfig.aircraft: {err}") from None
        if not (self.noise_scale >= 0.0 and self.parameter_strength >= 0.0):
            raise ValueError(f"noise_scale and parameter_strength must be >= 0, got {self.noise_scale} and "
                             f"{self.parameter_strength}")
        if self.turbulence_intensity != turb.PAPER and self.turbulence_intensity not in turb.SEVERITIES:
            raise ValueError(f"turbulence_intensity {self.turbulence_intensity!r}: use {turb.PAPER!r} or one of "
                             f"{sorted(turb.SEVERITIES)}")
        if self.turbulence_clip not in turb.CLIPS:
            raise ValueError(f"turbulence_clip {self.turbulence_clip!r}: use one of {turb.CLIPS}")
        for name in ("delay_s", "control_interval_s"):
            low, high = getattr(self, name)
            if not (0.0 <= low <= high < math.inf):  # NaN fails too
                raise ValueError(f"{name} must be a finite range (low, high) with 0 <= low <= high, got {(low, high)}")
        if not self.control_interval_s[0] > 0.0:
            raise ValueError(f"control_interval_s must be positive, got {self.control_interval_s}")
        if not (0.0 <= self.turbulence_sigma_mps < math.inf):  # NaN fails too
            raise ValueError(f"turbulence_sigma_mps must be finite and >= 0, got {self.turbulence_sigma_mps}")
        if self.servo_rate_limit_degps is not None and not self.servo_rate_limit_degps > 0.0:  # NaN fails too
            raise ValueError(f"servo_rate_limit_degps must be positive, got {self.servo_rate_limit_degps}")
        low, high = self.servo_rate_scale
        object.__setattr__(self, "servo_rate_scale", (float(low), float(high)))  # a list read from JSON compares too
        if not 0.0 < low <= high < math.inf:  # NaN fails too
            raise ValueError(f"servo_rate_scale must be a finite range (low, high) with 0 < low <= high, "
                             f"got {(low, high)}")
        # The start ranges as ranges here; FlightCore checks them against where its aircraft can start.
        for name in ("altitude_range_m", "eas_range_mps"):
            if getattr(self, name) is None:
                continue
            low, high = getattr(self, name)
            if not (-math.inf < low <= high < math.inf):  # NaN fails too
                raise ValueError(f"{name} must be a finite range (low, high) with low <= high, got {(low, high)}")
        if not 0.0 < self.sim_rate_hz < math.inf:
            raise ValueError(f"sim_rate_hz must be positive and finite, got {self.sim_rate_hz}")
        for name in ("perturb_attitude_deg", "perturb_rate_degps", "perturb_eas_mps", "backlash_deg",
                     "noise_reversion_per_s"):
            if not 0.0 <= getattr(self, name) < math.inf:  # NaN fails too
                raise ValueError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        if isinstance(self.max_steps, bool) or not isinstance(self.max_steps, (int, np.integer)) or self.max_steps < 1:
            raise ValueError(f"max_steps must be a whole number >= 1, got {self.max_steps!r}")
        if self.parameters != dist.RANDOMISED and self.parameters not in dist.PARAMETER_SETS:
            raise ValueError(f"unknown parameter set {self.parameters!r}: use {dist.RANDOMISED!r} or one of "
                             f"{sorted(dist.PARAMETER_SETS)}")

    @classmethod
    def ideal(cls, **overrides) -> CoreConfig:
        """No disturbance at all: 50 ms interval, no delay, no noise, nominal aircraft, calm air."""
        base = cls(control_interval_s=(0.05, 0.05), delay_s=(0.0, 0.0), sensor_noise=False, parameters="nominal",
                   turbulence=False, perturb_attitude_deg=0.0, perturb_rate_degps=0.0, perturb_eas_mps=0.0)
        return replace(base, **overrides)


@dataclass
class EpisodeSetup:
    """What was drawn for the episode."""

    seed: int | None
    altitude_m: float
    airspeed_eas_mps: float
    control_interval_s: float
    delay_s: float
    scales: dict[str, float]
    trim_command: np.ndarray  # aileron, elevator, rudder (deg), throttle
    servo_rate_limit_degps: float  # every surface servo's, as flown


@dataclass(frozen=True)
class Navigation:
    """Local position (north and east of the episode's start, m), altitude, ground velocity
    (NED, m/s), true airspeed, V_tas / V_eas and heading."""

    north_m: float
    east_m: float
    altitude_m: float
    v_north_mps: float
    v_east_mps: float
    v_down_mps: float
    tas_mps: float
    eas_to_tas: float
    heading_rad: float


class CommandError(ValueError):
    """A command that is not finite or not inside the actuator ranges."""


def start_ranges(sim: Simulation, span_m: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Where an episode of ``sim``'s aircraft, of span ``span_m``, can start: altitude (m above sea
    level) and EAS (m/s). EAS: the envelope's, the trim table's range (outside it a start would take
    the nearest trim for its own). Altitude: up to the envelope's and the trim table's top; below
    the envelope's floor down to half the span above the terrain (``sim.terrain_elevation_m``),
    where no attitude puts a wing tip into it: such a start ends as a ground strike, as the tests of
    that check use it."""
    envelope = sim.aircraft
    return (sim.terrain_elevation_m + 0.5 * span_m, envelope.altitude_range_m[1]), envelope.eas_range_mps


def _start_value(name: str, value, limits: tuple[float, float], unit: str, why: str) -> float:
    """``value`` as a float when it lies in ``limits``; else one ``ValueError`` naming it and them."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not limits[0] <= x <= limits[1]:  # NaN fails too
        raise ValueError(f"{name} {x:g} {unit} is outside where an episode can start: {limits[0]:g}..{limits[1]:g} "
                         f"{unit} ({why})")
    return x


class FlightCore:
    """One aircraft with delay, noise, turbulence, parameter sets and backlash.

    Args:
        config: the aircraft (``CoreConfig.aircraft``; episodes start from its trim), disturbances
            and episode start.
    """

    def __init__(self, config: CoreConfig | None = None):
        self.config = config or CoreConfig()
        self.aircraft = load_aircraft(self.config.aircraft)
        self.trim_table = TrimTable.shared(self.aircraft)
        # Where episodes start when not told: the configuration's ranges, or the aircraft's own.
        self.altitude_range_m = self.config.altitude_range_m or self.aircraft.start_altitude_range_m
        self.eas_range_mps = self.config.eas_range_mps or self.aircraft.start_eas_range_mps
        self.noise = dist.OrnsteinUhlenbeckNoise([self.config.noise_scale * s for s in NOISE_SIGMA],
                                                 self.config.noise_reversion_per_s)
        self._load()
        # The commands' range is the aircraft's own travel; JSBSim's normalised commands are
        # fractions of it.
        self.command_low, self.command_high = np.array(self.aircraft.command_low), np.array(self.aircraft.command_high)
        limits = self.sim.surface_limits_deg
        self._command_scale = (1.0 / limits["aileron"], 1.0 / limits["elevator"], 1.0 / limits["rudder"], 1.0)
        self.start_altitude_range_m, self.start_eas_range_mps = start_ranges(self.sim, self.span_m)
        # The default ends must lie outside the aircraft's envelope; an Envelope given is the user's
        # choice (the tests end episodes on purpose with one).
        # Where its episodes end: the configuration's envelope, its EAS range the aircraft's where it gives none.
        self.ends = ends = ends_for(self.config.envelope, self.aircraft)
        if self.config.envelope == Envelope() and not (ends.eas_range_mps[0] < self.aircraft.eas_range_mps[0]
                and self.aircraft.eas_range_mps[1] < ends.eas_range_mps[1]
                and self.aircraft.altitude_range_m[1] < ends.altitude_range_m[1]):
            raise ValueError(f"{self.aircraft.name}'s envelope (EAS {self.aircraft.eas_range_mps[0]:g}-"
                             f"{self.aircraft.eas_range_mps[1]:g} m/s, up to {self.aircraft.altitude_range_m[1]:g} m) "
                             f"reaches where an episode ends (CoreConfig.envelope: EAS {ends.eas_range_mps[0]:g}-"
                             f"{ends.eas_range_mps[1]:g} m/s, up to {ends.altitude_range_m[1]:g} m); give "
                             "CoreConfig an Envelope beyond it")
        for name, (low, high), limits, unit, why in (
                ("altitude_range_m", self.altitude_range_m, self.start_altitude_range_m, "m", self._altitude_why),
                ("eas_range_mps", self.eas_range_mps, self.start_eas_range_mps, "m/s", self._eas_why)):
            for value in (low, high):
                _start_value(f"CoreConfig.{name}", value, limits, unit, why)
        self.setup: EpisodeSetup | None = None
        self.rng = np.random.default_rng()
        # Multiplies the turbulence series: missions switch it between 0 and 1 by route leg.
        self.turbulence_gain = 1.0
        self._nav_origin: tuple[float, float] | None = None  # latitude, longitude of the episode start

    def _load(self) -> None:
        """A fresh JSBSim instance, with direct accessors to the properties used every step."""
        self.sim = Simulation(self.aircraft, sim_rate_hz=self.config.sim_rate_hz)
        self.dt_s = self.sim.dt_s
        self.span_m = self.sim["metrics/bw-ft"] * FT_TO_M
        f = self.sim.fdm
        pm = f.get_property_manager()

        def getter(name):
            return pm.get_node(name, False).get_double_value

        def setter(name):
            return pm.get_node(name, False).set_double_value

        self._run = f.run
        self._get_state = [getter(n) for n in (
            "position/h-sl-meters", "attitude/phi-rad", "attitude/theta-rad", "velocities/p-rad_sec",
            "velocities/q-rad_sec", "velocities/r-rad_sec", "velocities/vt-fps", "aero/alpha-rad", "aero/beta-rad",
            "fcs/aileron-pos-deg", "fcs/elevator-pos-deg", "fcs/rudder-pos-deg", "fcs/throttle-ref-norm",
            "atmosphere/rho-slugs_ft3", "attitude/psi-rad", "position/h-agl-ft")]
        self._set_command = [setter(n) for n in CONTROL_INPUTS]
        self._set_gust = [setter(f"atmosphere/gust-{a}-fps") for a in ("north", "east", "down")]
        self._set_gust_rate = [setter(f"atmosphere/gust-{a}-rad_sec") for a in "pqr"]

    @property
    def _altitude_why(self) -> str:
        low, high = self.aircraft.altitude_range_m
        return (f"{self.aircraft.name}'s flight envelope is {low:g}..{high:g} m; below it a start must "
                f"clear the terrain at {self.sim.terrain_elevation_m:g} m by half the {self.span_m:.3g} m span")

    @property
    def _eas_why(self) -> str:
        return "the EAS range of the trim table the start is trimmed from"

    # ------------------------------------------------------------------ episode start
    def reset(self, seed: int | None = None, altitude_m: float | None = None,
              airspeed_eas_mps: float | None = None, parameters: str | None = None,
              heading_deg: float | None = None) -> np.ndarray:
        """Start an episode: draw its setting, trim, perturb. Returns the first measurement.

        ``altitude_m``, ``airspeed_eas_mps``, ``parameters`` and ``heading_deg`` override the
        draws (evaluation, missions). An altitude or EAS outside where an episode can start
        (``start_ranges``: ``start_altitude_range_m``, ``start_eas_range_mps``), or not a number,
        and a heading that is not finite are refused (``ValueError``) before anything changes.
        """
        cfg = self.config
        if altitude_m is not None:
            _start_value("altitude_m", altitude_m, self.start_altitude_range_m, "m", self._altitude_why)
        if airspeed_eas_mps is not None:
            _start_value("airspeed_eas_mps", airspeed_eas_mps, self.start_eas_range_mps, "m/s", self._eas_why)
        if heading_deg is not None:
            try:
                finite = math.isfinite(float(heading_deg))
            except (TypeError, ValueError):
                finite = False
            if not finite:
                raise ValueError(f"heading_deg must be a finite number, got {heading_deg!r}")
        self.rng = rng = np.random.default_rng(seed)
        # Draw everything up front, in a fixed order, so that overrides do not shift later draws.
        alt = float(rng.uniform(*self.altitude_range_m))
        eas = float(rng.uniform(*self.eas_range_mps))
        interval = float(rng.uniform(*cfg.control_interval_s))
        delay = float(rng.uniform(*cfg.delay_s))
        perturb = rng.uniform(-1.0, 1.0, size=7)
        drawn_scales = dist.draw_scales(dist.RANDOMISED, rng)  # drawn even when a fixed set overrides it
        chosen = parameters or cfg.parameters
        if chosen == dist.RANDOMISED:
            k = cfg.parameter_strength  # applied after the draw, so the random stream is the same
            scales = drawn_scales if k == 1.0 else {name: 1.0 + k * (v - 1.0) for name, v in drawn_scales.items()}
        else:
            scales = dist.draw_scales(chosen, rng)
        turbulence_seed = int(rng.integers(2**31 - 1))
        jsbsim_seed = int(rng.integers(2**31 - 1))
        noise_seed = int(rng.integers(2**63))
        alt = alt if altitude_m is None else float(altitude_m)
        eas = eas if airspeed_eas_mps is None else float(airspeed_eas_mps)
        heading = float(perturb[6] * 180.0) if heading_deg is None else float(heading_deg)

        # A fresh JSBSim instance per episode (about 10 ms): JSBSim's initial-condition setters
        # keep quantities from the previous state, which leaves round-off differences between
        # episodes with the same seed. A fresh instance makes each episode a function of its seed alone.
        self._load()
        sim, f = self.sim, self.sim.fdm
        f["simulation/randomseed"] = jsbsim_seed
        for term in SCALED_TERMS:
            f[f"aero/scale/{term}"] = scales.get(term, 1.0)
        f["fcs/backlash-width-deg"] = cfg.backlash_deg
        if cfg.servo_rate_limit_degps is not None:  # else the model's own, as its file sets it
            f["fcs/surface-rate-limit-deg_s"] = cfg.servo_rate_limit_degps
        if cfg.servo_rate_scale != (1.0, 1.0):  # drawn last, and only here, so other streams stay as they were
            scale = math.exp(rng.uniform(*np.log(cfg.servo_rate_scale)))
            f["fcs/surface-rate-limit-deg_s"] = scale * f["fcs/surface-rate-limit-deg_s"]
        servo_rate = float(f["fcs/surface-rate-limit-deg_s"])
        for s in self._set_gust + self._set_gust_rate:
            s(0.0)
        # The nominal aircraft's trim, interpolated; with scaled coefficients the start is then
        # slightly off trim, which the perturbation below dwarfs.
        trim = self.trim_table.lookup(alt, eas)
        rho_ratio = sim.density_kg_m3(alt) / RHO0_KG_M3
        tas = eas / math.sqrt(rho_ratio)
        sim.set_initial_conditions(alt, tas, alpha_deg=trim.alpha_deg, beta_deg=trim.beta_deg)
        # Bring actuators and rotors (at rest in a fresh instance) to the trim commands.
        trim_command = np.array([trim.aileron_deg, trim.elevator_deg, trim.rudder_deg, trim.throttle])
        self._write_command(trim_command)
        sim.settle_actuators(fast=True)
        att = np.radians(cfg.perturb_attitude_deg) * perturb[:2]
        rates = np.radians(cfg.perturb_rate_degps) * perturb[2:5]
        eas0 = eas + cfg.perturb_eas_mps * perturb[5]
        tas0 = eas0 / math.sqrt(rho_ratio)
        sim.set_initial_conditions(alt, tas0, alpha_deg=trim.alpha_deg, pitch_deg=trim.alpha_deg + math.degrees(att[1]),
                                   roll_deg=math.degrees(att[0]), heading_deg=heading, beta_deg=trim.beta_deg,
                                   rates_radps=tuple(rates))
        self.setup = EpisodeSetup(seed, alt, eas, interval, delay, scales, trim_command, servo_rate)
        self.turbulence = None
        if cfg.turbulence:
            self.turbulence = turb.dryden_series(cfg.max_steps + 1, alt, tas, self.span_m, interval,
                                                 np.random.default_rng(turbulence_seed), cfg.turbulence_intensity,
                                                 cfg.turbulence_sigma_mps, cfg.turbulence_clip)
            # Plain lists: indexing them every step is several times cheaper than numpy rows.
            self._gust_wind = self.turbulence.wind_mps.tolist()
            self._gust_rate = self.turbulence.rate_radps.tolist()
        self.noise.reset(np.random.default_rng(noise_seed), cfg.max_steps + 1)
        self.step_index = 0
        self.sim_steps = 0
        self._pending: deque[tuple[int, np.ndarray]] = deque()
        self.applied_command = trim_command.copy()
        self._nav_origin = None
        self._apply_gusts()
        return self._measure()

    # ------------------------------------------------------------------ stepping
    def check_command(self, command: np.ndarray) -> np.ndarray:
        """Validate a physical command (aileron, elevator, rudder in deg, throttle 0..1)."""
        command = np.asarray(command, dtype=float)
        if command.shape != (4,):
            raise CommandError(f"command must have 4 elements (aileron, elevator, rudder, throttle), got {command.shape}")
        # Written so that NaN fails too (every comparison with NaN is false).
        if not (np.all(command >= self.command_low - 1e-9) and np.all(command <= self.command_high + 1e-9)):
            raise CommandError(f"command {command} is not finite or outside {self.aircraft.name}'s range "
                               f"[{self.command_low}, {self.command_high}]")
        return command

    def step(self, command: np.ndarray, checked: bool = False) -> np.ndarray:
        """Give ``command`` at the current control instant and fly to the next one.

        Returns the measurement at the next control instant. ``checked`` skips the validation
        of a command that its caller built from a validated action.
        """
        self.fly(command if checked else self.check_command(command))
        return self._measure()

    def fly(self, command) -> None:
        """``step`` without the validation and the measurement (the batched task measures itself).

        ``command``: aileron, elevator, rudder (deg), throttle; any sequence of 4 floats.
        """
        setup = self.setup
        if setup is None:
            raise RuntimeError("the flight core has no episode: call reset() before step()")
        k = self.step_index
        # Simulation step at which the command reaches the actuators, and the one that ends the interval.
        apply_at = math.ceil((k * setup.control_interval_s + setup.delay_s) / self.dt_s - 1e-9)
        self._pending.append((apply_at, command))
        end = round((k + 1) * setup.control_interval_s / self.dt_s)
        pending, run = self._pending, self._run
        n = self.sim_steps
        while n < end:
            while pending and pending[0][0] <= n:
                self._write_command(pending.popleft()[1])
            run()
            n += 1
        self.sim_steps = n
        self.step_index = k + 1
        self._apply_gusts()

    def _write_command(self, command) -> None:
        self.applied_command = command
        for s, v, k in zip(self._set_command, command, self._command_scale):
            s(v * k)

    def _apply_gusts(self) -> None:
        """Hold the turbulence sample of this control interval (zero-order hold)."""
        if self.turbulence is None:
            return
        k = min(self.step_index, len(self._gust_wind) - 1)
        g = self._get_state
        gain = self.turbulence_gain
        ned = turb.body_to_ned(g[1](), g[2](), g[14](), self._gust_wind[k])
        for s, v in zip(self._set_gust, ned):
            s(gain * v * M_TO_FT)
        for s, v in zip(self._set_gust_rate, self._gust_rate[k]):
            s(gain * v)

    def gust_now(self) -> list[float]:
        """The turbulence sample held over this control interval: body-axis wind u, v, w (m/s) and
        rates p, q, r (rad/s); zeros without turbulence. Not measurable on the aircraft: for a
        critic's privileged information and for analysis."""
        if self.turbulence is None:
            return [0.0] * 6
        k = min(self.step_index, len(self._gust_wind) - 1)
        g = self.turbulence_gain
        return [g * v for v in self._gust_wind[k]] + [g * v for v in self._gust_rate[k]]

    # ------------------------------------------------------------------ measurements

    def true_state(self) -> list[float]:
        """The state of the paper's Eq. 18 without noise (see ``STATE_NAMES``) as a list."""
        g = self._get_state
        return [g[0](), g[1](), g[2](), g[3](), g[4](), g[5](), math.sqrt(g[13]() / RHO0_SLUG_FT3) * g[6]() * FT_TO_M,
                g[7](), g[8](), g[9]() * DEG_TO_RAD, g[10]() * DEG_TO_RAD, g[11]() * DEG_TO_RAD,
                g[12]()]

    def height_above_ground_m(self) -> float:
        """Height above the simulated terrain (``sim.terrain_elevation_m``), for the ground-strike check."""
        return self._get_state[15]() * FT_TO_M

    def _measure(self) -> np.ndarray:
        state = self.true_state()
        self.last_true_state = state
        if self.config.sensor_noise:
            return np.array(state) + self.noise.step(self.setup.control_interval_s, self.rng)
        return np.array(state)

    @property
    def time_s(self) -> float:
        return self.sim_steps * self.dt_s

    def navigation(self) -> Navigation:
        """Position and velocity as a GNSS/INS would give them (true values)."""
        f, g = self.sim.fdm, self._get_state  # g: the cached accessors of ``_load``
        lat, lon = f["position/lat-geod-rad"], f["position/long-gc-rad"]
        if self._nav_origin is None:
            self._nav_origin = (lat, lon)
        lat0, lon0 = self._nav_origin
        altitude_m = g[0]()
        radius = EARTH_RADIUS_M + altitude_m
        return Navigation(
            north_m=(lat - lat0) * radius, east_m=(lon - lon0) * math.cos(lat0) * radius,
            altitude_m=altitude_m,
            v_north_mps=f["velocities/v-north-fps"] * FT_TO_M, v_east_mps=f["velocities/v-east-fps"] * FT_TO_M,
            v_down_mps=f["velocities/v-down-fps"] * FT_TO_M, tas_mps=g[6]() * FT_TO_M,
            eas_to_tas=1.0 / math.sqrt(g[13]() / RHO0_SLUG_FT3), heading_rad=g[14](),
        )

    def envelope_violation(self) -> str | None:
        """Why the aircraft has left the flight envelope, or None."""
        code = envelope_code(self.last_true_state, self.height_above_ground_m(), self.ends)
        return termination_reason(code, self.ends)


# Episode-end causes, in the order they are checked; code 0 is "inside the envelope".
TERMINATION_CAUSES = ("", "non-finite state", "ground strike", "altitude too high", "roll limit", "pitch limit",
                      "angle of attack limit", "airspeed limit")


@functools.lru_cache(maxsize=16)
def _envelope_bounds(env: Envelope) -> tuple[float, ...]:
    r = math.radians
    return (env.altitude_range_m[0], env.altitude_range_m[1], r(env.max_abs_roll_deg), r(env.max_abs_pitch_deg),
            r(env.alpha_range_deg[0]), r(env.alpha_range_deg[1]), env.eas_range_mps[0], env.eas_range_mps[1])


def envelope_code(state, height_agl_m: float, env: Envelope) -> int:
    """Index into ``TERMINATION_CAUSES`` for one state (``STATE_NAMES`` order); 0 inside the envelope."""
    agl_min, alt_max, roll_max, pitch_max, alpha_lo, alpha_hi, eas_lo, eas_hi = _envelope_bounds(env)
    if not math.isfinite(sum(state) + height_agl_m):  # NaN and inf propagate through the sum
        return 1
    if height_agl_m < agl_min:
        return 2
    if state[0] > alt_max:
        return 3
    if abs(state[1]) > roll_max:
        return 4
    if abs(state[2]) > pitch_max:
        return 5
    if not alpha_lo <= state[7] <= alpha_hi:
        return 6
    if not eas_lo <= state[6] <= eas_hi:
        return 7
    return 0


def termination_reason(code: int, env: Envelope) -> str | None:
    """A readable reason for an ``envelope_code``, with the limit that was passed."""
    if code == 0:
        return None
    limits = {3: f" ({env.altitude_range_m[1]:g} m)", 4: f" ({env.max_abs_roll_deg:g} deg)",
              5: f" ({env.max_abs_pitch_deg:g} deg)", 6: f" ({env.alpha_range_deg[0]:g}..{env.alpha_range_deg[1]:g} deg)",
              7: f" ({env.eas_range_mps[0]:g}..{env.eas_range_mps[1]:g} m/s EAS)",
              2: f" (below {env.altitude_range_m[0]:g} m above ground)"}
    return TERMINATION_CAUSES[code] + limits.get(int(code), "")

"""Gain-scheduled PID attitude controller: the classical baseline.

| loop | law (errors are measurement minus command) |
|---|---|
| pitch | elevator = trim + q_s (k_pitch e_pitch + k_q q) + integral of q_s k_pitch_i e_pitch |
| airspeed | throttle = trim - k_eas e_eas - integral of k_eas_i e_eas |
| roll | aileron = q_s (k_roll e_roll + k_p p) + integral of q_s k_roll_i e_roll |
| yaw | rudder = q_s (k_r washout(r) + k_beta beta); the washout (2 s) lets steady turns be |

Positive elevator pitches the nose down, positive aileron rolls left and positive rudder yaws
left (the paper's sign conventions), hence the signs. The gains come from ``tuning`` at each altitude
of ``DESIGN_ALTITUDES_M`` at EAS 10 m/s and are stored, with the trim data TECS uses, in
``pid_gains.json``
(``scripts/tune_pid.py`` writes it). In flight they are interpolated in altitude, and the
surface gains are scaled by q_s = (10 m/s / V_eas)^2 because control moments grow with
dynamic pressure. Integrators stop integrating while their actuator is saturated in the same
direction (anti-windup) and are bounded.
"""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from aircraft import load_aircraft
from jsbsim_env.control import gain_files, tuning
from jsbsim_env.sim.simulation import Simulation

DESIGN_ALTITUDES_M = (500.0, 1000.0, 2000.0, 5000.0, 10000.0, 15000.0, 20000.0)
DESIGN_EAS_MPS = 10.0
GAINS_PATH = gain_files.PACKAGED_DIR / gain_files.FILES["pid"]  # the paper's aircraft's
SURFACE_INTEGRATOR_LIMIT_DEG = 15.0
THROTTLE_INTEGRATOR_LIMIT = 0.5
MIN_EAS_FOR_SCALING_MPS = 6.0  # below this the dynamic-pressure scaling stops growing


@dataclass(frozen=True)
class DesignPoint:
    """PID gains at one design point and the trim data the outer loops use. Gains: surfaces in deg
    per rad, per rad/s or per rad s; throttle per m/s or per m."""

    k_pitch: float
    k_q: float
    k_pitch_i: float
    k_eas: float
    k_eas_i: float
    k_roll: float
    k_p: float
    k_roll_i: float
    k_r: float
    k_beta: float
    elevator_trim_deg: float
    throttle_trim: float
    pitch_trim_deg: float  # level flight
    tas_accel_per_throttle_mps2: float  # dV_tas/dt per unit throttle at trim (for TECS)


def design_gains(sim: Simulation, altitude_m: float, eas_mps: float = DESIGN_EAS_MPS,
                 start: DesignPoint | None = None) -> DesignPoint:
    """Tune both blocks at one flight condition (``tuning``), from ``start``'s gains if given."""
    plant = tuning.LinearPlant.at(sim, altitude_m, eas_mps)
    long_start = None if start is None else np.array([getattr(start, n) for n in tuning.LONG_GAIN_NAMES])
    lat_start = None if start is None else np.array([getattr(start, n) for n in tuning.LAT_GAIN_NAMES])
    long_gains = tuning.tune(tuning.LoopDesign(plant, lateral=False), long_start)
    lat_gains = tuning.tune(tuning.LoopDesign(plant, lateral=True), lat_start)
    return DesignPoint(*map(float, long_gains), *map(float, lat_gains), plant.elevator_trim_deg, plant.throttle_trim,
                       plant.pitch_trim_deg, float(plant.b_long[0, 3]))


def write_gain_table(path: Path = GAINS_PATH, altitudes_m=DESIGN_ALTITUDES_M, progress=None, aircraft=None,
                     eas_mps: float = DESIGN_EAS_MPS) -> dict:
    """Design ``aircraft`` (the paper's by default) at every altitude at ``eas_mps`` and write the
    table as JSON; returns it.

    Each altitude starts its search from the gains of the one below (continuation), so the
    schedule follows one family of solutions instead of hopping between local optima."""
    sim = Simulation(aircraft)
    rows = []
    previous = None
    for h in altitudes_m:
        previous = design_gains(sim, h, eas_mps, start=previous)
        rows.append({"altitude_m": float(h), **asdict(previous)})
        if progress:
            progress(rows[-1])
    table = {"controller": "pid", "design_eas_mps": float(eas_mps), "method": "jsbsim_env.control.tuning",
             "points": rows}
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(table, indent=1))
    tmp.replace(path)
    return table


def read_gain_file(path: Path | str, what: str) -> dict:
    """A gain table file (the PID's or the LQI's): its JSON, or ``ValueError`` naming ``what`` and the
    file, also where it is no table or records another controller (``recorded_controller``)."""
    try:
        table = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{what} gain table {path} is missing or malformed: {exc}") from exc
    if not isinstance(table, dict):
        kind = type(table).__name__
        raise ValueError(f"{what} gain table {path} is malformed: a JSON object with its points expected, got {kind}")  # noqa: TRY004
    recorded = recorded_controller(table)
    if recorded is not None and recorded != what.lower():
        raise ValueError(f"{what} gain table {path} records the {recorded.upper()}'s gains, not the {what}'s")
    return table


def recorded_controller(table: dict) -> str | None:
    """The controller a gain table says it is for ("pid" or "lqi": its ``controller`` entry, or its
    tuning record's), None where it does not say (tables written before they recorded it)."""
    tuning = table.get("tuning")
    value = table.get("controller", tuning.get("controller") if isinstance(tuning, dict) else None)
    return value if isinstance(value, str) else None


# A trim a table may hold: surfaces and attitudes within what any aircraft here flies, the throttle in
# its range. A trim beyond them is a table of another aircraft or an edit, and every flight would end.
TRIM_LIMITS = {"elevator_trim_deg": (-45.0, 45.0), "throttle_trim": (0.0, 1.0), "pitch_trim_deg": (-30.0, 30.0),
               "alpha_trim_deg": (-30.0, 30.0)}


def check_trims(table: dict, path: Path | str, what: str) -> None:
    """Every design point's trims (``TRIM_LIMITS``, those it has) within their limits; ``ValueError``
    naming the point, the trim and the limit otherwise."""
    for point in table["points"]:
        for name, (low, high) in TRIM_LIMITS.items():
            value = point.get(name)
            if value is not None and not low <= value <= high:
                raise ValueError(f"{what} gain table {path}: {name} {value:g} at {point['altitude_m']:g} m is outside "
                                 f"[{low:g}, {high:g}], an impossible trim")


def design_eas_of(table: dict, path: Path | str, what: str) -> float:
    """The EAS a gain table was designed at (m/s; ``DESIGN_EAS_MPS`` in a table that does not say),
    which the dynamic-pressure scaling of its gains divides by."""
    value = table.get("design_eas_mps", DESIGN_EAS_MPS)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value < math.inf:
        raise ValueError(f"{what} gain table {path}: design_eas_mps must be a positive number, got {value!r}")
    return float(value)


def altitude_points(table: dict, columns, path: Path | str, what: str) -> tuple[np.ndarray, np.ndarray]:
    """The design altitudes (m) and, a row each, the ``columns`` of a gain table's ``points``;
    ``ValueError`` naming ``what`` and ``path`` unless they are finite, at increasing altitudes."""
    try:
        points = table["points"]
        altitudes_m = np.array([p["altitude_m"] for p in points], dtype=float)
        values = np.array([[float(p[n]) for n in columns] for p in points])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{what} gain table {path} is missing or malformed: {exc}") from exc
    if len(altitudes_m) == 0 or np.any(np.diff(altitudes_m) <= 0) or not np.all(np.isfinite(values)):
        raise ValueError(f"{what} gain table {path} needs finite gains at increasing altitudes")
    return altitudes_m, values


# The sign of each feedback gain under this controller's conventions: a gain of the other sign
# feeds its error back the wrong way (every design here, the tuned ones included, keeps them).
GAIN_SIGNS = {"k_pitch": 1, "k_q": 1, "k_pitch_i": 1, "k_eas": 1, "k_eas_i": 1, "k_roll": 1, "k_p": 1,
              "k_roll_i": 1, "k_r": 1, "k_beta": -1}


class GainSchedule:
    """The stored gain table, interpolated in altitude (held constant beyond its ends)."""

    def __init__(self, path: Path | str = GAINS_PATH):
        self._load(read_gain_file(path, "PID"), path)

    @classmethod
    def from_table(cls, table: dict, source: str = "(in memory)") -> GainSchedule:
        """The schedule of a gain table already read (``write_gain_table``'s layout); ``source``
        names it in errors."""
        schedule = cls.__new__(cls)
        schedule._load(table, source)
        return schedule

    def _load(self, table: dict, path: Path | str) -> None:
        names = [f.name for f in fields(DesignPoint)]
        self.altitudes_m, self.values = altitude_points(table, names, path, "PID")
        self.design_eas_mps = design_eas_of(table, path, "PID")
        check_trims(table, path, "PID")
        for column, name in enumerate(names):
            sign = GAIN_SIGNS.get(name)
            if sign is not None and not np.all(sign * self.values[:, column] >= 0.0):
                raise ValueError(f"PID gain table {path}: {name} must be {'>=' if sign > 0 else '<='} 0 at every "
                                 f"altitude (its sign convention), got {self.values[:, column].tolist()}")

        # Plain floats: read every control step, on one altitude, where np.interp's per-call cost
        # (about 1.5 us a column) dominates.
        self._altitudes = self.altitudes_m.tolist()
        self._columns = self.values.T.tolist()

    def at(self, altitude_m: float) -> DesignPoint:
        return DesignPoint(*self.interpolate(altitude_m, range(len(self._columns))))

    def interpolate(self, altitude_m: float, columns) -> list[float]:
        """The gains of the given columns (``DesignPoint`` field order) at this altitude: linear
        between the design points, held beyond them; the very arithmetic of ``np.interp``, so the
        result is the same to the last bit."""
        alts, x = self._altitudes, float(altitude_m)
        if math.isnan(x):  # NaN in, NaN out, as np.interp
            return [math.nan for _ in columns]
        if x >= alts[-1]:
            return [self._columns[c][-1] for c in columns]
        if x <= alts[0]:
            return [self._columns[c][0] for c in columns]
        j = bisect_right(alts, x) - 1
        if alts[j] == x:
            return [self._columns[c][j] for c in columns]
        dx = x - alts[j]
        span = alts[j + 1] - alts[j]
        return [(col[j + 1] - col[j]) / span * dx + col[j] for col in (self._columns[c] for c in columns)]


class PIDAttitudeController:
    """Gain-scheduled PID on pitch, airspeed, roll and yaw (module docstring); shares the
    ``controllers.base.AttitudeController`` interface."""

    def __init__(self, schedule: GainSchedule | None = None, gains_path: Path | str | None = None, aircraft=None):
        """``schedule``, or the gain table at ``gains_path`` (a tuned one), or ``aircraft``'s table
        (``gain_files.gain_file``; the paper's aircraft's ``pid_gains.json`` by default). Commands
        are clipped to ``aircraft``'s travel (the paper's aircraft's by default), whichever table flies."""
        if schedule is not None and gains_path is not None:
            raise ValueError("give a schedule or a gain file, not both")
        self.schedule = schedule or GainSchedule(gain_files.gain_file("pid", aircraft) if gains_path is None
                                                 else gains_path)
        self._design_eas_mps = self.schedule.design_eas_mps
        flown = load_aircraft(aircraft)
        self._command_low, self._command_high = np.array(flown.command_low), np.array(flown.command_high)
        self.reset()

    def reset(self) -> None:
        self.i_pitch_deg = self.i_roll_deg = self.i_throttle = 0.0
        self.r_low_radps: float | None = None  # low-passed yaw rate; washout = r - r_low
        self.last_command = np.zeros(4)

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"control interval must be positive and finite, got {dt_s}")
        m = np.asarray(measurement, dtype=float)
        sp = np.asarray(setpoint, dtype=float)
        if m.shape != (13,) or sp.shape != (3,) or not (np.all(np.isfinite(m)) and np.all(np.isfinite(sp))):
            raise ValueError(f"measurement (13,) and setpoint (3,) must be finite; got {m} and {sp}")
        altitude, roll, pitch, p, q, r, eas, beta = m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[8]
        g = self.schedule.at(altitude)
        q_s = (self._design_eas_mps / max(eas, MIN_EAS_FOR_SCALING_MPS)) ** 2
        e_roll, e_pitch, e_eas = roll - sp[0], pitch - sp[1], eas - sp[2]
        if self.r_low_radps is None:
            self.r_low_radps = r
        washed = r - self.r_low_radps
        self.r_low_radps += dt_s / tuning.WASHOUT_S * (r - self.r_low_radps)

        aileron = q_s * (g.k_roll * e_roll + g.k_p * p) + self.i_roll_deg
        elevator = g.elevator_trim_deg + q_s * (g.k_pitch * e_pitch + g.k_q * q) + self.i_pitch_deg
        rudder = q_s * (g.k_r * washed + g.k_beta * beta)
        command = np.array([aileron, elevator, rudder, self._speed_loop(dt_s, g, e_eas)])
        clipped = np.clip(command, self._command_low, self._command_high)

        # Integrate unless the actuator is saturated in the direction the integral would push it.
        lim = SURFACE_INTEGRATOR_LIMIT_DEG
        self.i_roll_deg = _integrate(self.i_roll_deg, q_s * g.k_roll_i * e_roll * dt_s, command[0], clipped[0], lim)
        self.i_pitch_deg = _integrate(self.i_pitch_deg, q_s * g.k_pitch_i * e_pitch * dt_s, command[1], clipped[1],
                                      lim)
        self.last_command = clipped
        return clipped

    def throttle(self, dt_s: float, altitude_m: float, eas_mps: float, eas_goal_mps: float) -> float:
        """The airspeed loop alone (a speed hold): the throttle for the measured and demanded EAS,
        advancing only its integrator. Inputs are trusted (the training hot path)."""
        return self._speed_loop(dt_s, self.schedule.at(altitude_m), eas_mps - eas_goal_mps)

    def _speed_loop(self, dt_s: float, g: DesignPoint, e_eas: float) -> float:
        """Clipped throttle for the EAS error (measured minus demanded); integrates with anti-windup."""
        raw = g.throttle_trim - g.k_eas * e_eas + self.i_throttle
        clipped = min(max(raw, 0.0), 1.0)  # the throttle's range
        self.i_throttle = _integrate(self.i_throttle, -g.k_eas_i * e_eas * dt_s, raw, clipped,
                                     THROTTLE_INTEGRATOR_LIMIT)
        return clipped


def _integrate(state: float, increment: float, command: float, clipped: float, limit: float) -> float:
    if (command > clipped and increment > 0.0) or (command < clipped and increment < 0.0):
        return state
    return min(max(state + increment, -limit), limit)


__all__ = [
    "DESIGN_ALTITUDES_M",
    "DesignPoint",
    "GainSchedule",
    "PIDAttitudeController",
    "design_gains",
    "write_gain_table",
]

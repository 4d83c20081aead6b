"""What a controller may be asked to fly: the task's goals, and the measurements and control
intervals an aircraft in flight can give, each with a stated margin. ``InputLimits`` refuses
(``ValueError`` naming the value, its unit and the limit) anything outside them before a controller's
state moves: a goal in degrees, an altitude in feet, a throttle in percent or an interval in
milliseconds would otherwise be flown as given, into some finite but meaningless command.

| input | accepted | why that margin |
|---|---|---|
| goal roll, pitch | ``GOAL_MARGIN`` x the task's ±5°, ±10° | a doublet or step from the level-flight pitch reaches past the drawn range |
| goal EAS | what a measured EAS may be (below) | a route that leaves the speed to TECS gives the measured EAS as the goal (``RouteConfig.attitude_eas_demand``), in a gust or a dive beyond any goal drawn |
| altitude | the aircraft's altitude range, widened by ``ALTITUDE_MARGIN`` of its span each way | a flight leaves its range before it is ended |
| roll, pitch | ±180°, ±90° | what the angles can be |
| alpha, beta | ±180° | what the angles can be |
| p, q, r | ±``MAX_RATE_RADPS`` | one turn a second: far beyond any flight the aircraft can survive |
| EAS | ``MIN_EAS_MPS`` to ``MAX_EAS_FACTOR`` x the top of the aircraft's EAS range | sensor noise about zero, and a dive |
| surfaces | ``SURFACE_MARGIN`` x their travel | backlash and rounding at the stops |
| throttle | ``SURFACE_MARGIN`` about 0 to 1 | a measured throttle carries sensor noise past its stops |
| interval (learned) | ``INTERVAL_MARGIN`` about the task's 40-60 ms | the intervals a policy was trained at |
| interval (classical) | ``CLASSICAL_INTERVAL_S`` | the rates a discrete form of a continuous design holds at |
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from aircraft import Aircraft
from jsbsim_env.sim.core import N_STATE, STATE_NAMES, CoreConfig

# The goals a training task draws (roll, pitch rad; EAS m/s, the paper's aircraft's: ``goal_range``).
GOAL_LOW = np.array([math.radians(-5.0), math.radians(-10.0), 8.0])
GOAL_HIGH = np.array([math.radians(5.0), math.radians(10.0), 12.0])
GOAL_MARGIN = 2.0  # accepted goals: this many times the drawn range about its middle
ALTITUDE_MARGIN = 0.25  # of the aircraft's altitude span, below its floor and above its ceiling
MAX_RATE_RADPS = 2.0 * math.pi
MIN_EAS_MPS = -1.0
MAX_EAS_FACTOR = 3.0
SURFACE_MARGIN = 1.25
INTERVAL_MARGIN = 2.0  # accepted intervals of a learned controller: the task's / 2 to the task's x 2
CLASSICAL_INTERVAL_S = (1e-3, 0.5)
_UNITS = ("m", "rad", "rad", "rad/s", "rad/s", "rad/s", "m/s", "rad", "rad", "rad", "rad", "rad", "0..1")
_GOAL_NAMES = ("roll", "pitch", "EAS")
_GOAL_UNITS = ("rad", "rad", "m/s")


def goal_range(aircraft: Aircraft) -> tuple[np.ndarray, np.ndarray]:
    """The goals drawn for ``aircraft``: roll and pitch as ``GOAL_LOW``/``GOAL_HIGH`` (rad), EAS over
    its envelope (m/s; the paper's aircraft's: 8 to 12 m/s, ``GOAL_LOW``/``GOAL_HIGH`` themselves)."""
    low, high = aircraft.eas_range_mps
    return np.array([GOAL_LOW[0], GOAL_LOW[1], low]), np.array([GOAL_HIGH[0], GOAL_HIGH[1], high])


def task_intervals_s() -> tuple[float, float]:
    """The control intervals the training task draws (``CoreConfig.control_interval_s``)."""
    low, high = CoreConfig().control_interval_s
    return float(low), float(high)


def learned_interval_s() -> tuple[float, float]:
    """The control intervals a learned controller is flown at: the task's, ``INTERVAL_MARGIN`` each way."""
    low, high = task_intervals_s()
    return low / INTERVAL_MARGIN, high * INTERVAL_MARGIN


def _show(value: float, unit: str) -> str:
    """A value with its unit, and in degrees where it is an angle (a value in degrees shows as such)."""
    if unit in ("rad", "rad/s"):
        return f"{value:.6g} {unit} ({math.degrees(value):.4g} deg{'/s' if unit == 'rad/s' else ''})"
    return f"{value:.6g} {unit}"


def _numbers(values, what: str, shape: tuple[int], contents: str) -> list[float]:
    """``values`` as plain floats: real numbers of ``shape``, else ``ValueError``."""
    array = np.asarray(values)
    if array.dtype.kind not in "iuf" and not (array.dtype.kind == "O" and all(
            isinstance(v, numbers.Real) and not isinstance(v, bool) for v in array.ravel().tolist())):
        raise ValueError(f"{what} must hold real numbers, got {array.dtype} values {array.ravel().tolist()[:4]}")
    if array.shape != shape:
        raise ValueError(f"{what} must have shape {shape} ({contents}), got {array.shape}")
    return array.astype(float).tolist()


def check_interval(dt_s, limits_s: tuple[float, float], who: str = "controller") -> float:
    """``dt_s`` as a float, when a real number of seconds within ``limits_s``; ``ValueError`` naming it otherwise."""
    if isinstance(dt_s, (bool, np.bool_)) or not isinstance(dt_s, numbers.Real):
        # A ValueError, as every other refused input: the callers catch that one.
        raise ValueError(f"control interval dt_s must be a real number of seconds, got {dt_s!r} "  # noqa: TRY004
                         f"({type(dt_s).__name__})")
    low, high = limits_s
    value = float(dt_s)
    if not low <= value <= high:  # NaN fails too
        raise ValueError(f"control interval dt_s = {value:g} s is outside the {low:g} to {high:g} s this {who} flies at")
    return value


class InputLimits:
    """The goals and measurements a controller of ``aircraft`` accepts (module docstring)."""

    def __init__(self, aircraft: Aircraft):
        low, high = goal_range(aircraft)
        middle, half = (low + high) / 2.0, (high - low) / 2.0 * GOAL_MARGIN
        self.goal_low, self.goal_high = (middle - half).tolist(), (middle + half).tolist()
        self.goal_low[2], self.goal_high[2] = MIN_EAS_MPS, MAX_EAS_FACTOR * aircraft.eas_range_mps[1]
        a0, a1 = aircraft.altitude_range_m
        margin = ALTITUDE_MARGIN * max(a1 - a0, 1000.0)
        pi, half_pi = math.pi + 1e-9, math.pi / 2.0 + 1e-9
        aileron, elevator, rudder = (math.radians(x) * SURFACE_MARGIN for x in aircraft.surface_limits_deg)
        bounds = [(a0 - margin, a1 + margin), (-pi, pi), (-half_pi, half_pi),
                  *[(-MAX_RATE_RADPS, MAX_RATE_RADPS)] * 3, (MIN_EAS_MPS, MAX_EAS_FACTOR * aircraft.eas_range_mps[1]),
                  (-pi, pi), (-pi, pi), (-aileron, aileron), (-elevator, elevator), (-rudder, rudder),
                  (1.0 - SURFACE_MARGIN, SURFACE_MARGIN)]
        self.measurement_low = [b[0] for b in bounds]
        self.measurement_high = [b[1] for b in bounds]
        self.aircraft = aircraft

    def check(self, measurement, goal) -> tuple[list[float], list[float]]:
        """``measurement`` (``core.STATE_NAMES``) and ``goal`` (roll, pitch rad; EAS m/s) as plain
        floats, when each is within its limits; ``ValueError`` naming the first that is not."""
        m = _numbers(measurement, "measurement", (N_STATE,), "core.STATE_NAMES")
        g = _numbers(goal, "goal", (len(_GOAL_NAMES),), "roll, pitch rad; EAS m/s")
        for values, lows, highs in ((m, self.measurement_low, self.measurement_high), (g, self.goal_low, self.goal_high)):
            for v, lo, hi in zip(values, lows, highs):
                if not lo <= v <= hi:  # NaN fails too
                    raise ValueError(self._refusal(m, g))
        return m, g

    def _refusal(self, m: list[float], g: list[float]) -> str:
        for what, names, values in (("measurement", STATE_NAMES, m), ("goal", _GOAL_NAMES, g)):
            for name, v in zip(names, values):
                if not math.isfinite(v):
                    return f"{what} {name} = {v} is not finite"
        for name, unit, v, lo, hi in zip(STATE_NAMES, _UNITS, m, self.measurement_low, self.measurement_high):
            if not lo <= v <= hi:
                return (f"measurement {name} = {_show(v, unit)} is outside what {self.aircraft.name} in flight can give "
                        f"({_show(lo, unit)} to {_show(hi, unit)}); give SI units and radians (core.STATE_NAMES)")
        for name, unit, v, lo, hi in zip(_GOAL_NAMES, _GOAL_UNITS, g, self.goal_low, self.goal_high):
            if not lo <= v <= hi:
                why = f"{GOAL_MARGIN:g} x its drawn range" if name != "EAS" else "what its EAS may measure"
                return (f"goal {name} = {_show(v, unit)} is outside what the task asks of {self.aircraft.name} "
                        f"({_show(lo, unit)} to {_show(hi, unit)}, {why}); give roll, pitch in rad and EAS in m/s")
        return "measurement or goal outside its limits"


__all__ = [
    "CLASSICAL_INTERVAL_S",
    "GOAL_HIGH",
    "GOAL_LOW",
    "InputLimits",
    "check_interval",
    "goal_range",
    "learned_interval_s",
    "task_intervals_s",
]

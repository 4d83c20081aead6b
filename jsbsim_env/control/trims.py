"""The two trim stages around the learned controller, each a slow integrator with its own state.

``GoalTrim`` moves the roll and pitch goals the network is given, so that the attitude it settles
at is the goal asked for. ``SurfaceTrim`` adds integrators of the roll and pitch errors to the
aileron and elevator commands, the way the PID's integrators do. Both are flight-side stages of
the control stack (``jsbsim_env.control.stack``); the training task runs the same ``SurfaceTrim``
objects around the plant (``jsbsim_env.task.attitude``).

| stage | what it adds |
|---|---|
| goal trim | roll goal + integral of (roll_cmd - roll) / time_constant_s, pitch likewise, while the error is below ``active_below_deg``, within ``limit_deg`` |
| surface trim | aileron + integral of gain q_s k_roll_i (roll - roll_goal), elevator + integral of gain q_s k_pitch_i (pitch - pitch_goal) |

The surface trim's gains are the PID's gain-scheduled integral gains (``pid_gains.json``) times
``gain`` (a fraction), scaled by dynamic pressure, with the PID's anti-windup (no integration
while the command is saturated that way) and bounds. A learned policy without integral action
keeps a steady error wherever its implicit trim differs from the aircraft's; the surface trim
removes it. The goal trim removes what is left when the policy's own gain is high: the policy
answers each degree of surface trim with nearly a degree of its own, so moving its goal acts
through its gain rather than against it. The integral follows the measurement noise too, so a
short time constant makes the goal wander (docs/training.md).

``integrate`` wants a positive, finite control interval: a NaN would stay in a trim for good.
"""

from __future__ import annotations

import math
from dataclasses import fields

from jsbsim_env.control.pid import (
    MIN_EAS_FOR_SCALING_MPS,
    SURFACE_INTEGRATOR_LIMIT_DEG,
    DesignPoint,
    GainSchedule,
)
from jsbsim_env.sim.core import COMMAND_HIGH, STATE_NAMES

_SURFACE_HIGH = COMMAND_HIGH[:2].tolist()  # the paper's aircraft's aileron and elevator travel
_ROLL, _PITCH = STATE_NAMES.index("roll_rad"), STATE_NAMES.index("pitch_rad")
_AILERON = STATE_NAMES.index("aileron_rad")  # then the elevator's position
SURFACE_TRIM_GAIN_RANGE = (0.0, 2.0)  # fraction of the PID's integral gains; 0 means no stage
GOAL_TRIM_TIME_CONSTANT_RANGE_S = (0.5, 100.0)


def _check_interval(dt_s: float) -> None:
    if not 0.0 < dt_s < math.inf:
        raise ValueError(f"control interval must be positive and finite, got {dt_s} s")


def check_surface_trim_gain(gain: float, name: str = "surface trim gain") -> None:
    """Raise ``ValueError`` naming ``name`` unless ``gain`` is 0 (no surface trim) or in (0, 2]."""
    low, high = SURFACE_TRIM_GAIN_RANGE
    if not low <= gain <= high:  # NaN fails too
        raise ValueError(f"{name} must lie in [{low:g}, {high:g}] (a fraction of the PID's integral gains; 0: none), "
                         f"got {gain}")


def check_goal_trim_time_constant(time_constant_s: float, name: str = "goal trim time constant") -> None:
    """Raise ``ValueError`` naming ``name`` unless it is 0 (no goal trim) or in [0.5, 100] s."""
    low, high = GOAL_TRIM_TIME_CONSTANT_RANGE_S
    if not (time_constant_s == 0.0 or low <= time_constant_s <= high):
        raise ValueError(f"{name} must be 0 (none) or lie in [{low:g}, {high:g}] s, got {time_constant_s}")


class SurfaceTrim:
    """The aileron and elevator trims (deg) of one aircraft, on plain floats (the batched task keeps
    one per aircraft and calls it every control step)."""

    def __init__(self, gain: float, schedule: GainSchedule | None = None,
                 travel_deg: tuple[float, float] = (_SURFACE_HIGH[0], _SURFACE_HIGH[1])):
        """``travel_deg``: the aileron's and elevator's travel that a trimmed command is clipped to
        (an ``Aircraft``'s ``surface_limits_deg[:2]``; the paper's aircraft's by default)."""
        check_surface_trim_gain(gain)
        if gain == 0.0:
            raise ValueError("a surface trim stage needs a gain above 0 (0 means no stage)")
        self.gain = float(gain)
        self._low, self._high = [-float(t) for t in travel_deg], [float(t) for t in travel_deg]
        names = [f.name for f in fields(DesignPoint)]  # the order of the schedule's columns
        self._schedule = schedule or GainSchedule()
        self._gain_columns = tuple(names.index(c) for c in ("k_roll_i", "k_pitch_i"))
        self.reset()

    def reset(self) -> None:
        self.trim_deg = [0.0, 0.0]
        self._held = [0.0, 0.0]  # > 0: the last command was clipped at its upper limit, < 0 at its lower

    def integrate(self, dt_s: float, measurement, goal) -> list[float]:
        """One control interval of integration on a measured state (``core.STATE_NAMES``) and goal
        (roll, pitch in rad, ...); returns the trims (deg)."""
        _check_interval(dt_s)
        altitude, eas = float(measurement[0]), float(measurement[6])
        q_s = (self._schedule.design_eas_mps / max(eas, MIN_EAS_FOR_SCALING_MPS)) ** 2
        k = self.gain * q_s * dt_s
        gains = self._schedule.interpolate(altitude, self._gain_columns)
        increments = [k * gains[0] * (float(measurement[_ROLL]) - float(goal[0])),
                      k * gains[1] * (float(measurement[_PITCH]) - float(goal[1]))]
        lim = SURFACE_INTEGRATOR_LIMIT_DEG
        for j, inc in enumerate(increments):
            if inc * self._held[j] > 0.0:
                continue  # anti-windup: the surface is already saturated that way
            self.trim_deg[j] = min(max(self.trim_deg[j] + inc, -lim), lim)
        return self.trim_deg

    def apply(self, command) -> list[float]:
        """``command`` (aileron, elevator, rudder in deg, throttle) with the trims added and the
        trimmed surfaces clipped to their travel; remembers which way a surface saturated."""
        out = list(command)
        for j in range(2):
            wanted = out[j] + self.trim_deg[j]
            out[j] = min(max(wanted, self._low[j]), self._high[j])
            self._held[j] = wanted - out[j]
        return out

    def remove_from(self, row: list[float]) -> list[float]:
        """A row that starts with a state (``core.STATE_NAMES``) with the trims taken off its aileron
        and elevator positions (rad): the part of each surface the policy commanded, which is what
        the policy observes (exactly in steady state; while a trim moves, the actuators lag it)."""
        out = list(row)
        for j, t in enumerate(self.trim_deg):
            out[_AILERON + j] -= math.radians(t)
        return out


class GoalTrim:
    """The roll and pitch goal offsets (rad) of one aircraft, on plain floats."""

    def __init__(self, time_constant_s: float = 20.0, limit_deg: float = 2.0, active_below_deg: float = 1.0):
        check_goal_trim_time_constant(time_constant_s)
        if time_constant_s == 0.0:
            raise ValueError("a goal trim stage needs a time constant above 0 (0 means no stage)")
        if not 0.0 < limit_deg <= 10.0 or not 0.0 < active_below_deg <= 10.0:
            raise ValueError(f"goal trim limit and activity bound must lie in (0, 10] deg, got {limit_deg}, "
                             f"{active_below_deg}")
        self.time_constant_s = float(time_constant_s)
        self.limit_rad = math.radians(limit_deg)
        self._active_rad = math.radians(active_below_deg)
        self.reset()

    def reset(self) -> None:
        self.offset_rad = [0.0, 0.0]

    def goal(self, goal) -> list[float]:
        """``goal`` (roll, pitch rad, EAS m/s) with the offsets added; the EAS goal passes unchanged."""
        return [float(goal[0]) + self.offset_rad[0], float(goal[1]) + self.offset_rad[1], float(goal[2])]

    def integrate(self, dt_s: float, measurement, goal) -> list[float]:
        """One control interval on a measured state (``core.STATE_NAMES``) against the goal asked
        for; returns the offsets (rad)."""
        _check_interval(dt_s)
        k, lim = dt_s / self.time_constant_s, self.limit_rad
        for j, state in enumerate((_ROLL, _PITCH)):
            error = float(goal[j]) - float(measurement[state])
            if abs(error) < self._active_rad:  # a NaN error integrates nothing either
                self.offset_rad[j] = min(max(self.offset_rad[j] + k * error, -lim), lim)
        return self.offset_rad


__all__ = ["GoalTrim", "SurfaceTrim", "check_goal_trim_time_constant", "check_surface_trim_gain"]

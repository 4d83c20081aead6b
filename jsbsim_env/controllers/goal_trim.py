"""Goal trim: a slow integrator that moves the roll and pitch goals an attitude controller is given,
so that the attitude it settles at is the goal asked for.

A learned policy holds a small steady offset from its goal wherever its implicit trim differs from
the aircraft's (a few tenths of a degree). Integral trim on the surfaces (``integral_trim``) cannot
remove it when the policy's own gain is high: the policy answers each degree of surface trim with
nearly a degree of its own, and the trims run to their limit while the offset shrinks by a fraction.
Moving the goal instead acts through the policy's gain rather than against it: a goal moved by the
offset, the policy settles on the goal it was asked for.

| loop | goal given to the controller |
|---|---|
| roll | roll_cmd + integral of (roll_cmd - roll) / time_constant_s |
| pitch | pitch_cmd + integral of (pitch_cmd - pitch) / time_constant_s |

It integrates only while the error is below ``active_below_deg`` (a steady offset, not a goal step,
a turn or a gust) and stays within ``limit_deg``. The EAS goal passes unchanged. The integral
follows the measurement noise too, so a short time constant makes the goal wander: with 5 s our
policies' calm-air roll error at 1 km was up to twice that with 20 s (docs/training.md).
"""

from __future__ import annotations

import math

import numpy as np

from jsbsim_env.controllers.base import AttitudeController
from jsbsim_env.core import STATE_NAMES

_ROLL, _PITCH = STATE_NAMES.index("roll_rad"), STATE_NAMES.index("pitch_rad")


class GoalIntegrator:
    """The roll and pitch goal offsets (rad) of one aircraft, on plain floats."""

    def __init__(self, time_constant_s: float = 20.0, limit_deg: float = 2.0, active_below_deg: float = 1.0):
        if not 0.5 <= time_constant_s <= 100.0:
            raise ValueError(f"goal trim time constant must lie in [0.5, 100] s, got {time_constant_s}")
        if not 0.0 < limit_deg <= 10.0 or not 0.0 < active_below_deg <= 10.0:
            raise ValueError(f"goal trim limit and activity bound must lie in (0, 10] deg, got {limit_deg}, "
                             f"{active_below_deg}")
        self.time_constant_s = float(time_constant_s)
        self._limit_rad = math.radians(limit_deg)
        self._active_rad = math.radians(active_below_deg)
        self.reset()

    def reset(self) -> None:
        self.offset_rad = [0.0, 0.0]

    def goal(self, goal) -> list[float]:
        """``goal`` (roll, pitch rad, EAS m/s) with the offsets added."""
        return [float(goal[0]) + self.offset_rad[0], float(goal[1]) + self.offset_rad[1], float(goal[2])]

    def integrate(self, dt_s: float, measurement, goal) -> list[float]:
        """One control interval on a measured state (``core.STATE_NAMES``) against the goal asked
        for; returns the offsets (rad)."""
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"control interval must be positive and finite, got {dt_s} s")
        k, lim = dt_s / self.time_constant_s, self._limit_rad
        for j, state in enumerate((_ROLL, _PITCH)):
            error = float(goal[j]) - float(measurement[state])
            if abs(error) < self._active_rad:  # a NaN error integrates nothing either
                self.offset_rad[j] = min(max(self.offset_rad[j] + k * error, -lim), lim)
        return self.offset_rad


class GoalTrim:
    """``controller`` given goals moved by a ``GoalIntegrator`` (module docstring); shares the
    ``AttitudeController`` interface."""

    def __init__(self, controller: AttitudeController, time_constant_s: float = 20.0, limit_deg: float = 2.0,
                 active_below_deg: float = 1.0):
        self.controller = controller
        self.integrator = GoalIntegrator(time_constant_s, limit_deg, active_below_deg)
        self.reset()

    def reset(self) -> None:
        self.controller.reset()
        self.integrator.reset()

    @property
    def offset_deg(self) -> np.ndarray:
        return np.degrees(self.integrator.offset_rad)

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        command = self.controller.update(dt_s, measurement, np.array(self.integrator.goal(setpoint)))
        self.integrator.integrate(dt_s, measurement, setpoint)  # this step's error moves the next goal
        return command


__all__ = ["GoalIntegrator", "GoalTrim"]

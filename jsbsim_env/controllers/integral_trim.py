"""Integral trim: slow integrators of the roll and pitch errors added to an attitude controller's
aileron and elevator commands.

A learned policy without integral action keeps a steady error wherever its implicit trim differs
from the aircraft's (measured on a policy trained without it, in calm air: about 0.5 deg of roll
and 1 deg of pitch at every altitude). The integrators here remove it the way the PID's do: the
PID's gain-scheduled integral gains (``pid_gains.json``), times ``fraction``, scaled by dynamic
pressure, with the same anti-windup (no integration while the command is saturated that way) and
bounds. The throttle is left alone (TECS's on a route, the controller's otherwise). A rudder trim
is optional (``rudder_time_s`` > 0): the PID has no sideslip integrator, so its gain is the PID's
sideslip gain over a time constant. Wrapped around a policy trained without it, it doubled the
sideslip RMSE in turbulence; it is meant to be learned beside (``TaskConfig.rudder_trim_s``).

| loop | added command |
|---|---|
| roll | aileron += integral of fraction q_s k_roll_i (roll - roll_cmd) |
| pitch | elevator += integral of fraction q_s k_pitch_i (pitch - pitch_cmd) |
| sideslip (optional) | rudder += integral of fraction q_s (k_beta / rudder_time_s) beta |

``integrate`` wants a positive, finite control interval: a NaN would stay in the trims for good.

Two ways to use them: ``IntegralTrim`` wraps any controller after the fact; a policy trained with
``TaskConfig.integral_trim`` learns beside them and observes their values (``jsbsim_env.task``,
``training.policy.PolicyRuntime``), both through ``TrimIntegrator``.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np

from jsbsim_env.controllers.base import AttitudeController
from jsbsim_env.controllers.pid import (
    DESIGN_EAS_MPS,
    MIN_EAS_FOR_SCALING_MPS,
    SURFACE_INTEGRATOR_LIMIT_DEG,
    DesignPoint,
    GainSchedule,
)
from jsbsim_env.core import COMMAND_HIGH, COMMAND_LOW, STATE_NAMES

_SURFACE_LOW, _SURFACE_HIGH = COMMAND_LOW[:3].tolist(), COMMAND_HIGH[:3].tolist()
_ROLL, _PITCH, _BETA = (STATE_NAMES.index(n) for n in ("roll_rad", "pitch_rad", "beta_rad"))


def check_rudder_time(rudder_time_s: float) -> None:
    """Raise ``ValueError`` unless the rudder trim's time constant is 0 (none) or in [0.5, 100] s."""
    if not (rudder_time_s == 0.0 or 0.5 <= rudder_time_s <= 100.0):
        raise ValueError(f"rudder trim time constant: rudder_trim_s must be 0 (no rudder trim) or lie in "
                         f"[0.5, 100] s, got {rudder_time_s}")


class TrimIntegrator:
    """The aileron and elevator trims (deg) of one aircraft, and the rudder's with ``rudder_time_s``
    > 0, on plain floats (the batched task keeps one per aircraft and calls it every control step)."""

    def __init__(self, fraction: float, schedule: GainSchedule | None = None, rudder_time_s: float = 0.0):
        if not 0.0 < fraction <= 2.0:
            raise ValueError(f"integral trim fraction must lie in (0, 2], got {fraction}")
        check_rudder_time(rudder_time_s)
        self.fraction = float(fraction)
        self.rudder_time_s = float(rudder_time_s)
        schedule = schedule or GainSchedule()
        names = [f.name for f in fields(DesignPoint)]  # the order of the schedule's columns
        self._schedule = schedule
        columns = ["k_roll_i", "k_pitch_i"] + (["k_beta"] if rudder_time_s else [])
        self._gain_columns = tuple(names.index(c) for c in columns)
        self.channels = len(columns)
        self.reset()

    def reset(self) -> None:
        self.trim_deg = [0.0] * self.channels
        self._held = [0.0] * self.channels  # > 0: the last command was clipped at its upper limit, < 0 at its lower

    def integrate(self, dt_s: float, measurement, goal) -> list[float]:
        """One control interval of integration on a measured state (``core.STATE_NAMES``) and goal
        (roll, pitch in rad, ...); returns the trims (deg)."""
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"control interval must be positive and finite, got {dt_s} s")
        altitude, eas = float(measurement[0]), float(measurement[6])
        q_s = (DESIGN_EAS_MPS / max(eas, MIN_EAS_FOR_SCALING_MPS)) ** 2
        k = self.fraction * q_s * dt_s
        gains = self._schedule.interpolate(altitude, self._gain_columns)
        increments = [k * gains[0] * (float(measurement[_ROLL]) - float(goal[0])),
                      k * gains[1] * (float(measurement[_PITCH]) - float(goal[1]))]
        if self.channels == 3:  # sideslip's goal is 0
            increments.append(k * gains[2] / self.rudder_time_s * float(measurement[_BETA]))
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
        for j in range(self.channels):
            wanted = out[j] + self.trim_deg[j]
            out[j] = min(max(wanted, _SURFACE_LOW[j]), _SURFACE_HIGH[j])
            self._held[j] = wanted - out[j]
        return out


class IntegralTrim:
    """``controller`` with integral trim on roll and pitch, and sideslip with ``rudder_time_s`` > 0
    (module docstring), added after the fact;
    shares the ``AttitudeController`` interface."""

    def __init__(self, controller: AttitudeController, fraction: float = 0.5, schedule: GainSchedule | None = None,
                 rudder_time_s: float = 0.0):
        built_in = getattr(controller, "meta", {}).get("integral_trim", 0.0)
        if built_in:  # two integrators on the same error would fight over the same trim
            raise ValueError(f"this policy was trained with integral trim ({built_in:g}) and applies it itself: "
                             "fly it without --integral-trim")
        self.controller = controller
        self.integrator = TrimIntegrator(fraction, schedule, rudder_time_s)
        self.fraction = self.integrator.fraction
        self.reset()

    def reset(self) -> None:
        self.controller.reset()
        self.integrator.reset()

    @property
    def trim_deg(self) -> np.ndarray:
        return np.array(self.integrator.trim_deg)

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        m, sp = np.asarray(measurement, dtype=float), np.asarray(setpoint, dtype=float)
        command = self.integrator.apply(self.controller.update(dt_s, m, sp).tolist())
        # Integrated after the command, as the PID does: this step's error trims the next command.
        self.integrator.integrate(dt_s, m, sp)
        return np.clip(command, COMMAND_LOW, COMMAND_HIGH)


__all__ = ["IntegralTrim", "TrimIntegrator", "check_rudder_time"]

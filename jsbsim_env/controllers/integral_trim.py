"""Integral trim: slow integrators of the roll and pitch errors added to any attitude controller's
aileron and elevator commands.

A learned policy without integral action keeps a steady error wherever its implicit trim differs
from the aircraft's (measured on the shipped policy in calm air: about 0.5 deg of roll and 1 deg
of pitch at every altitude). The integrators here remove it the way the PID's do: the PID's
gain-scheduled integral gains (``pid_gains.json``), times ``fraction``, scaled by dynamic pressure,
with the same anti-windup (no integration while the command is saturated that way) and bounds.
The throttle is left alone (TECS's on a route, the controller's otherwise), and so is the rudder:
a sideslip integrator tried beside them doubled the sideslip RMSE in turbulence.

| loop | added command |
|---|---|
| roll | aileron += integral of fraction q_s k_roll_i (roll - roll_cmd) |
| pitch | elevator += integral of fraction q_s k_pitch_i (pitch - pitch_cmd) |
"""

from __future__ import annotations

import numpy as np

from jsbsim_env.controllers.base import AttitudeController
from jsbsim_env.controllers.pid import (
    DESIGN_EAS_MPS,
    MIN_EAS_FOR_SCALING_MPS,
    SURFACE_INTEGRATOR_LIMIT_DEG,
    GainSchedule,
)
from jsbsim_env.core import COMMAND_HIGH, COMMAND_LOW


class IntegralTrim:
    """``controller`` with integral trim on roll and pitch (module docstring); shares the
    ``AttitudeController`` interface."""

    def __init__(self, controller: AttitudeController, fraction: float = 0.5, schedule: GainSchedule | None = None):
        if not 0.0 < fraction <= 2.0:
            raise ValueError(f"integral trim fraction must lie in (0, 2], got {fraction}")
        self.controller, self.fraction = controller, float(fraction)
        self.schedule = schedule or GainSchedule()
        self.reset()

    def reset(self) -> None:
        self.controller.reset()
        self.trim_deg = np.zeros(2)  # added aileron, elevator

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        m, sp = np.asarray(measurement, dtype=float), np.asarray(setpoint, dtype=float)
        command = np.array(self.controller.update(dt_s, m, sp), dtype=float)
        command[:2] += self.trim_deg
        clipped = np.clip(command, COMMAND_LOW, COMMAND_HIGH)
        g = self.schedule.at(m[0])
        q_s = (DESIGN_EAS_MPS / max(m[6], MIN_EAS_FOR_SCALING_MPS)) ** 2
        increments = self.fraction * q_s * dt_s * np.array([g.k_roll_i * (m[1] - sp[0]), g.k_pitch_i * (m[2] - sp[1])])
        for k, inc in enumerate(increments):
            if (command[k] > clipped[k] and inc > 0.0) or (command[k] < clipped[k] and inc < 0.0):
                continue  # anti-windup: the surface is already saturated that way
            self.trim_deg[k] = min(max(self.trim_deg[k] + inc, -SURFACE_INTEGRATOR_LIMIT_DEG),
                                   SURFACE_INTEGRATOR_LIMIT_DEG)
        return clipped


__all__ = ["IntegralTrim"]

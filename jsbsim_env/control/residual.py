"""The residual stage: a classical controller flies, and the network adds a bounded correction.

    measurement, goal --> [base controller: its command and its integrators] --> network's inputs
    command = base command + authority x (action x the aircraft's action scale), clipped to the travel

The base is one of the aircraft's LQIs (``RESIDUAL_BASES``: the designed table, the one tuned on nominal
flights, the one tuned on the training episodes' conditions or the one tuned with a long delay and a
slow servo among its flights);
``authority`` is the correction's share of each surface's travel (and of half the throttle range).
A network whose output is zero flies exactly the base controller, so training starts from it
(``jsbsim_env.control.network.ActorNet.start_at_zero``). The network reads the base's command
(as an action) and its four integrators beside the usual observation (``RESIDUAL_NAMES``).

The base controller's delayed-command state is the command that reached the actuators, correction
included: that is the input its design models. The training task and the control stack run this
same class, so the policy flies exactly the stage it was trained through.
"""

from __future__ import annotations

import math

from aircraft import load_aircraft
from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.control.lqi import LQIAttitudeController
from jsbsim_env.control.observation import ACTION_OFFSET, action_scale

RESIDUAL_BASES = ("lqi", "lqi_tuned", "lqi_robust", "lqi_stressed")
MAX_RESIDUAL_AUTHORITY = 1.0
# The integrators' scales in the network's input: roll, pitch and sideslip in deg s, EAS in m.
INTEGRATOR_SCALE_DEG_S = 5.0
EAS_INTEGRATOR_SCALE_M = 10.0
_DEG = math.degrees(1.0)


def check_residual(base: str, authority: float) -> None:
    """A residual setting: no base and zero authority, or a base of ``RESIDUAL_BASES`` and an
    authority in (0, ``MAX_RESIDUAL_AUTHORITY``]; a ``ValueError`` naming the setting otherwise."""
    if isinstance(authority, bool) or not isinstance(authority, (int, float)) or not math.isfinite(authority):
        raise ValueError(f"residual_authority must be a finite number, got {authority!r}")
    if base == "":
        if authority != 0.0:
            raise ValueError(f"residual_authority {authority} needs a residual_on controller ({', '.join(RESIDUAL_BASES)})")
        return
    if base not in RESIDUAL_BASES:
        raise ValueError(f"residual_on must be one of {', '.join(RESIDUAL_BASES)} (or empty: no residual), got {base!r}")
    if not 0.0 < authority <= MAX_RESIDUAL_AUTHORITY:
        raise ValueError(f"residual_authority must lie in (0, {MAX_RESIDUAL_AUTHORITY}] (a share of each surface's "
                         f"travel), got {authority}")


class ResidualStage:
    """The base controller ``base`` of ``aircraft`` and the correction's ``authority`` (module docstring)."""

    def __init__(self, base: str, authority: float, aircraft=None):
        check_residual(base, authority)
        flown = load_aircraft(aircraft)
        self.base_name, self.authority = base, float(authority)
        self.gain_file = gain_file(base, flown)
        self.controller = LQIAttitudeController(gains_path=self.gain_file, aircraft=flown)
        self._scale = action_scale(flown).tolist()
        self._reach = [self.authority * k for k in self._scale]
        self._low, self._high = list(flown.command_low), list(flown.command_high)
        self.base_command: list[float] | None = None

    def reset(self) -> None:
        self.controller.reset()
        self.base_command = None

    def observe(self, dt_s: float, measurement: list[float], goal: list[float]) -> list[float]:
        """The base controller's step on what the network is about to read: its inputs to the
        network (``RESIDUAL_NAMES``), scaled."""
        self.base_command = command = self.controller.update(dt_s, measurement, goal).tolist()
        c = self.controller
        return [*((x - o) / k for x, o, k in zip(command, ACTION_OFFSET.tolist(), self._scale)),
                c.z_roll * _DEG / INTEGRATOR_SCALE_DEG_S, c.z_pitch * _DEG / INTEGRATOR_SCALE_DEG_S,
                c.z_beta * _DEG / INTEGRATOR_SCALE_DEG_S, c.z_eas / EAS_INTEGRATOR_SCALE_M]

    def command(self, action: list[float]) -> list[float]:
        """The base command of the step ``observe`` began plus the correction ``action`` (in [-1, 1]),
        within the travel; the base controller then holds it as its delayed command."""
        if self.base_command is None:
            raise RuntimeError("ResidualStage.command needs the step's observe() first")
        command = [min(max(b + r * a, lo), hi)
                   for b, r, a, lo, hi in zip(self.base_command, self._reach, action, self._low, self._high)]
        self.controller.last_command = command
        return command

__all__ = ["MAX_RESIDUAL_AUTHORITY", "RESIDUAL_BASES", "ResidualStage", "check_residual"]

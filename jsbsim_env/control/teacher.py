"""A teacher: one of the aircraft's LQIs flown in the shadow of the policy, for distillation.

At every step the teacher reads what the policy reads (the measurement and the goal it is given)
and gives the command it would send, as an action in [-1, 1]: the label a network is distilled
towards (``training.trainer``'s DAgger phase). It holds as its delayed command the command that
really reached the actuators, whoever chose it, so that its label is the one it would give from
the state the policy has led the aircraft to, which is what DAgger asks of a teacher.

The teacher is not part of what flies: a distilled policy flies with its task version's stack alone.
"""

from __future__ import annotations

from aircraft import load_aircraft
from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.control.lqi import LQIAttitudeController
from jsbsim_env.control.observation import ACTION_OFFSET, action_scale
from jsbsim_env.control.residual import RESIDUAL_BASES

# The LQIs a network can be distilled from: those a residual can ride on.
TEACHERS = RESIDUAL_BASES


def check_teacher(name: str) -> None:
    """A teacher's name: empty (none) or one of ``TEACHERS``; a ``ValueError`` naming it otherwise."""
    if name != "" and name not in TEACHERS:
        raise ValueError(f"teacher must be one of {', '.join(TEACHERS)} (or empty: none), got {name!r}")


class TeacherStage:
    """The LQI ``name`` (``TEACHERS``) of ``aircraft``, flown beside the policy (module docstring)."""

    def __init__(self, name: str, aircraft=None):
        check_teacher(name)
        if not name:
            raise ValueError("a TeacherStage needs a teacher's name")
        flown = load_aircraft(aircraft)
        self.name = name
        self.controller = LQIAttitudeController(gains_path=gain_file(name, flown), aircraft=flown)
        self._scale = action_scale(flown).tolist()
        self._offset = ACTION_OFFSET.tolist()
        self.action: list[float] = [0.0] * len(self._scale)

    def reset(self) -> None:
        self.controller.reset()

    def observe(self, dt_s: float, measurement: list[float], goal: list[float]) -> list[float]:
        """The teacher's step on what the policy is about to read: its command as an action in [-1, 1]."""
        command = self.controller.update(dt_s, measurement, goal).tolist()
        self.action = [min(max((x - o) / k, -1.0), 1.0) for x, o, k in zip(command, self._offset, self._scale)]
        return self.action

    def follow(self, command: list[float]) -> None:
        """The command that reached the actuators this step: the teacher's delayed-command state."""
        self.controller.last_command = list(command)


__all__ = ["TEACHERS", "TeacherStage", "check_teacher"]

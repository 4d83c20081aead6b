"""Observation and action of the learned controller: what the network reads and what its output
commands. One definition, used by the training task (``jsbsim_env.task.attitude``) and by the
runtime that flies (``jsbsim_env.control.policy``).

The observation (``OBS_SIZE`` = 20 values, each scaled as ``(value - offset) / scale``) is the
paper's (Section 3.2, Eqs. 18-19) with the last action added after the measured state: a command
takes 40-120 ms (one to three control steps) to reach the actuators and the measured surface
positions do not show it before then, so without it nothing in the next observation depends on
the action just taken and a one-step temporal-difference critic cannot learn what an action does.

| index | name | unit | offset | scale |
|---|---|---|---|---|
| 0 | altitude | m | 10000 | 10000 |
| 1, 2 | roll, pitch | rad | 0 | 10 deg |
| 3, 4, 5 | roll, pitch, yaw rate p, q, r | rad/s | 0 | 10 deg/s |
| 6 | equivalent airspeed | m/s | 10 | 2 |
| 7, 8 | angle of attack, sideslip | rad | 0 | 10 deg |
| 9, 10 | aileron, elevator position | rad | 0 | 30 deg |
| 11 | rudder position | rad | 0 | 20 deg |
| 12 | throttle position | 0..1 | 0.5 | 0.5 |
| 13-16 | last action: aileron, elevator, rudder, throttle | [-1, 1] | 0 | 1 |
| 17, 18 | roll, pitch goal | rad | 0 | 10 deg |
| 19 | EAS goal | m/s | 10 | 2 |

``OBSERVATION_TABLE`` holds the same rows, one per index, for code.

A controller that reads error integrals (``StackSettings.error_integrals``,
``jsbsim_env.control.integrals``) has three more values, ``INTEGRAL_NAMES``, each in deg s over
``INTEGRAL_SCALE_DEG_S``, between the last action and the goals (which close every observation):
``observation_size(error_integrals=True)`` = 23. A residual controller
(``jsbsim_env.control.residual``) reads its base controller's command (as an action) and
integrators, ``RESIDUAL_NAMES``, in the same place: ``observation_size(residual=True)`` = 28.

The action (``ACTION_SIZE`` = 4, each in [-1, 1]) maps linearly to each surface's travel and the
throttle 0..1 (``action_scale``): on the paper's aircraft its Table 2, aileron and elevator
+-30 deg, rudder +-20 deg (the default ``ACTION_SCALE``).

    >>> import numpy as np
    >>> action_to_command(np.array([0.5, -1.0, 0.0, 0.0]))  # aileron, elevator, rudder deg; throttle
    array([ 15. , -30. ,   0. ,   0.5])
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jsbsim_env.sim.core import N_STATE, STATE_NAMES

GOAL_NAMES = ("roll_cmd_rad", "pitch_cmd_rad", "airspeed_eas_cmd_mps")
ACTION_NAMES = ("aileron", "elevator", "rudder", "throttle")
ACTION_SIZE = len(ACTION_NAMES)
OBS_SIZE = N_STATE + ACTION_SIZE + len(GOAL_NAMES)
INTEGRAL_NAMES = ("roll_error_integral_deg_s", "pitch_error_integral_deg_s", "sideslip_error_integral_deg_s")
INTEGRAL_SCALE_DEG_S = 5.0  # a steady error of 0.25 deg reads 1 after 20 s
INTEGRAL_COLUMNS = slice(N_STATE + ACTION_SIZE, N_STATE + ACTION_SIZE + len(INTEGRAL_NAMES))
RESIDUAL_NAMES = (*(f"base_{a}" for a in ACTION_NAMES), "base_roll_integral", "base_pitch_integral",
                  "base_sideslip_integral", "base_eas_integral")


def observation_size(error_integrals: bool = False, residual: bool = False) -> int:
    """Values in one observation: ``OBS_SIZE``, and the error integrals and the residual's base
    controller where the controller reads them."""
    return OBS_SIZE + (len(INTEGRAL_NAMES) if error_integrals else 0) + (len(RESIDUAL_NAMES) if residual else 0)


_DEG = math.degrees(1.0)
# Angles and rates to tens of degrees, surfaces to their travel, airspeed about 10 m/s, altitude
# about 10 km; the last action as it is.
OBS_OFFSET = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0, 0, 10.0])
OBS_SCALE = np.array([10000.0, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 2.0, 10 / _DEG, 10 / _DEG,
                      30 / _DEG, 30 / _DEG, 20 / _DEG, 0.5, 1, 1, 1, 1, 10 / _DEG, 10 / _DEG, 2.0])
LAST_ACTION_COLUMNS = slice(N_STATE, N_STATE + ACTION_SIZE)
GOAL_COLUMNS = slice(-len(GOAL_NAMES), None)  # the goals close the observation

_STATE_UNITS = {"altitude_m": "m", "airspeed_eas_mps": "m/s", "throttle": "0..1"}


class ObservationEntry(NamedTuple):
    name: str
    unit: str
    offset: float
    scale: float


OBSERVATION_TABLE = tuple(
    ObservationEntry(name, unit, float(o), float(s))
    for name, unit, o, s in zip(
        (*STATE_NAMES, *(f"last_action_{a}" for a in ACTION_NAMES), *GOAL_NAMES),
        (*(_STATE_UNITS.get(n, "rad/s" if n.endswith("_radps") else "rad") for n in STATE_NAMES),
         *(["action"] * ACTION_SIZE), "rad", "rad", "m/s"),
        OBS_OFFSET, OBS_SCALE)
)

# Action -> physical command: command = ACTION_OFFSET + scale * action, where the scale is the
# aircraft's surface travel and half the throttle range (``action_scale``): an action of +-1 puts a
# surface at its stop, on every aircraft. ACTION_SCALE is the paper's aircraft's (its Table 2).
ACTION_OFFSET = np.array([0.0, 0.0, 0.0, 0.5])
THROTTLE_ACTION_SCALE = 0.5
ACTION_SCALE = np.array([30.0, 30.0, 20.0, THROTTLE_ACTION_SCALE])
ACTION_TOLERANCE = 1e-6
_ACT_SCALE, _ACT_OFFSET = ACTION_SCALE.tolist(), ACTION_OFFSET.tolist()
_OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST = OBS_OFFSET.tolist(), (1.0 / OBS_SCALE).tolist()


def action_scale(aircraft) -> np.ndarray:
    """An ``aircraft.Aircraft``'s action scale: its aileron, elevator and rudder travel (deg) and
    half the throttle range (the paper's aircraft's is ``ACTION_SCALE``)."""
    return np.array([*aircraft.surface_limits_deg, THROTTLE_ACTION_SCALE])


class ActionError(ValueError):
    """An action that is not finite, lies outside [-1, 1], or has the wrong shape."""


def action_to_command(action: np.ndarray, scale: np.ndarray = ACTION_SCALE) -> np.ndarray:
    """Map a policy action in [-1, 1]^4 to aileron, elevator, rudder (deg) and throttle (0..1) of
    the aircraft whose ``action_scale`` is ``scale`` (the paper's by default)."""
    a = np.asarray(action, dtype=float)
    if a.shape != (ACTION_SIZE,):
        raise ActionError(f"action must have shape ({ACTION_SIZE},), got {a.shape}")
    # Python comparisons on four floats are several times faster than numpy reductions here (the
    # runtime calls this every control step), and a NaN fails them too.
    limit = 1.0 + ACTION_TOLERANCE
    if not all(-limit <= x <= limit for x in a.tolist()):
        raise ActionError(f"action {a} is not finite or outside [-1, 1]")
    return ACTION_OFFSET + scale * np.minimum(np.maximum(a, -1.0), 1.0)


def action_list_to_command(action: list[float], scale: list[float] = _ACT_SCALE) -> list[float]:
    """``action_to_command`` on a list of four floats already in [-1, 1], with ``scale`` as a list:
    what the per-step loops use (a few microseconds less than the array version)."""
    return [o + k * x for x, k, o in zip(action, scale, _ACT_OFFSET)]


def command_to_action(command: np.ndarray, scale: np.ndarray = ACTION_SCALE) -> np.ndarray:
    """Inverse of ``action_to_command``."""
    return (np.asarray(command, dtype=float) - ACTION_OFFSET) / scale


def scale_observation(state: np.ndarray, last_action: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The network's observation (float32) from measured states (``core.STATE_NAMES``), the last
    action (in [-1, 1]) and goals; works on one (13,) + (4,) + (3,) or on N rows of each."""
    raw = np.concatenate([state, last_action, goal], axis=-1)
    return ((raw - OBS_OFFSET) / OBS_SCALE).astype(np.float32)


def scale_row(raw: list[float], noise: list[float] | None = None) -> list[float]:
    """One observation on plain floats, the per-step form: ``raw`` is a measured (or true) state,
    the last action and the goal joined in a list; ``noise``, where given, is added to each value
    before scaling (the training task adds the sensor noise here, zero on the action and goals)."""
    if noise is None:
        return [(x - o) * k for x, o, k in zip(raw, _OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST)]
    return [(x + n - o) * k for x, n, o, k in zip(raw, noise, _OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST)]


def initial_last_action(measurement, scale: np.ndarray = ACTION_SCALE) -> list[float]:
    """The "last action" at the start of an episode: the measured actuator positions (rad, rad, rad,
    throttle) as an action of the aircraft whose ``action_scale`` is ``scale`` (the paper's by
    default), which is the trim command the aircraft starts settled on."""
    m = np.asarray(measurement, dtype=float)
    return command_to_action(np.array([math.degrees(m[9]), math.degrees(m[10]), math.degrees(m[11]), m[12]]),
                             scale).tolist()


class ObservationWindow:
    """The last ``steps`` observations, oldest first, as training's ``CatFrames`` keeps them: a new
    episode's window is its first observation repeated."""

    def __init__(self, steps: int, size: int = OBS_SIZE):
        if steps < 1:
            raise ValueError(f"the observation window must hold at least 1 step, got {steps}")
        self.steps, self.size = int(steps), int(size)
        self._rows = np.zeros((self.steps, self.size), dtype=np.float32)
        self._filled = False

    def reset(self) -> None:
        self._filled = False

    @property
    def rows(self) -> np.ndarray:
        """The window's own array (steps, size), as ``push`` returns it."""
        return self._rows

    def push(self, observation) -> np.ndarray:
        """Add one observation; returns the window (steps, size), valid until the next push."""
        if not self._filled:
            self._rows[:] = observation
            self._filled = True
        else:
            self._rows[:-1] = self._rows[1:]
            self._rows[-1] = observation
        return self._rows


__all__ = [
    "ACTION_NAMES",
    "ACTION_OFFSET",
    "ACTION_SCALE",
    "ACTION_SIZE",
    "ACTION_TOLERANCE",
    "GOAL_COLUMNS",
    "GOAL_NAMES",
    "INTEGRAL_COLUMNS",
    "INTEGRAL_NAMES",
    "INTEGRAL_SCALE_DEG_S",
    "LAST_ACTION_COLUMNS",
    "OBSERVATION_TABLE",
    "OBS_OFFSET",
    "OBS_SCALE",
    "OBS_SIZE",
    "RESIDUAL_NAMES",
    "THROTTLE_ACTION_SCALE",
    "ActionError",
    "ObservationEntry",
    "ObservationWindow",
    "action_list_to_command",
    "action_scale",
    "action_to_command",
    "command_to_action",
    "initial_last_action",
    "observation_size",
    "scale_observation",
    "scale_row",
]

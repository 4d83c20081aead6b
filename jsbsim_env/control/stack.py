"""The learned controller as a chain of stages, each with its parameters and its state:

    goal asked --> [goal trim] --> goal given --+
                                                |
    measurement --> [surface trim: integrate, take its trims off the observed surfaces]
                                                |
                    [error integrals: integrate]
                                                |
                    [residual: the base controller's step, its command and integrators]
                                                |
                    [observation: scale, with the last action] --> [window: last N] --> network
                                                                                          |
    command <-- [surface trim: add trims, clip] <-- [action -> command] <-- action <------+
                (with a residual: base command + authority x action, clipped)

``StackSettings`` holds the parameters, as a policy file records them; ``ControlStack`` runs the
stages around a network for one aircraft (``jsbsim_env.control.policy.PolicyRuntime`` adds the
network). The training task (``jsbsim_env.task.attitude``) builds its observation with the same
``observation_row`` and trims its commands with the same ``SurfaceTrim``, so there is one
implementation of each stage; its window is TorchRL's ``CatFrames``, which ``ObservationWindow``
keeps exactly.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from aircraft import load_aircraft
from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.control.integrals import ErrorIntegrals, check_error_integrals
from jsbsim_env.control.observation import (
    GOAL_COLUMNS,
    INTEGRAL_SCALE_DEG_S,
    ObservationWindow,
    action_list_to_command,
    action_scale,
    initial_last_action,
    observation_size,
    scale_row,
)
from jsbsim_env.control.pid import GainSchedule
from jsbsim_env.control.residual import ResidualStage, check_residual
from jsbsim_env.control.trims import (
    GoalTrim,
    SurfaceTrim,
    check_goal_trim_time_constant,
    check_surface_trim_gain,
)

_GOALS_START = GOAL_COLUMNS.start  # negative: the goals close the row


def observation_row(state: list[float], last_action: list[float], goal: list[float],
                    surface_trim: SurfaceTrim | None = None, noise: list[float] | None = None,
                    integrals: ErrorIntegrals | None = None, residual: list[float] | None = None) -> list[float]:
    """The network's observation for one step, as a list: a state (``core.STATE_NAMES``), the last
    action and the goal, with the surface trim's present trims taken off the observed surfaces
    (the policy sees the part of each surface it commanded), scaled; with ``integrals``, their
    values go between the last action and the goal, and after them ``residual``, the residual
    stage's inputs (``ResidualStage.observe``). Flight gives the measured state; the training
    task gives the true state and the sensor noise to add (``noise``, zero on the action and the
    goal)."""
    raw = state + last_action + goal
    if surface_trim is not None:
        raw = surface_trim.remove_from(raw)
    row = scale_row(raw, noise)
    if integrals is not None:
        row[_GOALS_START:_GOALS_START] = [v / INTEGRAL_SCALE_DEG_S for v in integrals.integral_deg_s]
    if residual is not None:
        row[_GOALS_START:_GOALS_START] = residual
    return row


@dataclass(frozen=True)
class StackSettings:
    """Parameters of the stages around the network.

    ``window_steps``: observations the network reads, the newest last (the paper: 8).
    ``goal_trim_time_constant_s``: the goal trim's time constant; 0: no goal trim.
    ``surface_trim_gain``: the surface trim's gains as a fraction of the PID's integral gains; 0: no surface trim.
    ``error_integrals``: whether the network reads the roll, pitch and sideslip error integrals.
    ``residual_on``: the classical controller the network corrects (``jsbsim_env.control.residual``;
    empty: none, the network flies alone); ``residual_authority`` the correction's share of each
    surface's travel.
    """

    window_steps: int = 8
    goal_trim_time_constant_s: float = 0.0
    surface_trim_gain: float = 0.0
    error_integrals: bool = False
    residual_on: str = ""
    residual_authority: float = 0.0

    def __post_init__(self):
        if isinstance(self.window_steps, bool) or not isinstance(self.window_steps, int) \
                or not 1 <= self.window_steps <= 64:
            raise ValueError(f"window_steps must be a whole number in [1, 64], got {self.window_steps!r}")
        check_goal_trim_time_constant(self.goal_trim_time_constant_s, "goal_trim_time_constant_s")
        check_surface_trim_gain(self.surface_trim_gain, "surface_trim_gain")
        check_error_integrals(self.error_integrals)
        check_residual(self.residual_on, self.residual_authority)

    @property
    def observation_size(self) -> int:
        return observation_size(self.error_integrals, bool(self.residual_on))

    def network_alone(self) -> StackSettings:
        """These settings without the classical stages (goal trim, surface trim): the network with
        its inputs (window, error integrals) as they are. A residual's base controller stays: its
        network has no command of its own."""
        return replace(self, goal_trim_time_constant_s=0.0, surface_trim_gain=0.0)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> StackSettings:
        """The settings as ``to_dict`` wrote them; a setting of the wrong kind or unknown is refused by name."""
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown control-stack settings {sorted(unknown)}")
        numbers = {}
        for name in ("goal_trim_time_constant_s", "surface_trim_gain", "residual_authority"):
            value = data.get(name, 0.0)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{name} must be a number, got {value!r}")  # noqa: TRY004 - a bad setting, by name
            numbers[name] = float(value)
        return cls(window_steps=data.get("window_steps", 8), error_integrals=data.get("error_integrals", False),
                   residual_on=data.get("residual_on", ""), **numbers)


class ControlStack:
    """The stages around the network for one aircraft (module docstring), on plain floats; the
    surface trim's gains are ``aircraft``'s PID's (the paper's aircraft's by default)."""

    def __init__(self, settings: StackSettings | None = None, aircraft=None):
        self.settings = s = settings or StackSettings()
        flown = load_aircraft(aircraft)
        # An action of +-1 puts a surface at this aircraft's stop, as in training on it.
        self._action_scale = action_scale(flown).tolist()
        self.goal_trim = GoalTrim(s.goal_trim_time_constant_s) if s.goal_trim_time_constant_s else None
        self.surface_trim = (SurfaceTrim(s.surface_trim_gain, GainSchedule(gain_file("pid", flown)),
                                         flown.surface_limits_deg[:2])
                             if s.surface_trim_gain else None)
        self.integrals = ErrorIntegrals() if s.error_integrals else None
        self.residual = ResidualStage(s.residual_on, s.residual_authority, flown) if s.residual_on else None
        self.window = ObservationWindow(s.window_steps, s.observation_size)
        self.needs_interval = any(stage is not None
                                  for stage in (self.goal_trim, self.surface_trim, self.integrals, self.residual))
        self.last_action: list[float] | None = None  # fed back into the next observation
        self._step: tuple[list[float], list[float], float | None] | None = None  # this step's (measurement, goal, dt_s)

    def reset(self) -> None:
        """A new flight: every stage's state back to its start."""
        self.last_action = None
        self._step = None
        self.window.reset()
        for stage in (self.goal_trim, self.surface_trim, self.integrals, self.residual):
            if stage is not None:
                stage.reset()

    def observe(self, measurement: list[float], asked: list[float], dt_s: float | None) -> np.ndarray:
        """The stages before the network for one control step: the network's window (steps, values),
        valid until the next call. ``measurement`` in ``core.STATE_NAMES`` order, ``asked`` the goal
        (roll, pitch rad, EAS m/s), both finite lists."""
        self._step = (measurement, asked, dt_s)
        given = self.goal_trim.goal(asked) if self.goal_trim is not None else asked
        first = self.last_action is None
        if first:  # a residual's correction starts at zero; a network alone, at the surfaces' positions
            self.last_action = [0.0] * len(self._action_scale) if self.residual is not None \
                else initial_last_action(measurement, self._action_scale)
        if not first:  # the integrators start from zero with the flight, as in training
            if self.surface_trim is not None:
                self.surface_trim.integrate(dt_s, measurement, given)
            if self.integrals is not None:
                self.integrals.integrate(dt_s, measurement, given)
        base = self.residual.observe(dt_s, measurement, given) if self.residual is not None else None
        row = observation_row(measurement, self.last_action, given, self.surface_trim, integrals=self.integrals,
                              residual=base)
        return self.window.push(np.array(row, dtype=np.float32))

    def command(self, action: list[float]) -> list[float]:
        """The stages after the network, for the step ``observe`` began: the command (aileron,
        elevator, rudder deg, throttle) for an action in [-1, 1]^4; then this step's error against
        the goal asked moves the next goal."""
        if self._step is None:
            raise RuntimeError("ControlStack.command needs the step's observe() first")
        measurement, asked, dt_s = self._step
        self._step = None
        self.last_action = action
        if self.residual is not None:
            command = self.residual.command(action)
        else:
            command = action_list_to_command(action, self._action_scale)  # within the travel for actions in [-1, 1]
        if self.surface_trim is not None:
            command = self.surface_trim.apply(command)  # clips the trimmed surfaces to their travel
        if self.goal_trim is not None:
            self.goal_trim.integrate(dt_s, measurement, asked)
        return command


# The residual versions' correction: a quarter of each surface's travel (and of half the throttle range).
RESIDUAL_AUTHORITY = 0.25
# v10's: a twentieth, for a correction of the size a goal held in turbulence asks for, and exploration
# that far smaller around the base.
FINE_RESIDUAL_AUTHORITY = 0.05
# The stack each registered task version (``jsbsim_env.task.versions``) flies with, by its id: what a
# policy file that records the version must record as its stack (``policy.load_policy``).
_GOAL_AND_SURFACE_TRIM = StackSettings(window_steps=8, goal_trim_time_constant_s=20.0, surface_trim_gain=2.0)
# v5 and the versions that change only its training episodes (v7, v8) fly the same stack.
_RESIDUAL_ON_TUNED_LQI = StackSettings(window_steps=8, residual_on="lqi_tuned", residual_authority=RESIDUAL_AUTHORITY)
FLIGHT_STACKS = {
    "SolarUAVAttitude-v0": StackSettings(),
    "SolarUAVAttitude-v1": _GOAL_AND_SURFACE_TRIM,
    "SolarUAVAttitude-v2": _GOAL_AND_SURFACE_TRIM,
    "SolarUAVAttitude-v3": StackSettings(window_steps=8, error_integrals=True),
    "SolarUAVAttitude-v4": StackSettings(window_steps=8, residual_on="lqi", residual_authority=RESIDUAL_AUTHORITY),
    "SolarUAVAttitude-v5": _RESIDUAL_ON_TUNED_LQI,
    "SolarUAVAttitude-v6": StackSettings(window_steps=8, residual_on="lqi_robust",
                                         residual_authority=RESIDUAL_AUTHORITY),
    "SolarUAVAttitude-v7": _RESIDUAL_ON_TUNED_LQI,
    "SolarUAVAttitude-v8": _RESIDUAL_ON_TUNED_LQI,
    "SolarUAVAttitude-v9": StackSettings(window_steps=8, residual_on="lqi_stressed",
                                         residual_authority=RESIDUAL_AUTHORITY),
    "SolarUAVAttitude-v10": replace(_RESIDUAL_ON_TUNED_LQI, residual_authority=FINE_RESIDUAL_AUTHORITY),
}

__all__ = ["FINE_RESIDUAL_AUTHORITY", "FLIGHT_STACKS", "RESIDUAL_AUTHORITY", "ControlStack", "StackSettings", "observation_row"]

"""The attitude-tracking task on top of the flight core: goals, observation, action, reward, episode end.

| item | definition |
|---|---|
| observation (16) | SPEC Eq. 18-19: altitude, roll, pitch, p, q, r, V_eas, alpha, beta, aileron, elevator, rudder, throttle, then the goals roll_cmd, pitch_cmd, V_eas_cmd; each scaled by ``OBS_OFFSET``/``OBS_SCALE`` |
| action (4) | in [-1, 1]: aileron +-30 deg, elevator +-30 deg, rudder +-20 deg, throttle 0..1 (SPEC Table 2) |
| reward | SPEC Eq. 22: 1 - p_roll - p_pitch - p_V - p_beta, errors in deg and m/s; each term in ``info`` |
| goals | drawn in roll +-5 deg, pitch +-10 deg, V_eas 8..12 m/s; each channel steps to a new draw after a hold drawn in ``goal_hold_s`` |
| start | altitude and EAS drawn (``CoreConfig``), nominal trim, then perturbed |
| end | terminated on ground strike, non-finite state or leaving ``Envelope`` (reason in ``info``); truncated after ``max_steps`` interactions |

Actions outside [-1, 1] by more than 1e-6, or not finite, raise ``ActionError``; within that
tolerance they are clipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from jsbsim_env.core import N_STATE, CoreConfig, FlightCore

GOAL_NAMES = ("roll_cmd_rad", "pitch_cmd_rad", "airspeed_eas_cmd_mps")
GOAL_LOW = np.array([math.radians(-5.0), math.radians(-10.0), 8.0])
GOAL_HIGH = np.array([math.radians(5.0), math.radians(10.0), 12.0])
OBS_SIZE = N_STATE + len(GOAL_NAMES)
ACTION_SIZE = 4

_DEG = math.degrees(1.0)
# Scaled observation = (x - offset) / scale: angles and rates to tens of degrees, surfaces to their
# travel, airspeed about 10 m/s, altitude about 10 km.
OBS_OFFSET = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5, 0, 0, 10.0])
OBS_SCALE = np.array([10000.0, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 2.0, 10 / _DEG, 10 / _DEG,
                      30 / _DEG, 30 / _DEG, 20 / _DEG, 0.5, 10 / _DEG, 10 / _DEG, 2.0])
# Action -> physical command: command = ACTION_OFFSET + ACTION_SCALE * action.
ACTION_SCALE = np.array([30.0, 30.0, 20.0, 0.5])
ACTION_OFFSET = np.array([0.0, 0.0, 0.0, 0.5])
ACTION_TOLERANCE = 1e-6


class ActionError(ValueError):
    """An action that is not finite or lies outside [-1, 1]."""


def action_to_command(action: np.ndarray) -> np.ndarray:
    """Map a policy action in [-1, 1]^4 to aileron, elevator, rudder (deg) and throttle (0..1)."""
    a = np.asarray(action, dtype=float)
    if a.shape != (ACTION_SIZE,):
        raise ActionError(f"action must have shape ({ACTION_SIZE},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ActionError(f"action is not finite: {a}")
    if np.any(np.abs(a) > 1.0 + ACTION_TOLERANCE):
        raise ActionError(f"action {a} is outside [-1, 1]")
    return ACTION_OFFSET + ACTION_SCALE * np.clip(a, -1.0, 1.0)


def command_to_action(command: np.ndarray) -> np.ndarray:
    """Inverse of ``action_to_command``."""
    return (np.asarray(command, dtype=float) - ACTION_OFFSET) / ACTION_SCALE


def scale_observation(state: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The network's observation from a measured state (``core.STATE_NAMES``) and the goal."""
    return ((np.concatenate([state, goal]) - OBS_OFFSET) / OBS_SCALE).astype(np.float32)


def reward_terms(state: np.ndarray, goal: np.ndarray) -> dict[str, float]:
    """SPEC Eq. 22 on the true state: penalties in degrees and m/s, and the reward."""
    p_roll = min(abs(math.degrees(state[1] - goal[0])) / 5.0, 0.3)
    p_pitch = min(abs(math.degrees(state[2] - goal[1])) / 6.0, 0.3)
    p_speed = min(abs(state[6] - goal[2]) / 5.0, 0.3)
    p_beta = min(abs(math.degrees(state[8])) / 30.0, 0.1)
    return {"penalty_roll": p_roll, "penalty_pitch": p_pitch, "penalty_airspeed": p_speed, "penalty_beta": p_beta,
            "reward": 1.0 - p_roll - p_pitch - p_speed - p_beta}


@dataclass(frozen=True)
class TaskConfig:
    """The attitude-tracking task; the flight core's settings are in ``core``."""

    core: CoreConfig = field(default_factory=CoreConfig)
    goal_hold_s: tuple[float, float] = (3.0, 10.0)  # each channel holds its goal this long, drawn uniformly


class GoalSchedule:
    """Step-style goals: each channel jumps to a new uniform draw after its own random hold."""

    def __init__(self, hold_s: tuple[float, float]):
        self.hold_s = hold_s

    def reset(self, rng: np.random.Generator) -> np.ndarray:
        self.rng = rng
        self.goal = rng.uniform(GOAL_LOW, GOAL_HIGH)
        self.next_change_s = rng.uniform(*self.hold_s, size=3)
        return self.goal.copy()

    def update(self, time_s: float) -> np.ndarray:
        due = time_s >= self.next_change_s
        if due.any():
            for i in np.flatnonzero(due):
                self.goal[i] = self.rng.uniform(GOAL_LOW[i], GOAL_HIGH[i])
                self.next_change_s[i] = time_s + self.rng.uniform(*self.hold_s)
        return self.goal.copy()


class AttitudeTask:
    """One aircraft flying the attitude-tracking task (array in, array out; no RL library)."""

    def __init__(self, config: TaskConfig | None = None, root=None):
        self.config = config or TaskConfig()
        self.core = FlightCore(self.config.core, root)
        self.goals = GoalSchedule(self.config.goal_hold_s)
        self.steps = 0

    def reset(self, seed: int | None = None, **overrides) -> tuple[np.ndarray, dict]:
        """Start an episode; ``overrides`` go to ``FlightCore.reset`` (altitude_m, airspeed_eas_mps, parameters)."""
        measurement = self.core.reset(seed, **overrides)
        # The goals draw from their own stream of the episode's seed.
        self.goal = self.goals.reset(np.random.default_rng(self.core.rng.integers(2**63)))
        self.steps = 0
        self.measurement = measurement
        return scale_observation(measurement, self.goal), {"setup": self.core.setup}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        command = action_to_command(action)
        measurement = self.core.step(command)
        self.steps += 1
        terms = reward_terms(self.core.last_true_state, self.goal)
        reason = self.core.envelope_violation()
        terminated = reason is not None
        truncated = not terminated and self.steps >= self.config.core.max_steps
        info = {**terms, "termination": reason or "", "time_s": self.core.time_s, "goal": self.goal.copy()}
        reward = terms["reward"]
        if terminated and not np.isfinite(reward):
            reward = 0.0
        # The next goal is announced with the observation that the next action answers.
        self.goal = self.goals.update(self.core.time_s)
        self.measurement = measurement
        obs = scale_observation(np.nan_to_num(measurement), self.goal)
        return obs, float(reward), terminated, truncated, info

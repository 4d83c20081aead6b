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

from jsbsim_env.core import N_STATE, CoreConfig, FlightCore, envelope_codes, termination_reason

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
    # One comparison catches NaN too (it compares false).
    if not float(np.abs(a).max()) <= 1.0 + ACTION_TOLERANCE:
        raise ActionError(f"action {a} is not finite or outside [-1, 1]")
    return ACTION_OFFSET + ACTION_SCALE * np.clip(a, -1.0, 1.0)


def command_to_action(command: np.ndarray) -> np.ndarray:
    """Inverse of ``action_to_command``."""
    return (np.asarray(command, dtype=float) - ACTION_OFFSET) / ACTION_SCALE


def scale_observation(state: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The network's observation (float32) from measured states (``core.STATE_NAMES``) and goals;
    works on one (13,) + (3,) or on N x 13 + N x 3."""
    return ((np.concatenate([state, goal], axis=-1) - OBS_OFFSET) / OBS_SCALE).astype(np.float32)


REWARD_TERMS = ("penalty_roll", "penalty_pitch", "penalty_airspeed", "penalty_beta")


def reward_terms(states: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """SPEC Eq. 22 for N x 13 true states and N x 3 goals: columns are ``REWARD_TERMS`` then the reward.

    Errors are in degrees and m/s; the reward is 1 minus the sum of the four penalties.
    """
    states, goals = np.atleast_2d(states), np.atleast_2d(goals)
    out = np.empty((len(states), 5))
    out[:, 0] = np.minimum(np.abs(np.degrees(states[:, 1] - goals[:, 0])) / 5.0, 0.3)
    out[:, 1] = np.minimum(np.abs(np.degrees(states[:, 2] - goals[:, 1])) / 6.0, 0.3)
    out[:, 2] = np.minimum(np.abs(states[:, 6] - goals[:, 2]) / 5.0, 0.3)
    out[:, 3] = np.minimum(np.abs(np.degrees(states[:, 8])) / 30.0, 0.1)
    out[:, 4] = 1.0 - out[:, :4].sum(axis=1)
    return out


@dataclass(frozen=True)
class TaskConfig:
    """The attitude-tracking task; the flight core's settings are in ``core``."""

    core: CoreConfig = field(default_factory=CoreConfig)
    goal_hold_s: tuple[float, float] = (3.0, 10.0)  # each channel holds its goal this long, drawn uniformly


class AttitudeTaskBatch:
    """N aircraft flying the attitude-tracking task; arrays in, arrays out; no RL library.

    JSBSim runs aircraft after aircraft; everything else (noise, goals, reward, envelope,
    observation) is done on all N at once. Each aircraft's episode depends only on its seed.
    """

    def __init__(self, num_envs: int, config: TaskConfig | None = None, root=None):
        self.config = config or TaskConfig()
        self.num_envs = n = num_envs
        self.cores = [FlightCore(self.config.core, root) for _ in range(n)]
        self.states = np.zeros((n, N_STATE))  # true states
        self.height_agl_m = np.zeros(n)
        self.noise = np.zeros((n, N_STATE))
        self.goals = np.zeros((n, 3))
        self.next_goal_change_s = np.zeros((n, 3))
        self.steps = np.zeros(n, dtype=np.int64)
        self.interval_s = np.zeros(n)
        self._goal_rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self._sensor_noise = self.config.core.sensor_noise

    # ------------------------------------------------------------------ episode start
    def reset_one(self, i: int, seed: int | None = None, **overrides) -> np.ndarray:
        """Start a new episode on aircraft ``i``; ``overrides`` go to ``FlightCore.reset``. Returns its observation."""
        core = self.cores[i]
        core.reset(seed, **overrides)
        core.true_state(self.states[i])
        self.height_agl_m[i] = core.height_above_ground_m()
        self.interval_s[i] = core.setup.control_interval_s
        # Goals and noise draw from their own streams of the episode's seed.
        self._goal_rngs[i] = grng = np.random.default_rng(core.rng.integers(2**63))
        self.goals[i] = grng.uniform(GOAL_LOW, GOAL_HIGH)
        self.next_goal_change_s[i] = grng.uniform(*self.config.goal_hold_s, size=3)
        self.noise[i] = 0.0
        self._draw_noise(i)
        self.steps[i] = 0
        return self.observation(i)

    # ------------------------------------------------------------------ stepping
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One control interval for every aircraft.

        Returns observations (N x 16), reward terms (N x 5: ``REWARD_TERMS`` then the reward),
        terminated and truncated flags, and termination codes (``core.TERMINATION_CAUSES``).
        The caller resets the aircraft whose episode ended.
        """
        actions = np.asarray(actions, dtype=float).reshape(self.num_envs, ACTION_SIZE)
        if not float(np.abs(actions).max()) <= 1.0 + ACTION_TOLERANCE:  # NaN fails too
            bad = np.flatnonzero(~(np.abs(actions) <= 1.0 + ACTION_TOLERANCE).all(axis=1))
            raise ActionError(f"actions of aircraft {bad.tolist()} are not finite or outside [-1, 1]: {actions[bad]}")
        commands = ACTION_OFFSET + ACTION_SCALE * np.clip(actions, -1.0, 1.0)
        states, agl = self.states, self.height_agl_m
        for i, core in enumerate(self.cores):
            core.fly(commands[i])
            core.true_state(states[i])
            agl[i] = core.height_above_ground_m()
        self.steps += 1
        terms = reward_terms(states, self.goals)
        codes = envelope_codes(states, agl, self.config.core.envelope)
        terminated = codes > 0
        terms[terminated & ~np.isfinite(terms[:, 4])] = 0.0
        truncated = ~terminated & (self.steps >= self.config.core.max_steps)
        time_s = self.steps * self.interval_s
        for i in range(self.num_envs):
            self._draw_noise(i)
            self._update_goals(i, time_s[i])
        obs = self.observations()
        return obs, terms, terminated, truncated, codes

    def _draw_noise(self, i: int) -> None:
        """Advance aircraft ``i``'s Ornstein-Uhlenbeck sensor noise by one control interval."""
        if self._sensor_noise:
            core = self.cores[i]
            self.noise[i] = core.noise.step(self.interval_s[i], core.rng)

    def _update_goals(self, i: int, time_s: float) -> None:
        """Step-style goals: each channel jumps to a new draw once its hold has run out."""
        due = time_s >= self.next_goal_change_s[i]
        if due.any():
            rng = self._goal_rngs[i]
            for j in np.flatnonzero(due):
                self.goals[i, j] = rng.uniform(GOAL_LOW[j], GOAL_HIGH[j])
                self.next_goal_change_s[i, j] = time_s + rng.uniform(*self.config.goal_hold_s)

    # ------------------------------------------------------------------ observations
    def measurements(self) -> np.ndarray:
        """Measured states (true state plus sensor noise), N x 13."""
        return self.states + self.noise

    def observations(self) -> np.ndarray:
        """Scaled network observations, N x 16 float32 (non-finite values of an ended episode as 0)."""
        return np.nan_to_num(scale_observation(self.measurements(), self.goals))

    def observation(self, i: int) -> np.ndarray:
        return self.observations()[i]


class AttitudeTask:
    """One aircraft flying the attitude-tracking task, with gymnasium-style returns."""

    def __init__(self, config: TaskConfig | None = None, root=None):
        self.batch = AttitudeTaskBatch(1, config, root)
        self.config = self.batch.config
        self.core = self.batch.cores[0]

    def reset(self, seed: int | None = None, **overrides) -> tuple[np.ndarray, dict]:
        """Start an episode; ``overrides`` go to ``FlightCore.reset`` (altitude_m, airspeed_eas_mps, parameters)."""
        obs = self.batch.reset_one(0, seed, **overrides)
        return obs, {"setup": self.core.setup, "goal": self.batch.goals[0].copy()}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        b = self.batch
        goal = b.goals[0].copy()
        obs, terms, terminated, truncated, codes = b.step(np.asarray(action, dtype=float)[None])
        info = {name: float(terms[0, j]) for j, name in enumerate(REWARD_TERMS)}
        info.update(termination=termination_reason(int(codes[0]), b.config.core.envelope) or "",
                    time_s=self.core.time_s, goal=goal, true_state=b.states[0].copy())
        return obs[0], float(terms[0, 4]), bool(terminated[0]), bool(truncated[0]), info

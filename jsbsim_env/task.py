"""The attitude-tracking task on top of the flight core: goals, observation, action, reward, episode end.

| item | definition |
|---|---|
| observation (20) | SPEC Eq. 18-19: altitude, roll, pitch, p, q, r, V_eas, alpha, beta, aileron, elevator, rudder, throttle; then the last action (4, in [-1, 1]); then the goals roll_cmd, pitch_cmd, V_eas_cmd; each scaled by ``OBS_OFFSET``/``OBS_SCALE`` |
| action (4) | in [-1, 1]: aileron +-30 deg, elevator +-30 deg, rudder +-20 deg, throttle 0..1 (SPEC Table 2) |
| reward | SPEC Eq. 22: 1 - p_roll - p_pitch - p_V - p_beta, errors in deg and m/s; each term in ``info`` |
| goals | drawn in roll +-5 deg, pitch +-10 deg, V_eas 8..12 m/s; each channel steps to a new draw after a hold drawn in ``goal_hold_s`` |
| start | altitude and EAS drawn (``CoreConfig``), nominal trim, then perturbed |
| end | terminated on ground strike, non-finite state or leaving ``Envelope`` (reason in ``info``); truncated after ``max_steps`` interactions |

Actions outside [-1, 1] by more than 1e-6, or not finite, raise ``ActionError``; within that
tolerance they are clipped.

The last action is in the observation, beyond SPEC Eq. 18-19: a command takes 80-120 ms (two or
three control steps) to reach the actuators, and the measured surface positions do not show it
before then. Without it, nothing in the next observation depends on the action just taken, so a
one-step temporal-difference critic cannot learn what an action does: measured in training, the
critics' Q varied 60 times more between states than between actions. With the last action in
every frame, the 8-step window holds every command still in the delay line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from jsbsim_env.controllers.integral_trim import TrimIntegrator, check_rudder_time
from jsbsim_env.controllers.pid import GainSchedule, PIDAttitudeController
from jsbsim_env.core import (
    N_STATE,
    SCALED_TERMS,
    STATE_NAMES,
    CoreConfig,
    FlightCore,
    envelope_code,
    termination_reason,
)

GOAL_NAMES = ("roll_cmd_rad", "pitch_cmd_rad", "airspeed_eas_cmd_mps")
GOAL_LOW = np.array([math.radians(-5.0), math.radians(-10.0), 8.0])
GOAL_HIGH = np.array([math.radians(5.0), math.radians(10.0), 12.0])
ACTION_SIZE = 4
OBS_SIZE = N_STATE + ACTION_SIZE + len(GOAL_NAMES)

_DEG = math.degrees(1.0)
# Scaled observation = (x - offset) / scale: angles and rates to tens of degrees, surfaces to their
# travel, airspeed about 10 m/s, altitude about 10 km; the last action as it is.
OBS_OFFSET = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0, 0, 10.0])
OBS_SCALE = np.array([10000.0, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 10 / _DEG, 2.0, 10 / _DEG, 10 / _DEG,
                      30 / _DEG, 30 / _DEG, 20 / _DEG, 0.5, 1, 1, 1, 1, 10 / _DEG, 10 / _DEG, 2.0])
LAST_ACTION_COLUMNS = slice(N_STATE, N_STATE + ACTION_SIZE)
GOAL_COLUMNS = slice(-len(GOAL_NAMES), None)  # the goals close every observation layout

# Error integrals (``TaskConfig.error_integral_decay`` > 0), beyond the paper: a decaying integral of
# the roll, pitch, airspeed and sideslip errors, which gives the policy what a PID's integrators
# give it. Columns of the scaled observation they integrate: roll, pitch, V_eas, sideslip.
INTEGRAL_COLUMNS = (1, 2, 6, 8)
# Scaled integral = gain (1 - d) sum_k d^k (x_t-k - g_t): a steady error of e (scaled units)
# reads gain x e; the weight column (1 - d) sum_k d^k rises from 1 - d to 1 after a reset.
INTEGRAL_GAIN = 10.0
INTEGRAL_SIZE = len(INTEGRAL_COLUMNS) + 1

# Integral trim (``TaskConfig.integral_trim`` > 0), beyond the paper: the aileron and elevator
# (and, with ``rudder_trim_s``, rudder) trims of ``controllers.integral_trim.TrimIntegrator``, added to the policy's commands and, unless
# ``TaskConfig.observe_trims`` is off, shown to it (scaled as the surfaces) after the last action,
# before any error integrals and the goals.
TRIM_SIZE = 2
TRIM_SCALE_DEG = 30.0

# The critics' state (``AttitudeTaskBatch.critic_states``), beyond the paper: what makes the task
# Markov for a critic without memory, known in simulation only. The true state (scaled as the
# observation, no noise), the last RECENT_ACTIONS actions (newest first: with at most 120 ms of
# delay and at least 40 ms per step, every command still in the delay line), the flight core's
# ``episode_conditions`` (delay, interval, coefficient scales, turbulence), then, as in the
# observation, the error integrals where configured and the goals last.
RECENT_ACTIONS = 3
CRITIC_STATE_BASE = N_STATE + RECENT_ACTIONS * ACTION_SIZE + 2 + len(SCALED_TERMS) + 6 + len(GOAL_NAMES)
# Action -> physical command: command = ACTION_OFFSET + ACTION_SCALE * action.
ACTION_SCALE = np.array([30.0, 30.0, 20.0, 0.5])
ACTION_OFFSET = np.array([0.0, 0.0, 0.0, 0.5])
ACTION_TOLERANCE = 1e-6
_ACT_SCALE, _ACT_OFFSET = ACTION_SCALE.tolist(), ACTION_OFFSET.tolist()


class ActionError(ValueError):
    """An action that is not finite, lies outside [-1, 1], or has the wrong shape."""


def action_to_command(action: np.ndarray) -> np.ndarray:
    """Map a policy action in [-1, 1]^4 to aileron, elevator, rudder (deg) and throttle (0..1)."""
    a = np.asarray(action, dtype=float)
    if a.shape != (ACTION_SIZE,):
        raise ActionError(f"action must have shape ({ACTION_SIZE},), got {a.shape}")
    # Python comparisons on four floats are several times faster than numpy reductions here (the
    # runtime calls this every control step), and a NaN fails them too.
    limit = 1.0 + ACTION_TOLERANCE
    if not all(-limit <= x <= limit for x in a.tolist()):
        raise ActionError(f"action {a} is not finite or outside [-1, 1]")
    return ACTION_OFFSET + ACTION_SCALE * np.minimum(np.maximum(a, -1.0), 1.0)


def action_list_to_command(action: list[float]) -> list[float]:
    """``action_to_command`` on a list of four floats already in [-1, 1], as a list: what the
    per-step loops use (a few microseconds less than the array version)."""
    return [o + k * x for x, k, o in zip(action, _ACT_SCALE, _ACT_OFFSET)]


def command_to_action(command: np.ndarray) -> np.ndarray:
    """Inverse of ``action_to_command``."""
    return (np.asarray(command, dtype=float) - ACTION_OFFSET) / ACTION_SCALE


def scale_observation(state: np.ndarray, last_action: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The network's observation (float32) from measured states (``core.STATE_NAMES``), the last
    action (in [-1, 1]) and goals; works on one (13,) + (4,) + (3,) or on N rows of each."""
    raw = np.concatenate([state, last_action, goal], axis=-1)
    return ((raw - OBS_OFFSET) / OBS_SCALE).astype(np.float32)


_OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST = OBS_OFFSET.tolist(), (1.0 / OBS_SCALE).tolist()


def scale_row(raw: list[float]) -> list[float]:
    """``scale_observation`` of one measured state, last action and goal joined in a list, on plain
    floats and with the inverse scale as the batched task multiplies (the per-step runtime's form)."""
    return [(x - o) * k for x, o, k in zip(raw, _OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST)]


def initial_last_action(measurement: np.ndarray) -> np.ndarray:
    """The "last action" at the start of an episode: the measured actuator positions (rad, rad, rad,
    throttle) as an action, which is the trim command the aircraft starts settled on."""
    m = np.asarray(measurement, dtype=float)
    return command_to_action(np.array([math.degrees(m[9]), math.degrees(m[10]), math.degrees(m[11]), m[12]]))


REWARD_TERMS = ("penalty_roll", "penalty_pitch", "penalty_airspeed", "penalty_beta")
# The state elements the reward depends on (``core.STATE_NAMES`` order): roll, pitch, V_eas, sideslip.
ACHIEVED_INDEX = (1, 2, 6, 8)
EAS_INDEX = ACHIEVED_INDEX[2]
AILERON_INDEX = STATE_NAMES.index("aileron_rad")  # then elevator and rudder position (rad)
# Errors at which each penalty of Eq. 22 saturates (rad, rad, m/s): beyond them a goal error
# no longer changes the reward.
PENALTY_SATURATION = (math.radians(1.5), math.radians(1.8), 1.5)


def _penalty(x: float, cap: float, tail: float) -> float:
    """One penalty of Eq. 22, ``x`` before its cap: capped, plus ``tail`` times what lies beyond."""
    return min(x, cap) + tail * max(x - cap, 0.0)


def reward_terms(state, goal, sideslip_weight: float = 1.0, penalty_tail: float = 0.0,
                 roll_weight: float = 1.0, pitch_weight: float = 1.0) -> list[float]:
    """SPEC Eq. 22 for one true state (``core.STATE_NAMES`` order) and goal: the four penalties
    (``REWARD_TERMS``, errors in degrees and m/s) and then the reward, 1 minus their sum;
    ``sideslip_weight``, ``roll_weight`` and ``pitch_weight`` scale those penalties and their caps,
    ``penalty_tail`` keeps that share of each penalty's slope beyond its cap (``TaskConfig``; 1, 0
    and 1 give Eq. 22)."""
    p_roll = roll_weight * _penalty(abs(state[1] - goal[0]) * _DEG / 5.0, 0.3, penalty_tail)
    p_pitch = pitch_weight * _penalty(abs(state[2] - goal[1]) * _DEG / 6.0, 0.3, penalty_tail)
    p_speed = _penalty(abs(state[6] - goal[2]) / 5.0, 0.3, penalty_tail)
    p_beta = sideslip_weight * _penalty(abs(state[8]) * _DEG / 30.0, 0.1, penalty_tail)
    return [p_roll, p_pitch, p_speed, p_beta, 1.0 - (p_roll + p_pitch + p_speed + p_beta)]


def _penalties(x, cap: float, tail: float):
    """``_penalty`` on arrays (numpy or torch)."""
    capped = x.clip(max=cap)
    return capped + tail * (x - capped) if tail else capped


def reward_from_achieved(achieved, goal, sideslip_weight: float = 1.0, penalty_tail: float = 0.0,
                         roll_weight: float = 1.0, pitch_weight: float = 1.0):
    """SPEC Eq. 22 on arrays (numpy or torch): ``achieved`` (..., 4) in ``ACHIEVED_INDEX`` order and
    ``goal`` (..., 3) -> reward (...). The vectorised twin of ``reward_terms``."""
    p_roll = roll_weight * _penalties(abs(achieved[..., 0] - goal[..., 0]) * (_DEG / 5.0), 0.3, penalty_tail)
    p_pitch = pitch_weight * _penalties(abs(achieved[..., 1] - goal[..., 1]) * (_DEG / 6.0), 0.3, penalty_tail)
    p_speed = _penalties(abs(achieved[..., 2] - goal[..., 2]) / 5.0, 0.3, penalty_tail)
    p_beta = sideslip_weight * _penalties(abs(achieved[..., 3]) * (_DEG / 30.0), 0.1, penalty_tail)
    return 1.0 - (p_roll + p_pitch + p_speed + p_beta)


@dataclass(frozen=True)
class TaskConfig:
    """The attitude-tracking task; the flight core's settings are in ``core``.

    ``error_integral_decay`` d > 0 adds the error integrals (``ErrorIntegrals``) to the
    observation, before the goals; 0 keeps the 20 values of the table above.
    ``integral_trim`` f > 0 adds integral trim at f times the PID's integral gains to the policy's
    aileron and elevator commands and shows the two trims in the observation (``TRIM_SIZE``).
    ``observe_trims`` False hides the trims from the policy: it cannot then learn to cancel them, so
    they settle where they remove its steady error rather than drifting to their limits against an
    opposite bias of the policy (``docs/training.md``).
    ``trims_in_surfaces`` False takes the present trims off the measured positions of the trimmed
    surfaces in the observation: the policy sees the part of each surface it commanded (exactly in
    steady state; while a trim moves, the actuators lag it by the delay and their time constant).
    With the trims in them, hidden trims show as surfaces that stand away from the policy's last
    action, and a policy learns to cancel them through that. Without integral trim it does nothing.
    ``rudder_trim_s`` T > 0 adds a rudder trim on sideslip beside them, at ``integral_trim`` times
    the PID's sideslip gain over T (``TrimIntegrator``); with hidden trims only.
    ``sideslip_weight`` multiplies Eq. 22's sideslip penalty and its cap (1: the paper's reward),
    ``roll_weight`` its roll penalty and cap, ``pitch_weight`` its pitch penalty and cap (1: the
    paper's reward).
    ``penalty_tail`` keeps that share of each penalty's slope beyond its cap (0: the paper's reward).
    Eq. 22 pays nothing for a pitch error of 12 deg that it does not pay for 2 deg, so a policy
    gains nothing by moving towards a goal it cannot reach within the cap.
    ``external_throttle`` is the share of episodes in which a speed hold (the PID's airspeed loop)
    flies the throttle instead of the policy, as TECS does on a route. Those episodes are speed-free
    for the policy, as a route flown with ``RouteConfig.attitude_eas_demand = "measured"`` is: its
    EAS goal is its measured EAS (so it sees no airspeed error) and the reward has no airspeed term,
    so that it learns to track pitch rather than trade pitch for an airspeed it does not fly.
    """

    core: CoreConfig = field(default_factory=CoreConfig)
    goal_hold_s: tuple[float, float] = (3.0, 10.0)  # each channel holds its goal this long, drawn uniformly
    error_integral_decay: float = 0.0  # per control step; 0.99 forgets with a time constant of 100 steps
    integral_trim: float = 0.0  # fraction of the PID's integral gains; 0: none, as the paper
    observe_trims: bool = True  # the trims in the observation (with integral trim only)
    trims_in_surfaces: bool = True  # the observed surface positions include the trims, as measured
    rudder_trim_s: float = 0.0  # time constant of a rudder trim on sideslip; 0: none
    sideslip_weight: float = 1.0
    roll_weight: float = 1.0
    pitch_weight: float = 1.0
    penalty_tail: float = 0.0
    external_throttle: float = 0.0  # share of episodes; 0: the policy always flies the throttle, as the paper

    def __post_init__(self):
        if not 0.0 <= self.error_integral_decay < 1.0:
            raise ValueError(f"error_integral_decay must lie in [0, 1), got {self.error_integral_decay}")
        check_trim_settings(self.integral_trim, self.observe_trims, self.rudder_trim_s)
        for name in ("sideslip_weight", "roll_weight", "pitch_weight"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise ValueError(f"{name} must lie in [0, 10], got {getattr(self, name)}")
        if not 0.0 <= self.penalty_tail <= 1.0:
            raise ValueError(f"penalty_tail must lie in [0, 1], got {self.penalty_tail}")
        if not 0.0 <= self.external_throttle <= 1.0:
            raise ValueError(f"external_throttle must lie in [0, 1], got {self.external_throttle}")

    @property
    def observation_size(self) -> int:
        return observation_size(self.error_integral_decay, self.integral_trim, self.observe_trims)

    @property
    def critic_state_size(self) -> int:
        return CRITIC_STATE_BASE + self.observation_size - OBS_SIZE


def check_trim_settings(integral_trim: float, observe_trims: bool, rudder_trim_s: float) -> None:
    """Raise ``ValueError`` naming the problem if the integral trim settings cannot go together."""
    if not 0.0 <= integral_trim <= 2.0:
        raise ValueError(f"integral_trim must lie in [0, 2], got {integral_trim}")
    check_rudder_time(rudder_trim_s)
    if rudder_trim_s and (not integral_trim or observe_trims):
        raise ValueError("a rudder trim (rudder_trim_s > 0) needs integral trim (integral_trim > 0) with the "
                         "trims hidden (observe_trims False): the observation has room for two trims")


def observation_size(error_integral_decay: float, integral_trim: float = 0.0, observe_trims: bool = True) -> int:
    """Values in one observation: 20, 5 more with error integrals, 2 more with observed integral trim."""
    trims = TRIM_SIZE if integral_trim > 0.0 and observe_trims else 0
    return OBS_SIZE + (INTEGRAL_SIZE if error_integral_decay > 0.0 else 0) + trims


def without_trims(row: list[float], trim_deg: list[float]) -> list[float]:
    """A row that starts with a state (``core.STATE_NAMES``) with the trims (deg) taken off its
    aileron, elevator and, where trimmed, rudder positions (rad): the part of each surface the
    policy commanded."""
    out = list(row)
    for j, t in enumerate(trim_deg):
        out[AILERON_INDEX + j] -= math.radians(t)
    return out


def insert_trims(scaled: list[float], trim_deg: list[float]) -> list[float]:
    """A scaled observation of the 20-value layout with the integral trims inserted before the goals."""
    return scaled[:-3] + [t / TRIM_SCALE_DEG for t in trim_deg] + scaled[-3:]


class ErrorIntegrals:
    """Decaying integrals of the tracking errors of one aircraft, against its present goal.

    With S = sum_k d^k x_t-k of each measured channel and W = sum_k d^k, the integral is
    S - g_t W: the past measurements against the goal held now. A goal step shifts it at once,
    and a replayed transition can be given another goal exactly (``training.relabel``), because
    S and W do not depend on the goal. Sideslip's goal is 0. Works on scaled observations.
    """

    def __init__(self, decay: float):
        self.decay = float(decay)
        self._factor = INTEGRAL_GAIN * (1.0 - self.decay)
        self.reset()

    def reset(self) -> None:
        self._sums = [0.0] * len(INTEGRAL_COLUMNS)
        self._weight = 0.0

    def extend(self, scaled: list[float]) -> list[float]:
        """Add one scaled observation of the 20-value layout; returns it with the integrals and
        the weight inserted before the goals."""
        d = self.decay
        self._sums = [d * s + scaled[c] for s, c in zip(self._sums, INTEGRAL_COLUMNS)]
        self._weight = d * self._weight + 1.0
        goals = scaled[-3:] + [0.0]  # roll, pitch, V_eas goals; sideslip's is 0 (scaled: 0 too)
        k = self._factor
        integrals = [k * (s - g * self._weight) for s, g in zip(self._sums, goals)]
        return scaled[:-3] + integrals + [(1.0 - d) * self._weight] + scaled[-3:]


_NO_EXTRA_NOISE = [0.0] * (ACTION_SIZE + len(GOAL_NAMES))  # the last action and the goals are known exactly


class AttitudeTaskBatch:
    """N aircraft flying the attitude-tracking task; arrays in, arrays out; no RL library.

    Each aircraft's episode depends only on its seed. The per-aircraft work is plain Python on
    short lists: for vectors of 4 to 16 numbers that is several times faster than numpy calls.
    """

    def __init__(self, num_envs: int, config: TaskConfig | None = None, root=None):
        self.config = config or TaskConfig()
        self.num_envs = n = num_envs
        self.cores = [FlightCore(self.config.core, root) for _ in range(n)]
        self.states: list[list[float]] = [[0.0] * N_STATE for _ in range(n)]  # true states
        self.noise: list[list[float]] = [[0.0] * N_STATE for _ in range(n)]
        self.goals = np.zeros((n, 3))
        self._goal_lists: list[list[float]] = [[0.0, 0.0, 0.0] for _ in range(n)]
        self.next_goal_change_s = np.full((n, 3), np.inf)
        self._next_goal_change_min_s = [math.inf] * n
        self.steps = np.zeros(n, dtype=np.int64)
        self.interval_s = np.zeros(n)
        self._goal_rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(n)]
        self.last_actions: list[list[float]] = [[0.0] * ACTION_SIZE for _ in range(n)]
        self._sensor_noise = self.config.core.sensor_noise
        decay = self.config.error_integral_decay
        self._integrals = [ErrorIntegrals(decay) for _ in range(n)] if decay > 0.0 else None
        trim, self._external_share = self.config.integral_trim, self.config.external_throttle
        schedule = GainSchedule() if trim > 0.0 or self._external_share > 0.0 else None  # read once for all
        self._trims = [TrimIntegrator(trim, schedule, self.config.rudder_trim_s) for _ in range(n)] \
            if trim > 0.0 else None
        self._observe_trims = self._trims is not None and self.config.observe_trims
        self._trim_free_surfaces = self._trims is not None and not self.config.trims_in_surfaces
        self._speed_holds = [PIDAttitudeController(schedule) for _ in range(n)] if self._external_share > 0.0 else None
        self._sideslip_weight, self._roll_weight = self.config.sideslip_weight, self.config.roll_weight
        self._pitch_weight = self.config.pitch_weight
        self._penalty_tail = self.config.penalty_tail
        self.external_throttle = [False] * n  # whether the speed hold flies each aircraft's throttle
        self._obs_lists: list[list[float]] = [[0.0] * self.config.observation_size for _ in range(n)]
        self._recent_actions: list[list[float]] = [[0.0] * (RECENT_ACTIONS * ACTION_SIZE) for _ in range(n)]

    # ------------------------------------------------------------------ episode start
    def reset_one(self, i: int, seed: int | None = None, **overrides) -> np.ndarray:
        """Start a new episode on aircraft ``i``; ``overrides`` go to ``FlightCore.reset``. Returns its observation."""
        core = self.cores[i]
        core.reset(seed, **overrides)
        self.states[i] = core.last_true_state = core.true_state()
        self.last_actions[i] = initial_last_action(self.states[i]).tolist()
        self._recent_actions[i] = self.last_actions[i] * RECENT_ACTIONS  # the trim command, pending or not
        self.interval_s[i] = core.setup.control_interval_s
        # Goals draw from their own stream of the episode's seed.
        self._goal_rngs[i] = grng = np.random.default_rng(core.rng.integers(2**63))
        self.goals[i] = grng.uniform(GOAL_LOW, GOAL_HIGH)
        self._goal_lists[i] = self.goals[i].tolist()
        self.next_goal_change_s[i] = grng.uniform(*self.config.goal_hold_s, size=3)
        self._next_goal_change_min_s[i] = float(self.next_goal_change_s[i].min())
        if self._speed_holds is not None:  # drawn only then, so that other settings keep their goal draws
            self.external_throttle[i] = bool(grng.random() < self._external_share)
            self._speed_holds[i].reset()
        self.noise[i] = core.noise.step(core.setup.control_interval_s, core.rng) if self._sensor_noise \
            else [0.0] * N_STATE
        self.steps[i] = 0
        if self._integrals is not None:
            self._integrals[i].reset()
        if self._trims is not None:
            self._trims[i].reset()
        return np.array(self._observation(i), dtype=np.float32)

    # ------------------------------------------------------------------ stepping
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One control interval for every aircraft.

        Returns observations (N x 20 float32), reward terms (N x 5: ``REWARD_TERMS`` then the
        reward), terminated and truncated flags, and termination codes (``core.TERMINATION_CAUSES``).
        The caller resets the aircraft whose episode ended.
        """
        actions = np.asarray(actions, dtype=float)
        if actions.shape != (self.num_envs, ACTION_SIZE):
            raise ActionError(f"actions must have shape ({self.num_envs}, {ACTION_SIZE}): one row of aileron, "
                              f"elevator, rudder, throttle per aircraft; got shape {actions.shape}")
        rows = actions.tolist()
        hi = 1.0 + ACTION_TOLERANCE
        for i, a in enumerate(rows):
            if not all(-hi <= x <= hi for x in a):  # NaN fails too
                raise ActionError(f"action of aircraft {i} is not finite or outside [-1, 1]: {a}")
        envelope, max_steps = self.config.core.envelope, self.config.core.max_steps
        obs, terms = [], []
        codes = [0] * self.num_envs
        self.steps += 1
        for i, (core, a) in enumerate(zip(self.cores, rows)):
            a = self.last_actions[i] = [min(max(x, -1.0), 1.0) for x in a]
            self._recent_actions[i] = a + self._recent_actions[i][:-ACTION_SIZE]
            command = action_list_to_command(a)
            if self._trims is not None:
                command = self._trims[i].apply(command)
            external = self.external_throttle[i]
            if external:
                # The speed hold reads the measurement the policy acted on and flies the real goal.
                s, e = self.states[i], self.noise[i]
                command[3] = self._speed_holds[i].throttle(core.setup.control_interval_s, s[0] + e[0],
                                                           s[EAS_INDEX] + e[EAS_INDEX], self._goal_lists[i][2])
            core.fly(command)
            self.states[i] = state = core.last_true_state = core.true_state()
            code = codes[i] = envelope_code(state, core.height_above_ground_m(), envelope)
            goal = self._goal_lists[i]
            if external:  # speed-free: no airspeed term
                goal = [goal[0], goal[1], state[EAS_INDEX]]
            t = reward_terms(state, goal, self._sideslip_weight, self._penalty_tail, self._roll_weight,
                             self._pitch_weight)
            if code and not math.isfinite(t[4]):
                t = [0.0] * 5
            terms.append(t)
            if self._sensor_noise:
                self.noise[i] = core.noise.step(core.setup.control_interval_s, core.rng)
            time_s = core.step_index * core.setup.control_interval_s
            if time_s >= self._next_goal_change_min_s[i]:
                self._update_goals(i, time_s)
            if self._trims is not None and not code:
                # The error against the goal now held, measured as the policy sees it, trims the
                # next command (as ``PolicyRuntime`` does in flight).
                measured = [x + e for x, e in zip(state, self.noise[i])]
                self._trims[i].integrate(core.setup.control_interval_s, measured, self._goal_lists[i])
            obs.append(self._observation(i))
        codes_a = np.array(codes)
        terminated = codes_a > 0
        truncated = ~terminated & (self.steps >= max_steps)
        observations = np.array(obs, dtype=np.float32)
        if terminated.any():
            observations = np.nan_to_num(observations)
        return observations, np.array(terms), terminated, truncated, codes_a

    def _update_goals(self, i: int, time_s: float) -> None:
        """Step-style goals: each channel jumps to a new draw once its hold has run out."""
        rng = self._goal_rngs[i]
        for j in np.flatnonzero(time_s >= self.next_goal_change_s[i]):
            self.goals[i, j] = rng.uniform(GOAL_LOW[j], GOAL_HIGH[j])
            self.next_goal_change_s[i, j] = time_s + rng.uniform(*self.config.goal_hold_s)
        self._goal_lists[i] = self.goals[i].tolist()
        self._next_goal_change_min_s[i] = float(self.next_goal_change_s[i].min())

    def set_goal(self, i: int, goal) -> None:
        """Give aircraft ``i`` this goal and hold it (its random schedule stops until the next reset);
        for scripted references such as doublets."""
        self.goals[i] = goal
        self._goal_lists[i] = self.goals[i].tolist()
        self.next_goal_change_s[i] = math.inf
        self._next_goal_change_min_s[i] = math.inf

    # ------------------------------------------------------------------ observations
    def _observation(self, i: int) -> list[float]:
        """Scaled network observation of aircraft ``i`` (measured state, last action, error integrals
        where configured, goal), as a list; once per control step (it advances the integrals)."""
        raw = self.states[i] + self.last_actions[i] + self._goal_lists[i]
        if self._trim_free_surfaces:
            raw = without_trims(raw, self._trims[i].trim_deg)
        noise = self.noise[i] + _NO_EXTRA_NOISE
        if self.external_throttle[i]:  # speed-free: the EAS goal is the measured EAS
            raw[-1] = self.states[i][EAS_INDEX] + self.noise[i][EAS_INDEX]
        obs = [(x + n - o) * k for x, n, o, k in zip(raw, noise, _OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST)]
        if self._observe_trims:
            obs = insert_trims(obs, self._trims[i].trim_deg)
        if self._integrals is not None:
            obs = self._integrals[i].extend(obs)
        self._obs_lists[i] = obs
        return obs

    def critic_states(self) -> np.ndarray:
        """The critics' states (see ``CRITIC_STATE_BASE``), N x ``config.critic_state_size`` float32
        (non-finite values of an ended episode as 0)."""
        rows = []
        offset, inv_scale = _OBS_OFFSET_LIST, _OBS_INV_SCALE_LIST
        for i, core in enumerate(self.cores):
            true = [(x - o) * k for x, o, k in zip(self.states[i], offset, inv_scale)]
            tail = self._obs_lists[i][OBS_SIZE - 3:]  # the trims and error integrals where configured, the goals
            rows.append(true + self._recent_actions[i] + core.episode_conditions() + tail)
        return np.nan_to_num(np.array(rows, dtype=np.float32))

    def measurements(self) -> np.ndarray:
        """Measured states (true state plus sensor noise), N x 13."""
        return np.array(self.states) + np.array(self.noise)

    def observations(self) -> np.ndarray:
        """The latest scaled network observations, N x ``config.observation_size`` float32
        (non-finite values of an ended episode as 0)."""
        return np.nan_to_num(np.array(self._obs_lists, dtype=np.float32))


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
        action = np.asarray(action, dtype=float)
        if action.shape != (ACTION_SIZE,):
            raise ActionError(f"action must have shape ({ACTION_SIZE},): aileron, elevator, rudder, throttle; "
                              f"got shape {action.shape}")
        obs, terms, terminated, truncated, codes = b.step(action[None])
        info = {name: float(terms[0, j]) for j, name in enumerate(REWARD_TERMS)}
        info.update(termination=termination_reason(int(codes[0]), b.config.core.envelope) or "",
                    time_s=self.core.time_s, goal=goal, true_state=np.array(b.states[0]))
        return obs[0], float(terms[0, 4]), bool(terminated[0]), bool(truncated[0]), info

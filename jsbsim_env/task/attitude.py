"""The attitude-tracking task on top of the flight core: goals, observation, action, reward, episode end.

| item | definition |
|---|---|
| observation (20) | the paper's Eqs. 18-19 with the last action: ``jsbsim_env.control.observation`` (its table gives every index, unit and scale) |
| action (4) | in [-1, 1]: aileron +-30 deg, elevator +-30 deg, rudder +-20 deg, throttle 0..1 (the paper's Table 2) |
| reward | the paper's Eq. 22: 1 - p_roll - p_pitch - p_V - p_beta, errors in deg and m/s; each term in ``info`` |
| goals | drawn in roll +-5 deg, pitch +-10 deg, V_eas over the aircraft's envelope (the paper's: 8..12 m/s); each channel steps to a new draw after a hold drawn in ``goal_hold_s`` |
| start | altitude and EAS drawn (``CoreConfig``), nominal trim, then perturbed |
| end | terminated on ground strike, non-finite state or leaving ``Envelope`` (reason in ``info``); truncated after ``max_steps`` interactions |

Actions outside [-1, 1] by more than 1e-6, or not finite, raise ``ActionError``; within that
tolerance they are clipped. ``info["true_state"]`` is the state before sensor noise, in
``jsbsim_env.sim.core.STATE_NAMES`` order (altitude m, roll and pitch rad, p, q, r rad/s, EAS m/s,
alpha and beta rad, aileron, elevator and rudder positions rad, throttle 0..1).

With ``TaskConfig.surface_trim_gain`` > 0, the flown controller's surface trim
(``jsbsim_env.control.trims.SurfaceTrim``, the same stage objects as in flight) adds its trims to
every command and takes them off the observed surface positions, as the flight runtime does. With
``TaskConfig.goal_trim_time_constant_s`` > 0, its goal trim (``GoalTrim``) moves the goal the
policy observes, step for step as ``jsbsim_env.control.stack.ControlStack`` does in flight; the
reward is always against the goal asked for. With ``TaskConfig.residual_on``, a classical
controller flies and the action is its bounded correction (``jsbsim_env.control.residual``, the
same stage as in flight), which the policy observes beside the controller's command and integrators.

``AttitudeTaskBatch.privileged`` gives, per aircraft, what the aircraft cannot measure
(``PRIVILEGED_NAMES``): the true state, the turbulence, the episode's coefficient scales, its delay
and control interval, the trims' states and the command the actuators hold. A critic may read it
(an asymmetric actor-critic); the policy never does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.control.input_checks import GOAL_HIGH, GOAL_LOW, goal_range  # noqa: F401 - the task's, kept here too
from jsbsim_env.control.integrals import ErrorIntegrals, check_error_integrals
from jsbsim_env.control.observation import (
    ACTION_OFFSET,
    ACTION_SIZE,
    ACTION_TOLERANCE,
    GOAL_NAMES,
    OBS_SIZE,
    ActionError,
    action_list_to_command,
    action_scale,
    initial_last_action,
    observation_size,
    scale_row,
)
from jsbsim_env.control.pid import SURFACE_INTEGRATOR_LIMIT_DEG, GainSchedule, PIDAttitudeController
from jsbsim_env.control.residual import ResidualStage, check_residual
from jsbsim_env.control.stack import observation_row
from jsbsim_env.control.teacher import TeacherStage
from jsbsim_env.control.trims import GoalTrim, SurfaceTrim, check_goal_trim_time_constant, check_surface_trim_gain
from jsbsim_env.sim.core import (
    N_STATE,
    STATE_NAMES,
    CoreConfig,
    FlightCore,
    envelope_code,
    termination_reason,
)
from jsbsim_env.sim.model_check import SCALED_TERMS

_DEG = math.degrees(1.0)


REWARD_TERMS = ("penalty_roll", "penalty_pitch", "penalty_airspeed", "penalty_beta")
# The state elements the reward depends on (``core.STATE_NAMES`` order): roll, pitch, V_eas, sideslip.
ACHIEVED_INDEX = (1, 2, 6, 8)
EAS_INDEX = ACHIEVED_INDEX[2]
# Errors at which each penalty of Eq. 22 saturates (rad, rad, m/s): beyond them a goal error
# no longer changes the reward.
PENALTY_SATURATION = (math.radians(1.5), math.radians(1.8), 1.5)

# What ``AttitudeTaskBatch.privileged`` gives, each scaled to about unit size: the true state as the
# observation scales the measured one; turbulence by its 0.5 m/s and 0.005 rad/s; each coefficient
# scale as (scale - 1) / 0.2 (Table 4's range to +-1); delay and control interval about their
# nominal 0.08 s and 0.05 s; trims over their limits; the command held as an action.
PRIVILEGED_NAMES = (*(f"true_{n}" for n in STATE_NAMES), "gust_u", "gust_v", "gust_w", "gust_p", "gust_q", "gust_r",
                    *(f"scale_{t}" for t in SCALED_TERMS), "delay", "control_interval", "surface_trim_aileron",
                    "surface_trim_elevator", "goal_trim_roll", "goal_trim_pitch", "held_aileron", "held_elevator",
                    "held_rudder", "held_throttle")
PRIVILEGED_SIZE = len(PRIVILEGED_NAMES)
_NO_TRIM = [0.0, 0.0]
_ACTION_OFFSET = ACTION_OFFSET.tolist()


def _penalty(x: float, cap: float, tail: float) -> float:
    """One penalty of Eq. 22, ``x`` before its cap: capped, plus ``tail`` times what lies beyond."""
    return min(x, cap) + tail * max(x - cap, 0.0)


def reward_terms(state, goal, sideslip_weight: float = 1.0, penalty_tail: float = 0.0,
                 roll_weight: float = 1.0, pitch_weight: float = 1.0) -> list[float]:
    """The paper's Eq. 22 for one true state (``core.STATE_NAMES`` order) and goal: the four penalties
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
    """The paper's Eq. 22 on arrays (numpy or torch): ``achieved`` (..., 4) in ``ACHIEVED_INDEX`` order and
    ``goal`` (..., 3) -> reward (...). The vectorised twin of ``reward_terms``."""
    p_roll = roll_weight * _penalties(abs(achieved[..., 0] - goal[..., 0]) * (_DEG / 5.0), 0.3, penalty_tail)
    p_pitch = pitch_weight * _penalties(abs(achieved[..., 1] - goal[..., 1]) * (_DEG / 6.0), 0.3, penalty_tail)
    p_speed = _penalties(abs(achieved[..., 2] - goal[..., 2]) / 5.0, 0.3, penalty_tail)
    p_beta = sideslip_weight * _penalties(abs(achieved[..., 3]) * (_DEG / 30.0), 0.1, penalty_tail)
    return 1.0 - (p_roll + p_pitch + p_speed + p_beta)


@dataclass(frozen=True)
class TaskConfig:
    """The attitude-tracking task; the flight core's settings are in ``core``. The defaults are the
    paper's task; the registered versions (``jsbsim_env.task.versions``) name the tasks the package
    trains on.

    ``surface_trim_gain`` g > 0 flies the policy's commands through the control stack's surface
    trim at g times the PID's integral gains (``jsbsim_env.control.trims``); 0: none, as the paper.
    ``goal_trim_time_constant_s`` > 0 gives the policy its goals through the control stack's goal
    trim with that time constant; 0: none, as the paper.
    ``error_integrals`` gives the policy the control stack's roll, pitch and sideslip error
    integrals in its observation (``jsbsim_env.control.integrals``); False: none, as the paper.
    ``residual_on`` names the classical controller whose command the policy corrects by up to
    ``residual_authority`` of each surface's travel (``jsbsim_env.control.residual``); empty: none,
    the policy flies alone, as the paper.
    ``sideslip_weight``, ``roll_weight`` and ``pitch_weight`` multiply Eq. 22's sideslip, roll and
    pitch penalties and their caps (1: the paper's reward).
    ``penalty_tail`` keeps that share of each penalty's slope beyond its cap (0: the paper's reward),
    so that a large error still costs more than a small one.
    ``external_throttle`` is the share of episodes in which a speed hold (the PID's airspeed loop)
    flies the throttle instead of the policy, as TECS does on a route. Those episodes are speed-free
    for the policy, as a route flown with ``RouteConfig.attitude_eas_demand = "measured"`` is: its
    EAS goal is its measured EAS (so it sees no airspeed error) and the reward has no airspeed term.
    """

    core: CoreConfig = field(default_factory=CoreConfig)
    goal_hold_s: tuple[float, float] = (3.0, 10.0)  # each channel holds its goal this long, drawn uniformly
    surface_trim_gain: float = 0.0  # fraction of the PID's integral gains; 0: none, as the paper
    goal_trim_time_constant_s: float = 0.0  # 0: none, as the paper
    error_integrals: bool = False  # False: none, as the paper
    residual_on: str = ""  # empty: none, as the paper
    residual_authority: float = 0.0
    sideslip_weight: float = 1.0
    roll_weight: float = 1.0
    pitch_weight: float = 1.0
    penalty_tail: float = 0.0
    external_throttle: float = 0.0  # share of episodes; 0: the policy always flies the throttle, as the paper

    def __post_init__(self):
        check_surface_trim_gain(self.surface_trim_gain, "surface_trim_gain")
        check_goal_trim_time_constant(self.goal_trim_time_constant_s, "goal_trim_time_constant_s")
        check_error_integrals(self.error_integrals)
        check_residual(self.residual_on, self.residual_authority)
        low, high = self.goal_hold_s
        if not 0.0 < low <= high < math.inf:  # NaN fails too
            raise ValueError(f"goal_hold_s must be a finite range (low, high) with 0 < low <= high, got {(low, high)}")
        for name in ("sideslip_weight", "roll_weight", "pitch_weight"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise ValueError(f"{name} must lie in [0, 10], got {getattr(self, name)}")
        if not 0.0 <= self.penalty_tail <= 1.0:
            raise ValueError(f"penalty_tail must lie in [0, 1], got {self.penalty_tail}")
        if not 0.0 <= self.external_throttle <= 1.0:
            raise ValueError(f"external_throttle must lie in [0, 1], got {self.external_throttle}")

    @property
    def observation_size(self) -> int:
        return observation_size(self.error_integrals, bool(self.residual_on))


_NO_EXTRA_NOISE = [0.0] * (ACTION_SIZE + len(GOAL_NAMES))  # the last action and the goals are known exactly
# What an episode start may override (``FlightCore.reset``'s keywords): gymnasium's reset options.
RESET_OPTIONS = ("altitude_m", "airspeed_eas_mps", "parameters", "heading_deg")


def check_num_envs(num_envs, name: str = "num_envs") -> int:
    """``num_envs`` as an int when it is a whole number >= 1; else a ``ValueError`` naming ``name``."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
        raise ValueError(f"{name} must be a whole number of aircraft >= 1, got {num_envs!r}")
    return int(num_envs)


class AttitudeTaskBatch:
    """N aircraft flying the attitude-tracking task; arrays in, arrays out; no RL library.

    Each aircraft's episode depends only on its seed. The per-aircraft work is plain Python on
    short lists: for vectors of 4 to 16 numbers that is several times faster than numpy calls.
    ``teacher`` (one of ``jsbsim_env.control.teacher.TEACHERS``) flies that LQI in the shadow of
    the policy: ``teacher_actions`` gives its actions on the latest observations, labels to distil.
    """

    def __init__(self, num_envs: int, config: TaskConfig | None = None, teacher: str = ""):
        self.config = config or TaskConfig()
        self.num_envs = n = check_num_envs(num_envs)
        self.cores = [FlightCore(self.config.core) for _ in range(n)]
        self.aircraft = self.cores[0].aircraft
        self.goal_low, self.goal_high = goal_range(self.aircraft)
        # An action of +-1 puts a surface at this aircraft's stop (``observation.action_scale``).
        self.action_scale = action_scale(self.aircraft)
        self._action_scale = self.action_scale.tolist()
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
        trim, self._external_share = self.config.surface_trim_gain, self.config.external_throttle
        # The aircraft's PID gains, read once for all.
        schedule = (GainSchedule(gain_file("pid", self.aircraft)) if trim > 0.0 or self._external_share > 0.0
                    else None)
        self._trims = ([SurfaceTrim(trim, schedule, self.aircraft.surface_limits_deg[:2]) for _ in range(n)]
                       if trim > 0.0 else None)
        tc = self.config.goal_trim_time_constant_s
        self._goal_trims = [GoalTrim(tc) for _ in range(n)] if tc > 0.0 else None
        self._integrals = [ErrorIntegrals() for _ in range(n)] if self.config.error_integrals else None
        base, authority = self.config.residual_on, self.config.residual_authority
        self._residuals = [ResidualStage(base, authority, self.aircraft) for _ in range(n)] if base else None
        self._residual_inputs: list[list[float] | None] = [None] * n  # each step's, as the policy reads them
        # A teacher (``jsbsim_env.control.teacher``) beside the policy: its action on what the policy reads.
        self._teachers = [TeacherStage(teacher, self.aircraft) for _ in range(n)] if teacher else None
        self._speed_holds = ([PIDAttitudeController(schedule, aircraft=self.aircraft) for _ in range(n)]
                             if self._external_share > 0.0 else None)
        self._sideslip_weight, self._roll_weight = self.config.sideslip_weight, self.config.roll_weight
        self._pitch_weight = self.config.pitch_weight
        self._penalty_tail = self.config.penalty_tail
        self.external_throttle = [False] * n  # whether the speed hold flies each aircraft's throttle
        self._obs_lists: list[list[float]] = [[0.0] * self.config.observation_size for _ in range(n)]
        self._not_started = set(range(n))  # aircraft without an episode yet: step() needs reset_one() first

    # ------------------------------------------------------------------ episode start
    def reset_one(self, i: int, seed: int | None = None, **overrides) -> np.ndarray:
        """Start a new episode on aircraft ``i``; ``overrides`` go to ``FlightCore.reset``
        (``RESET_OPTIONS``). Returns its observation."""
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.num_envs:
            raise IndexError(f"aircraft index must be a whole number in 0..{self.num_envs - 1}, got {i!r}")
        unknown = sorted(set(overrides) - set(RESET_OPTIONS))
        if unknown:
            raise ValueError(f"unknown episode-start option(s) {', '.join(map(repr, unknown))}: use "
                             f"{', '.join(RESET_OPTIONS)}")
        core = self.cores[i]
        core.reset(seed, **overrides)
        self._not_started.discard(i)
        self.states[i] = core.last_true_state = core.true_state()
        # A residual's correction starts at zero; a policy alone, at the surfaces' positions.
        self.last_actions[i] = [0.0] * ACTION_SIZE if self._residuals is not None \
            else initial_last_action(self.states[i], self.action_scale)
        self.interval_s[i] = core.setup.control_interval_s
        # Goals draw from their own stream of the episode's seed.
        self._goal_rngs[i] = grng = np.random.default_rng(core.rng.integers(2**63))
        self.goals[i] = grng.uniform(self.goal_low, self.goal_high)
        self._goal_lists[i] = self.goals[i].tolist()
        self.next_goal_change_s[i] = grng.uniform(*self.config.goal_hold_s, size=3)
        self._next_goal_change_min_s[i] = float(self.next_goal_change_s[i].min())
        if self._speed_holds is not None:  # drawn only then, so that other settings keep their goal draws
            self.external_throttle[i] = bool(grng.random() < self._external_share)
            self._speed_holds[i].reset()
        self.noise[i] = core.noise.step(core.setup.control_interval_s, core.rng) if self._sensor_noise \
            else [0.0] * N_STATE
        self.steps[i] = 0
        if self._trims is not None:
            self._trims[i].reset()
        if self._goal_trims is not None:
            self._goal_trims[i].reset()
        if self._integrals is not None:
            self._integrals[i].reset()
        if self._residuals is not None:
            self._residuals[i].reset()
        if self._teachers is not None:
            self._teachers[i].reset()
        self._observe_controllers(i)
        return np.array(self._observation(i), dtype=np.float32)

    # ------------------------------------------------------------------ stepping
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One control interval for every aircraft.

        Returns observations (N x ``observation_size`` float32), reward terms (N x 5: ``REWARD_TERMS`` then the
        reward), terminated and truncated flags, and termination codes (``core.TERMINATION_CAUSES``).
        The caller resets the aircraft whose episode ended.
        """
        if self._not_started:
            who = "the aircraft has" if self.num_envs == 1 else f"aircraft {sorted(self._not_started)} have"
            raise RuntimeError(f"{who} no episode yet: call reset() before step()")
        actions = np.asarray(actions, dtype=float)
        if actions.shape != (self.num_envs, ACTION_SIZE):
            raise ActionError(f"actions must have shape ({self.num_envs}, {ACTION_SIZE}): one row of aileron, "
                              f"elevator, rudder, throttle per aircraft; got shape {actions.shape}")
        rows = actions.tolist()
        hi = 1.0 + ACTION_TOLERANCE
        for i, a in enumerate(rows):
            if not all(-hi <= x <= hi for x in a):  # NaN fails too
                raise ActionError(f"action of aircraft {i} is not finite or outside [-1, 1]: {a}")
        envelope, max_steps = self.cores[0].ends, self.config.core.max_steps
        obs, terms = [], []
        codes = [0] * self.num_envs
        self.steps += 1
        for i, (core, a) in enumerate(zip(self.cores, rows)):
            a = self.last_actions[i] = [min(max(x, -1.0), 1.0) for x in a]
            # A residual's command is its base's list, which the base holds as its delayed command:
            # the speed hold's throttle below reaches it too.
            command = self._residuals[i].command(a) if self._residuals is not None \
                else action_list_to_command(a, self._action_scale)
            if self._trims is not None:
                command = self._trims[i].apply(command)
            if self._goal_trims is not None:
                # This step's error against the goal asked moves the next goal given (as in flight).
                measured = [x + e for x, e in zip(self.states[i], self.noise[i])]
                self._goal_trims[i].integrate(core.setup.control_interval_s, measured, self._goal_lists[i])
            external = self.external_throttle[i]
            if external:
                # The speed hold reads the measurement the policy acted on and flies the real goal.
                s, e = self.states[i], self.noise[i]
                command[3] = self._speed_holds[i].throttle(core.setup.control_interval_s, s[0] + e[0],
                                                           s[EAS_INDEX] + e[EAS_INDEX], self._goal_lists[i][2])
            if self._teachers is not None:
                self._teachers[i].follow(command)
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
            if (self._trims is not None or self._integrals is not None) and not code:
                # The error against the goal now held, measured as the policy sees it, trims the
                # next command and moves the integrals the policy reads (as the control stack does
                # in flight).
                measured = [x + e for x, e in zip(state, self.noise[i])]
                given = self._given_goal(i)
                if self._trims is not None:
                    self._trims[i].integrate(core.setup.control_interval_s, measured, given)
                if self._integrals is not None:
                    self._integrals[i].integrate(core.setup.control_interval_s, measured, given)
            if not code:
                self._observe_controllers(i)
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
            self.goals[i, j] = rng.uniform(self.goal_low[j], self.goal_high[j])
            self.next_goal_change_s[i, j] = time_s + rng.uniform(*self.config.goal_hold_s)
        self._goal_lists[i] = self.goals[i].tolist()
        self._next_goal_change_min_s[i] = float(self.next_goal_change_s[i].min())

    def set_goal(self, i: int, goal) -> None:
        """Give aircraft ``i`` this goal and hold it (its random schedule stops until the next reset);
        for scripted references such as doublets. A goal that is not 3 finite values (roll, pitch
        rad; EAS m/s) is refused (``ValueError``): a NaN goal would make every reward NaN."""
        g = np.asarray(goal, dtype=float)
        if g.shape != (len(GOAL_NAMES),) or not math.isfinite(sum(g.tolist())):
            raise ValueError(f"goal must be {len(GOAL_NAMES)} finite values (roll, pitch rad; EAS m/s), got {goal!r}")
        self.goals[i] = goal
        self._goal_lists[i] = self.goals[i].tolist()
        self.next_goal_change_s[i] = math.inf
        self._next_goal_change_min_s[i] = math.inf

    # ------------------------------------------------------------------ observations
    def _given_goal(self, i: int) -> list[float]:
        """The goal aircraft ``i``'s policy is given: the goal asked for, through the goal trim."""
        goal = self._goal_lists[i]
        return self._goal_trims[i].goal(goal) if self._goal_trims is not None else goal

    def _observed_goal(self, i: int) -> list[float]:
        """The goal aircraft ``i``'s policy (and a residual's base controller) reads."""
        goal = self._given_goal(i)
        if self.external_throttle[i]:  # speed-free: the EAS goal is the measured EAS
            goal = [goal[0], goal[1], self.states[i][EAS_INDEX] + self.noise[i][EAS_INDEX]]
        return goal

    def _observe_controllers(self, i: int) -> None:
        """The step of the classical controllers beside the policy (a residual's base, a teacher)
        on the measurement and goal the policy is about to read."""
        if self._residuals is None and self._teachers is None:
            return
        measured = [x + e for x, e in zip(self.states[i], self.noise[i])]
        dt_s, goal = self.cores[i].setup.control_interval_s, self._observed_goal(i)
        if self._residuals is not None:
            self._residual_inputs[i] = self._residuals[i].observe(dt_s, measured, goal)
        if self._teachers is not None:
            self._teachers[i].observe(dt_s, measured, goal)

    def teacher_actions(self) -> np.ndarray:
        """Each aircraft's teacher's action on its latest observation, N x 4 in [-1, 1]
        (``jsbsim_env.control.teacher``); a ``RuntimeError`` where the batch has no teacher."""
        if self._teachers is None:
            raise RuntimeError("this task batch has no teacher: make it with teacher=<an LQI's name>")
        return np.array([t.action for t in self._teachers], dtype=np.float32)

    def _observation(self, i: int) -> list[float]:
        """Scaled network observation of aircraft ``i`` (measured state, last action, goal given), as a
        list: the control stack's ``observation_row`` on the true state and its sensor noise."""
        trim = self._trims[i] if self._trims is not None else None
        integrals = self._integrals[i] if self._integrals is not None else None
        residual = self._residual_inputs[i] if self._residuals is not None else None
        obs = self._obs_lists[i] = observation_row(self.states[i], self.last_actions[i], self._observed_goal(i), trim,
                                                   self.noise[i] + _NO_EXTRA_NOISE, integrals, residual)
        return obs

    def privileged(self) -> np.ndarray:
        """What the aircraft cannot measure, N x ``PRIVILEGED_SIZE`` float32 (``PRIVILEGED_NAMES``;
        non-finite values of an ended episode as 0), for a critic: never the policy's input."""
        rows = []
        pad = [0.0] * (OBS_SIZE - N_STATE)
        for i, core in enumerate(self.cores):
            setup = core.setup
            gust = core.gust_now()
            scales = setup.scales
            surface = [t / SURFACE_INTEGRATOR_LIMIT_DEG for t in self._trims[i].trim_deg] \
                if self._trims is not None else _NO_TRIM
            goal = [o / self._goal_trims[i].limit_rad for o in self._goal_trims[i].offset_rad] \
                if self._goal_trims is not None else _NO_TRIM
            held = [(c - o) / k for c, o, k in zip(core.applied_command, _ACTION_OFFSET, self._action_scale)]
            rows.append(scale_row(self.states[i] + pad)[:N_STATE]
                        + [g / 0.5 for g in gust[:3]] + [g / 0.005 for g in gust[3:]]
                        + [(scales.get(t, 1.0) - 1.0) / 0.2 for t in SCALED_TERMS]
                        + [(setup.delay_s - 0.08) / 0.04, (setup.control_interval_s - 0.05) / 0.01]
                        + surface + goal + held)
        return np.nan_to_num(np.array(rows, dtype=np.float32))

    def measurements(self) -> np.ndarray:
        """Measured states (true state plus sensor noise), N x 13."""
        return np.array(self.states) + np.array(self.noise)

    def observations(self) -> np.ndarray:
        """The latest scaled network observations, N x ``OBS_SIZE`` float32
        (non-finite values of an ended episode as 0)."""
        return np.nan_to_num(np.array(self._obs_lists, dtype=np.float32))


class AttitudeTask:
    """One aircraft flying the attitude-tracking task, with gymnasium-style returns."""

    def __init__(self, config: TaskConfig | None = None):
        self.batch = AttitudeTaskBatch(1, config)
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
        info.update(termination=termination_reason(int(codes[0]), self.core.ends) or "",
                    time_s=self.core.time_s, goal=goal, true_state=np.array(b.states[0]))
        return obs[0], float(terms[0, 4]), bool(terminated[0]), bool(truncated[0]), info

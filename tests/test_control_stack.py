"""The stages around the learned controller (``jsbsim_env.control.observation``, ``.trims`` and
``.stack``): the observation and its table, the surface and goal trims, the stack's settings and the
stack that runs the stages in order."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import astuple

import numpy as np
import pytest

from jsbsim_env.control.integrals import LIMIT_DEG_S, ErrorIntegrals
from jsbsim_env.control.observation import (
    ACTION_SIZE,
    GOAL_NAMES,
    INTEGRAL_COLUMNS,
    INTEGRAL_SCALE_DEG_S,
    OBS_OFFSET,
    OBS_SCALE,
    OBS_SIZE,
    OBSERVATION_TABLE,
    ActionError,
    ObservationWindow,
    action_list_to_command,
    action_to_command,
    command_to_action,
    initial_last_action,
    scale_observation,
    scale_row,
)
from jsbsim_env.control.pid import (
    DESIGN_EAS_MPS,
    MIN_EAS_FOR_SCALING_MPS,
    SURFACE_INTEGRATOR_LIMIT_DEG,
    GainSchedule,
)
from jsbsim_env.control.stack import ControlStack, StackSettings
from jsbsim_env.control.trims import GoalTrim, SurfaceTrim
from jsbsim_env.sim.core import N_STATE, STATE_NAMES

# Level at 1 km and 10 m/s EAS, pitch 0.02 rad above a zero goal, surfaces a little off neutral.
MEASUREMENT = [1000.0, 0.0, 0.02, 0.0, 0.0, 0.0, 10.0, 0.05, 0.0, 0.01, -0.02, 0.003, 0.4]
GOAL = [0.0, 0.0, 10.0]
DT_S = 0.04


def _gains(altitude_m: float) -> tuple[float, float]:
    """The PID's roll and pitch integral gains at ``altitude_m``."""
    point = GainSchedule().at(altitude_m)
    return point.k_roll_i, point.k_pitch_i


# ----------------------------------------------------------------------------- observation

def test_the_observation_table_has_a_row_per_value_with_the_scaling_used():
    assert len(OBSERVATION_TABLE) == OBS_SIZE == 20 == N_STATE + ACTION_SIZE + len(GOAL_NAMES)
    assert [row.offset for row in OBSERVATION_TABLE] == OBS_OFFSET.tolist()
    assert [row.scale for row in OBSERVATION_TABLE] == OBS_SCALE.tolist()
    names = [row.name for row in OBSERVATION_TABLE]
    assert names[:N_STATE] == list(STATE_NAMES) and names[-3:] == list(GOAL_NAMES)
    assert names[N_STATE:N_STATE + ACTION_SIZE] == ["last_action_aileron", "last_action_elevator",
                                                    "last_action_rudder", "last_action_throttle"]
    units = {row.name: row.unit for row in OBSERVATION_TABLE}
    assert (units["altitude_m"], units["roll_rad"], units["airspeed_eas_mps"], units["roll_cmd_rad"]) == (
        "m", "rad", "m/s", "rad")
    assert units[STATE_NAMES[3]] == "rad/s" and units["last_action_throttle"] == "action"


def test_scale_row_is_the_scaled_observation_with_the_noise_added_before_scaling():
    rng = np.random.default_rng(0)
    for _ in range(20):
        state, last, goal = rng.normal(size=N_STATE), rng.uniform(-1, 1, ACTION_SIZE), rng.normal(size=3)
        raw = [*state, *last, *goal]
        np.testing.assert_allclose(scale_row(raw), scale_observation(state, last, goal), rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(scale_row(raw), (np.array(raw) - OBS_OFFSET) / OBS_SCALE, rtol=1e-12)
        noise = rng.normal(size=OBS_SIZE).tolist()
        np.testing.assert_allclose(scale_row(raw, noise), scale_row((np.array(raw) + noise).tolist()), atol=1e-12)
    assert scale_observation(np.zeros((5, N_STATE)), np.zeros((5, ACTION_SIZE)), np.zeros((5, 3))).shape == (5, 20)


def test_actions_map_to_commands_and_back_and_bad_ones_are_refused():
    action = np.array([0.5, -1.0, 0.25, 0.0])
    command = action_to_command(action)
    np.testing.assert_allclose(command, [15.0, -30.0, 5.0, 0.5])
    np.testing.assert_allclose(command_to_action(command), action)
    assert action_list_to_command(action.tolist()) == command.tolist()
    for bad in ([math.nan, 0, 0, 0], [0, 1.01, 0, 0], [0, 0, -math.inf, 0]):
        with pytest.raises(ActionError, match="not finite or outside"):
            action_to_command(np.array(bad))
    with pytest.raises(ActionError, match="shape"):
        action_to_command(np.zeros(3))


def test_the_first_last_action_is_the_measured_actuator_positions():
    last = initial_last_action(MEASUREMENT)
    assert isinstance(last, list) and len(last) == ACTION_SIZE
    np.testing.assert_allclose(action_to_command(np.array(last)),
                               [math.degrees(0.01), math.degrees(-0.02), math.degrees(0.003), 0.4], atol=1e-12)


def test_the_window_repeats_a_new_episodes_first_observation_and_keeps_the_oldest_first():
    window = ObservationWindow(3, size=2)
    np.testing.assert_array_equal(window.push([1.0, 1.0]), [[1, 1]] * 3)
    window.push([2.0, 2.0])
    np.testing.assert_array_equal(window.push([3.0, 3.0])[:, 0], [1, 2, 3])
    np.testing.assert_array_equal(window.push([4.0, 4.0])[:, 0], [2, 3, 4])
    window.reset()
    np.testing.assert_array_equal(window.push([5.0, 5.0])[:, 0], [5, 5, 5])
    with pytest.raises(ValueError, match="at least 1 step"):
        ObservationWindow(0)


# ----------------------------------------------------------------------------- surface trim

def test_the_surface_trim_integrates_the_errors_onto_aileron_and_elevator_only():
    trim = SurfaceTrim(0.5)
    assert trim.apply([1.0, 2.0, 3.0, 0.4]) == [1.0, 2.0, 3.0, 0.4]  # nothing integrated yet
    trims = trim.integrate(DT_S, MEASUREMENT, GOAL)
    k_roll_i, k_pitch_i = _gains(1000.0)
    assert trims[0] == 0.0 and trims[1] == pytest.approx(0.5 * DT_S * k_pitch_i * 0.02)  # q_s = 1 at 10 m/s
    roll_off = list(MEASUREMENT)
    roll_off[1] = -0.01
    assert trim.integrate(DT_S, roll_off, GOAL)[0] == pytest.approx(0.5 * DT_S * k_roll_i * -0.01)
    command = trim.apply([1.0, 2.0, 3.0, 0.4])
    assert command[0] == pytest.approx(1.0 + trim.trim_deg[0]) and command[1] == pytest.approx(2.0 + trim.trim_deg[1])
    assert command[2:] == [3.0, 0.4]  # rudder and throttle untouched
    trim.reset()
    assert trim.trim_deg == [0.0, 0.0]


@pytest.mark.parametrize(("eas_mps", "q_s"), [(10.0, 1.0), (5.0, (DESIGN_EAS_MPS / MIN_EAS_FOR_SCALING_MPS) ** 2),
                                              (20.0, 0.25)])
def test_the_surface_trims_gains_scale_with_dynamic_pressure(eas_mps, q_s):
    """As the PID's integrators: the gains go as (design EAS / EAS)^2, no higher than at 6 m/s."""
    measurement = list(MEASUREMENT)
    measurement[6] = eas_mps
    trim = SurfaceTrim(1.0)
    assert trim.integrate(DT_S, measurement, GOAL)[1] == pytest.approx(q_s * DT_S * _gains(1000.0)[1] * 0.02)


def test_the_surface_trim_stops_integrating_against_a_saturated_surface_and_stays_in_its_bounds():
    trim = SurfaceTrim(1.0)
    for _ in range(500):
        command = trim.apply([0.0, 30.0, 0.0, 0.5])  # the elevator at its upper limit
        trim.integrate(DT_S, MEASUREMENT, GOAL)  # pitch above its goal: more up elevator wanted
    # One step's worth at the limit, then no more (500 steps would otherwise add about 60 deg).
    assert command[1] == 30.0 and 0.0 < trim.trim_deg[1] < 0.2
    below = list(MEASUREMENT)
    below[2] = -0.02  # the other way is not held back
    held = trim.trim_deg[1]
    assert trim.integrate(DT_S, below, GOAL)[1] < held
    trim = SurfaceTrim(2.0)
    for _ in range(20_000):
        trim.apply([0.0, 0.0, 0.0, 0.5])
        trim.integrate(DT_S, MEASUREMENT, GOAL)
    assert trim.trim_deg[1] == SURFACE_INTEGRATOR_LIMIT_DEG


def test_the_surface_trim_comes_off_the_observed_surfaces():
    trim = SurfaceTrim(1.0)
    trim.trim_deg = [2.0, -3.0]
    row = [*MEASUREMENT, 0.1, 0.2, 0.3, 0.4, *GOAL]
    seen = trim.remove_from(row)
    np.testing.assert_allclose(seen[9:11], [0.01 - math.radians(2.0), -0.02 + math.radians(3.0)])
    assert seen[:9] == row[:9] and seen[11:] == row[11:] and row[9] == 0.01  # the rest as it was, the row untouched


@pytest.mark.parametrize("gain", [-0.5, 2.5, float("nan")])
def test_a_surface_trim_gain_outside_its_range_is_refused(gain):
    with pytest.raises(ValueError, match=r"surface trim gain must lie in \[0, 2\]"):
        SurfaceTrim(gain)


def test_a_surface_trim_of_gain_zero_is_no_stage_and_a_bad_interval_is_refused():
    with pytest.raises(ValueError, match="needs a gain above 0"):
        SurfaceTrim(0.0)
    for dt_s in (float("nan"), 0.0, -0.04, float("inf")):  # a NaN interval would stay in the trims for good
        with pytest.raises(ValueError, match="control interval must be positive"):
            SurfaceTrim(1.0).integrate(dt_s, MEASUREMENT, GOAL)


def test_gain_schedule_interpolates_as_np_interp_to_the_bit():
    """The schedule the PID, the speed hold and the surface trims read every step gives np.interp's
    values exactly, between, at and beyond the design points."""
    schedule = GainSchedule()
    altitudes = [-100.0, 0.0, 499.0, 1000.0, 7_321.5, 20_000.0, 25_000.0, *schedule.altitudes_m.tolist(),
                 *np.random.default_rng(0).uniform(0.0, 21_000.0, 200).tolist()]
    for altitude_m in altitudes:
        expected = [float(np.interp(altitude_m, schedule.altitudes_m, col)) for col in schedule.values.T]
        assert list(astuple(schedule.at(altitude_m))) == expected
        assert schedule.interpolate(altitude_m, (3, 0)) == [expected[3], expected[0]]
    assert all(math.isnan(g) for g in astuple(schedule.at(math.nan)))


# ----------------------------------------------------------------------------- goal trim

def test_goal_trim_moves_the_goal_toward_a_small_error_only_and_within_its_limit():
    trim = GoalTrim(time_constant_s=2.0, limit_deg=1.5, active_below_deg=1.0)
    level = list(MEASUREMENT)
    level[2] = 0.0
    goal = [math.radians(0.5), 0.0, 10.0]  # roll 0.5 deg below its goal: integrate
    assert trim.goal(goal) == goal  # nothing integrated before the first step
    for _ in range(3):
        trim.integrate(DT_S, level, goal)
    assert math.degrees(trim.offset_rad[0]) == pytest.approx(3 * DT_S / 2.0 * 0.5) and trim.offset_rad[1] == 0.0
    given = trim.goal(goal)
    assert given[0] > goal[0] and given[1] == 0.0 and given[2] == 10.0  # EAS passes unchanged
    far = [math.radians(5.0), 0.0, 10.0]  # a goal step, not a steady offset: no integration
    before = list(trim.offset_rad)
    trim.integrate(DT_S, level, far)
    assert trim.offset_rad == before
    nan = list(level)
    nan[1] = math.nan
    trim.integrate(DT_S, nan, goal)
    assert trim.offset_rad == before  # a NaN error integrates nothing
    for _ in range(10_000):
        trim.integrate(DT_S, level, goal)
    assert math.degrees(trim.offset_rad[0]) == pytest.approx(1.5)  # held at its limit
    trim.reset()
    assert trim.offset_rad == [0.0, 0.0]


@pytest.mark.parametrize("kwargs", [{"time_constant_s": 0.0}, {"time_constant_s": float("nan")},
                                    {"time_constant_s": 0.4}, {"time_constant_s": 101.0}, {"limit_deg": 0.0},
                                    {"active_below_deg": -1.0}, {"active_below_deg": 11.0}])
def test_goal_trim_settings_outside_their_range_are_refused(kwargs):
    with pytest.raises(ValueError, match="goal trim"):
        GoalTrim(**kwargs)


def test_error_integrals_integrate_small_errors_only_within_their_bound_sideslip_against_zero():
    integrals = ErrorIntegrals()
    m = list(MEASUREMENT)
    m[1], m[2], m[8] = math.radians(0.5), math.radians(-0.2), math.radians(0.3)
    goal = [0.0, 0.0, 10.0]
    assert integrals.integrate(0.1, m, goal) == pytest.approx([-0.05, 0.02, -0.03])
    m[1] = math.radians(1.5)  # a goal step's transient: the roll integral holds
    assert integrals.integrate(0.1, m, goal) == pytest.approx([-0.05, 0.04, -0.06])
    m[1], m[2], m[8] = math.radians(-0.9), math.radians(-0.9), float("nan")  # a NaN integrates nothing
    for _ in range(200):
        integrals.integrate(0.1, m, goal)
    assert integrals.integral_deg_s == pytest.approx([LIMIT_DEG_S, LIMIT_DEG_S, -0.06])
    integrals.reset()
    assert integrals.integral_deg_s == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="control interval"):
        integrals.integrate(float("nan"), m, goal)


def test_the_error_integrals_are_read_between_the_last_action_and_the_goals():
    stack = ControlStack(StackSettings(window_steps=2, error_integrals=True))
    reference = ErrorIntegrals()
    assert stack.needs_interval
    last = initial_last_action(MEASUREMENT)
    for k, (m, action) in enumerate(zip(_measurements(10), ACTIONS)):
        window = stack.observe(m, GOAL, DT_S)
        if k > 0:  # from the flight's second step, as the trims
            reference.integrate(DT_S, m, GOAL)
        plain = scale_row(m + last + GOAL)
        expected = plain[:-3] + [v / INTEGRAL_SCALE_DEG_S for v in reference.integral_deg_s] + plain[-3:]
        np.testing.assert_allclose(window[-1], np.array(expected, np.float32), rtol=0, atol=0)
        np.testing.assert_allclose(window[-1, INTEGRAL_COLUMNS] * INTEGRAL_SCALE_DEG_S, reference.integral_deg_s,
                                   rtol=1e-6)
        assert stack.command(action) == action_list_to_command(action)  # nothing added to the command
        last = action
    assert reference.integral_deg_s[0] < -1e-3 and reference.integral_deg_s[1] < -1e-3  # roll and pitch above


# ----------------------------------------------------------------------------- stack settings

def test_stack_settings_round_trip_and_default_to_the_network_alone():
    assert StackSettings() == StackSettings(8, 0.0, 0.0)
    for settings in (StackSettings(), StackSettings(8, 20.0, 2.0), StackSettings(1, 0.5, 0.1), StackSettings(64, 100.0)):
        assert StackSettings.from_dict(settings.to_dict()) == settings
    assert StackSettings(8, 20.0, 2.0).to_dict() == {"window_steps": 8, "goal_trim_time_constant_s": 20.0,
                                                     "surface_trim_gain": 2.0, "error_integrals": False,
                                                     "residual_on": "", "residual_authority": 0.0}
    with_integrals = StackSettings(8, error_integrals=True)
    assert StackSettings.from_dict(with_integrals.to_dict()) == with_integrals
    residual = StackSettings(8, residual_on="lqi_tuned", residual_authority=0.25)
    assert StackSettings.from_dict(residual.to_dict()) == residual and residual.network_alone() == residual
    assert (StackSettings().observation_size, with_integrals.observation_size) == (OBS_SIZE, OBS_SIZE + 3)
    # The network alone keeps its inputs and loses the classical stages.
    assert StackSettings(4, 20.0, 2.0, True).network_alone() == StackSettings(4, error_integrals=True)
    assert StackSettings.from_dict({}) == StackSettings()
    with pytest.raises(ValueError, match=r"unknown control-stack settings \['integral_trim'\]"):
        StackSettings.from_dict({"window_steps": 8, "integral_trim": 0.5})
    with pytest.raises(dataclasses.FrozenInstanceError):
        StackSettings().window_steps = 4


@pytest.mark.parametrize(("kwargs", "named"), [
    ({"window_steps": 0}, "window_steps"), ({"window_steps": 65}, "window_steps"),
    ({"window_steps": 8.0}, "window_steps"), ({"window_steps": "8"}, "window_steps"),
    ({"goal_trim_time_constant_s": 0.4}, "goal_trim_time_constant_s"),
    ({"goal_trim_time_constant_s": 101.0}, "goal_trim_time_constant_s"),
    ({"goal_trim_time_constant_s": -1.0}, "goal_trim_time_constant_s"),
    ({"goal_trim_time_constant_s": float("nan")}, "goal_trim_time_constant_s"),
    ({"surface_trim_gain": -0.1}, "surface_trim_gain"), ({"surface_trim_gain": 2.1}, "surface_trim_gain"),
    ({"surface_trim_gain": float("nan")}, "surface_trim_gain"),
    ({"error_integrals": 1}, "error_integrals"), ({"error_integrals": "yes"}, "error_integrals"),
])
def test_stack_settings_outside_their_ranges_are_refused_by_name(kwargs, named):
    with pytest.raises(ValueError, match=named):
        StackSettings(**kwargs)


# ----------------------------------------------------------------------------- the stack

def _measurements(n: int, seed: int = 0) -> list[list[float]]:
    """``n`` measurements near ``MEASUREMENT``, pitch and roll a little off a zero goal."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        m = list(MEASUREMENT)
        m[1], m[2] = 0.004 + rng.normal(0.0, 1e-3), 0.006 + rng.normal(0.0, 1e-3)
        m[6] = 10.0 + rng.normal(0.0, 0.1)
        out.append(m)
    return out


ACTIONS = [[0.1, -0.2, 0.05, 0.1], [0.2, 0.1, -0.1, 0.0], [-0.3, 0.2, 0.0, -0.2], [0.0, 0.3, 0.1, 0.2]] * 3


def test_without_trims_the_stack_observes_the_scaled_measurement_last_action_and_goal():
    stack = ControlStack(StackSettings(window_steps=4))
    assert not stack.needs_interval and stack.goal_trim is None and stack.surface_trim is None
    rows, last = [], initial_last_action(MEASUREMENT)
    for m, action in zip(_measurements(6), ACTIONS):
        window = stack.observe(m, GOAL, None)
        rows.append(scale_row(m + last + GOAL))
        expected = ([rows[0]] * 4 + rows)[-4:]  # a new flight's window is its first observation repeated
        np.testing.assert_allclose(window, np.array(expected, dtype=np.float32), rtol=0, atol=0)
        assert stack.command(action) == action_list_to_command(action)
        last = action


def test_a_surface_trim_is_taken_off_the_observed_surfaces_and_added_to_the_command():
    stack = ControlStack(StackSettings(window_steps=2, surface_trim_gain=1.0))
    reference = SurfaceTrim(1.0)
    assert stack.needs_interval and stack.goal_trim is None
    last = initial_last_action(MEASUREMENT)
    for k, (m, action) in enumerate(zip(_measurements(10), ACTIONS)):
        window = stack.observe(m, GOAL, DT_S)
        if k > 0:  # the trims start from zero with the flight and integrate from its second step
            reference.integrate(DT_S, m, GOAL)
        assert stack.surface_trim.trim_deg == reference.trim_deg
        observed = window[-1] * OBS_SCALE + OBS_OFFSET
        np.testing.assert_allclose(observed[9:11], np.array(m[9:11]) - np.radians(reference.trim_deg), atol=1e-6)
        np.testing.assert_allclose(window[-1], np.array(scale_row(reference.remove_from(m + last + GOAL)), np.float32))
        command = stack.command(action)
        np.testing.assert_allclose(command, reference.apply(action_list_to_command(action)), rtol=0, atol=0)
        np.testing.assert_allclose(command[:2], action_to_command(np.array(action))[:2] + reference.trim_deg, atol=1e-12)
        assert command[2:] == action_list_to_command(action)[2:]
        last = action
    assert min(abs(t) for t in reference.trim_deg) > 1e-3  # both trims moved


def test_a_goal_trim_moves_the_goal_the_network_is_given():
    stack = ControlStack(StackSettings(window_steps=2, goal_trim_time_constant_s=5.0))
    reference = GoalTrim(5.0)
    for m, action in zip(_measurements(10), ACTIONS):
        window = stack.observe(m, GOAL, DT_S)
        given = window[-1, -3:] * OBS_SCALE[-3:] + OBS_OFFSET[-3:]
        np.testing.assert_allclose(given, reference.goal(GOAL), atol=1e-6)
        stack.command(action)
        reference.integrate(DT_S, m, GOAL)  # after the command: this step's error moves the next goal
        assert stack.goal_trim.offset_rad == reference.offset_rad
    assert reference.offset_rad[0] < -1e-4 and reference.offset_rad[1] < -1e-4  # roll and pitch above: goals lowered


def test_reset_starts_every_stage_afresh():
    settings = StackSettings(window_steps=3, goal_trim_time_constant_s=5.0, surface_trim_gain=1.0)
    stack, fresh = ControlStack(settings), ControlStack(settings)
    flights = _measurements(8, seed=1)
    for m, action in zip(flights, ACTIONS):
        stack.observe(m, GOAL, DT_S)
        stack.command(action)
    assert stack.surface_trim.trim_deg != [0.0, 0.0] and stack.goal_trim.offset_rad != [0.0, 0.0]
    stack.reset()
    assert stack.last_action is None and stack.surface_trim.trim_deg == [0.0, 0.0]
    assert stack.goal_trim.offset_rad == [0.0, 0.0]
    for m, action in zip(flights[:4], ACTIONS):  # the same flight again gives what a new stack gives
        np.testing.assert_array_equal(stack.observe(m, GOAL, DT_S), fresh.observe(m, GOAL, DT_S))
        assert stack.command(action) == fresh.command(action)


# ----------------------------------------------------------------------------- in closed loop

class _StackAroundProportional:
    """The control stack around a stand-in for a network that has no integral action: the PID
    without its roll and pitch integrators, and with its aileron and elevator 1 deg off, reading the
    window's newest observation. It holds a steady error, as such a policy does."""

    def __init__(self, settings: StackSettings):
        from jsbsim_env.control.pid import PIDAttitudeController

        self.stack, self.law = ControlStack(settings), PIDAttitudeController()

    def reset(self):
        self.stack.reset()
        self.law.reset()

    def update(self, dt_s, measurement, setpoint):
        m, asked = np.asarray(measurement, float).tolist(), np.asarray(setpoint, float).tolist()
        newest = self.stack.observe(m, asked, dt_s)[-1].astype(float) * OBS_SCALE + OBS_OFFSET
        command = self.law.update(dt_s, newest[:N_STATE], newest[-3:]) + np.array([1.0, 1.0, 0.0, 0.0])
        self.law.i_roll_deg = self.law.i_pitch_deg = 0.0
        action = np.clip(command_to_action(command), -1.0, 1.0).tolist()
        return np.array(self.stack.command(action))


@pytest.mark.parametrize(("trims", "pitch_share"), [(StackSettings(surface_trim_gain=0.5), 0.5),
                                                    (StackSettings(goal_trim_time_constant_s=5.0), 0.3)],
                         ids=["surface trim", "goal trim"])
def test_each_trim_removes_a_steady_error_on_the_route(trims, pitch_share):
    from jsbsim_env.missions import RouteConfig, fly_route
    from training.evaluation.report import steady_state_errors

    config = RouteConfig(altitude_m=1000.0, duration_s=200.0)
    alone = steady_state_errors(fly_route(_StackAroundProportional(StackSettings()), config), 60.0)
    trimmed = steady_state_errors(fly_route(_StackAroundProportional(trims), config), 60.0)
    assert alone["pitch_deg"] > 0.2 and trimmed["pitch_deg"] < pitch_share * alone["pitch_deg"]
    assert alone["roll_deg"] > 0.1 and trimmed["roll_deg"] < 0.5 * alone["roll_deg"]


# ----------------------------------------------------------------------------- training as flown
@pytest.mark.parametrize("goal_trim_s, surface_gain, integrals", [(20.0, 2.0, False), (0.0, 0.5, False),
                                                                  (5.0, 0.0, False), (0.0, 0.0, True), (20.0, 2.0, True)])
def test_the_training_task_observes_step_for_step_as_the_flight_stack(goal_trim_s, surface_gain, integrals):
    # The task's episodes (sensor noise, delay, random interval on) fed to the flight stack as
    # measurements: from the second step on, when both last actions are the policy's, the stack's
    # newest observation is the task's, so a policy trained in the task flies as it trained.
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.task.attitude import AttitudeTask, TaskConfig

    pilot = PIDAttitudeController()  # flies the aircraft close to its goals, where the goal trim acts
    task = AttitudeTask(TaskConfig(surface_trim_gain=surface_gain, goal_trim_time_constant_s=goal_trim_s,
                                   error_integrals=integrals))
    stack = ControlStack(StackSettings(window_steps=1, goal_trim_time_constant_s=goal_trim_s,
                                       surface_trim_gain=surface_gain, error_integrals=integrals))
    assert task.config.observation_size == stack.settings.observation_size
    obs, _ = task.reset(seed=5)
    dt_s = task.core.setup.control_interval_s
    for k in range(250):  # 10 s: goals change, trims move
        b = task.batch
        measurement, asked = b.measurements()[0], b.goals[0].copy()
        window = stack.observe(measurement.tolist(), asked.tolist(), dt_s)
        if k > 0:
            np.testing.assert_allclose(window[-1], obs, rtol=0, atol=1e-6)
        action = np.clip(command_to_action(pilot.update(dt_s, measurement, asked)), -1.0, 1.0).tolist()
        stack.command(action)
        obs, _, terminated, truncated, _ = task.step(np.array(action))
        assert obs.shape == (stack.settings.observation_size,) and not (terminated or truncated)
    if surface_gain:
        assert max(abs(t) for t in stack.surface_trim.trim_deg) > 1e-3
    if goal_trim_s:
        assert max(abs(t) for t in stack.goal_trim.offset_rad) > 1e-5
    if integrals:
        assert min(abs(v) for v in stack.integrals.integral_deg_s) > 1e-4

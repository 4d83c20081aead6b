"""Integral trim around an attitude controller: it removes a steady error, stops integrating
against a saturated surface, and refuses a nonsensical gain."""

import math
from dataclasses import astuple

import numpy as np
import pytest

from jsbsim_env.control.goal_trim import GoalTrim
from jsbsim_env.control.integral_trim import IntegralTrim
from jsbsim_env.control.pid import SURFACE_INTEGRATOR_LIMIT_DEG, PIDAttitudeController
from jsbsim_env.missions import RouteConfig, fly_route
from training.evaluation.report import steady_state_errors


class _Offset:
    """A controller that holds a fixed command whatever the state."""

    def __init__(self, command):
        self.command = np.array(command, dtype=float)

    def reset(self):
        pass

    def update(self, dt_s, measurement, setpoint):
        return self.command.copy()


MEASUREMENT = np.array([1000.0, 0.0, 0.02, 0, 0, 0, 10.0, 0.05, 0, 0, 0, 0, 0.4])


def test_it_integrates_the_errors_onto_aileron_and_elevator_only():
    trim = IntegralTrim(_Offset([1.0, 2.0, 3.0, 0.4]), fraction=0.5)
    first = trim.update(0.04, MEASUREMENT, np.array([0.0, 0.0, 10.0]))
    assert np.array_equal(first, [1.0, 2.0, 3.0, 0.4])  # nothing integrated yet
    second = trim.update(0.04, MEASUREMENT, np.array([0.0, 0.0, 10.0]))
    assert second[0] == 1.0 and second[1] > 2.0 and second[2:].tolist() == [3.0, 0.4]  # pitch above its goal
    trim.reset()
    assert trim.trim_deg.tolist() == [0.0, 0.0]


def test_it_stops_integrating_against_a_saturated_surface():
    trim = IntegralTrim(_Offset([0.0, 30.0, 0.0, 0.5]), fraction=1.0)
    for _ in range(500):
        command = trim.update(0.04, MEASUREMENT, np.array([0.0, 0.0, 10.0]))
    # One step's worth at the limit, then no more (500 steps would otherwise add about 60 deg).
    assert command[1] == 30.0 and 0.0 < trim.trim_deg[1] < 0.2
    trim = IntegralTrim(_Offset([0.0, 0.0, 0.0, 0.5]), fraction=2.0)
    for _ in range(20_000):
        trim.update(0.04, MEASUREMENT, np.array([0.0, 0.0, 10.0]))
    assert trim.trim_deg[1] == SURFACE_INTEGRATOR_LIMIT_DEG


@pytest.mark.parametrize("fraction", [0.0, -0.5, 3.0, float("nan")])
def test_a_fraction_outside_its_range_is_refused(fraction):
    with pytest.raises(ValueError, match="integral trim fraction must lie in"):
        IntegralTrim(_Offset([0, 0, 0, 0.5]), fraction)


class _ProportionalOnly(PIDAttitudeController):
    """The PID without its roll and pitch integrators and with its aileron and elevator trim 1 deg
    off: a controller with a steady error, as a policy without integral action has."""

    def update(self, dt_s, measurement, setpoint):
        command = super().update(dt_s, measurement, setpoint)
        self.i_roll_deg = self.i_pitch_deg = 0.0
        return command + np.array([1.0, 1.0, 0.0, 0.0])


@pytest.mark.parametrize(("wrap", "pitch_share"), [(lambda c: IntegralTrim(c, 0.5), 0.5),
                                                   (lambda c: GoalTrim(c, 5.0), 0.3)], ids=["surfaces", "goals"])
def test_it_removes_a_controllers_steady_errors_on_the_route(wrap, pitch_share):
    config = RouteConfig(altitude_m=1000.0, duration_s=200.0)
    alone = steady_state_errors(fly_route(_ProportionalOnly(), config), 60.0)
    trimmed = steady_state_errors(fly_route(wrap(_ProportionalOnly()), config), 60.0)
    assert alone["pitch_deg"] > 0.2 and trimmed["pitch_deg"] < pitch_share * alone["pitch_deg"]
    assert alone["roll_deg"] > 0.1 and trimmed["roll_deg"] < 0.5 * alone["roll_deg"]


def test_the_rudder_trim_integrates_sideslip_against_the_pid_sideslip_gain():
    sideslip = MEASUREMENT.copy()
    sideslip[8] = math.radians(1.0)
    fast, slow = (IntegralTrim(_Offset([0.0, 0.0, 2.0, 0.4]), 0.5, rudder_time_s=t) for t in (2.0, 8.0))
    for trim in (fast, slow):
        trim.update(0.04, sideslip, np.array([0.0, 0.02, 10.0]))
        command = trim.update(0.04, sideslip, np.array([0.0, 0.02, 10.0]))
        # The PID's sideslip gain is negative (positive rudder yaws left): positive sideslip, less rudder.
        assert command[2] < 2.0 and command[:2].tolist() == [0.0, 0.0]
    assert fast.trim_deg[2] == pytest.approx(4.0 * slow.trim_deg[2])  # the gain goes as 1 / time constant
    assert IntegralTrim(_Offset([0, 0, 0, 0.5]), 0.5).trim_deg.size == 2  # none unless asked for
    with pytest.raises(ValueError, match="rudder trim time constant"):
        IntegralTrim(_Offset([0, 0, 0, 0.5]), 0.5, rudder_time_s=0.1)


def test_a_policy_with_built_in_trim_refuses_a_second_one():
    class TrainedWithTrim:
        def __init__(self):
            self.meta = {"integral_trim": 0.5}

        def reset(self):
            pass

    with pytest.raises(ValueError, match="trained with integral trim"):
        IntegralTrim(TrainedWithTrim(), 0.5)


def test_gain_schedule_interpolates_as_np_interp_to_the_bit():
    """The schedule the PID, the speed hold and the integral trims read every step gives np.interp's
    values exactly, between, at and beyond the design points."""
    from jsbsim_env.control.pid import GainSchedule

    schedule = GainSchedule()
    altitudes = [-100.0, 0.0, 499.0, 1000.0, 7_321.5, 20_000.0, 25_000.0, *schedule.altitudes_m.tolist(),
                 *np.random.default_rng(0).uniform(0.0, 21_000.0, 200).tolist()]
    for altitude_m in altitudes:
        expected = [float(np.interp(altitude_m, schedule.altitudes_m, col)) for col in schedule.values.T]
        assert list(astuple(schedule.at(altitude_m))) == expected
        assert schedule.interpolate(altitude_m, (3, 0)) == [expected[3], expected[0]]
    assert all(math.isnan(g) for g in astuple(schedule.at(math.nan)))


@pytest.mark.parametrize(("fraction", "observe"), [(0.0, False), (0.5, True)])
def test_a_rudder_trim_needs_hidden_integral_trims(fraction, observe):
    from jsbsim_env.task.attitude import TaskConfig

    with pytest.raises(ValueError, match="a rudder trim"):
        TaskConfig(integral_trim=fraction, observe_trims=observe, rudder_trim_s=2.0)


class _Recorder(_Offset):
    """Holds a fixed command and remembers the setpoints it was given."""

    def __init__(self):
        super().__init__([0.0, 0.0, 0.0, 0.5])
        self.setpoints = []

    def update(self, dt_s, measurement, setpoint):
        self.setpoints.append(np.array(setpoint, dtype=float))
        return super().update(dt_s, measurement, setpoint)


def test_goal_trim_moves_the_goal_toward_a_small_error_only_and_within_its_limit():
    recorder = _Recorder()
    trim = GoalTrim(recorder, time_constant_s=2.0, limit_deg=1.5, active_below_deg=1.0)
    level = MEASUREMENT.copy()
    level[2] = 0.0
    goal = np.array([math.radians(0.5), 0.0, 10.0])  # roll 0.5 deg below its goal: integrate
    for _ in range(3):
        trim.update(0.04, level, goal)
    assert recorder.setpoints[0].tolist() == goal.tolist()  # nothing integrated before the first step
    assert trim.offset_deg[0] == pytest.approx(3 * 0.04 / 2.0 * 0.5) and trim.offset_deg[1] == 0.0
    assert recorder.setpoints[-1][0] > goal[0] and recorder.setpoints[-1][2] == 10.0  # EAS passes unchanged
    far = np.array([math.radians(5.0), 0.0, 10.0])  # a goal step, not a steady offset: no integration
    before = trim.offset_deg.copy()
    trim.update(0.04, level, far)
    assert np.array_equal(trim.offset_deg, before)
    for _ in range(10_000):
        trim.update(0.04, level, goal)
    assert trim.offset_deg[0] == pytest.approx(1.5)  # held at its limit
    trim.reset()
    assert trim.offset_deg.tolist() == [0.0, 0.0]


@pytest.mark.parametrize("kwargs", [{"time_constant_s": 0.0}, {"time_constant_s": float("nan")}, {"limit_deg": 0.0},
                                    {"active_below_deg": -1.0}])
def test_goal_trim_settings_outside_their_range_are_refused(kwargs):
    with pytest.raises(ValueError, match="goal trim"):
        GoalTrim(_Offset([0, 0, 0, 0.5]), **kwargs)

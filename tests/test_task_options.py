"""The task's training options beyond the paper: their ranges, and the speed hold that flies the
throttle in a share of the episodes."""

from __future__ import annotations

import numpy as np
import pytest

from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig


@pytest.mark.parametrize(("field", "value"), [("surface_trim_gain", -0.1), ("surface_trim_gain", 2.5),
                                              ("surface_trim_gain", float("nan")), ("external_throttle", 1.5),
                                              ("sideslip_weight", -1.0), ("sideslip_weight", 11.0),
                                              ("roll_weight", -0.5), ("roll_weight", float("nan")),
                                              ("pitch_weight", 10.5), ("pitch_weight", float("nan"))])
def test_training_options_out_of_range_are_refused(field, value):
    with pytest.raises(ValueError, match=f"{field} must lie in"):
        TaskConfig(**{field: value})


def test_external_throttle_flies_the_throttle_whatever_the_policy_commands():
    def fly(throttle_action: float, share: float) -> np.ndarray:
        batch = AttitudeTaskBatch(1, TaskConfig(external_throttle=share))
        batch.reset_one(0, seed=12)
        for _ in range(60):
            batch.step(np.array([[0.0, 0.0, 0.0, throttle_action]]))
        assert batch.external_throttle[0] == (share == 1.0)
        return np.array(batch.states[0])

    np.testing.assert_array_equal(fly(-1.0, 1.0), fly(1.0, 1.0))  # the speed hold's throttle alone
    assert abs(fly(-1.0, 0.0)[6] - fly(1.0, 0.0)[6]) > 0.5  # the policy's throttle otherwise


def test_speed_hold_episodes_are_speed_free_for_the_policy():
    """The EAS goal the policy sees is its measured EAS, the reward has no airspeed term, and the
    environment marks those steps for the learner (so relabelling leaves them alone)."""
    from jsbsim_env.control.observation import OBS_OFFSET, OBS_SCALE
    from jsbsim_env.task.attitude import EAS_INDEX
    from jsbsim_env.task.torchrl_env import SolarUAVAttitudeEnv

    batch = AttitudeTaskBatch(1, TaskConfig(external_throttle=1.0))
    batch.reset_one(0, seed=5)
    real_goal_mps = batch.goals[0, 2]
    for _ in range(20):
        obs, terms, *_ = batch.step(np.zeros((1, 4)))
        raw = obs[0] * OBS_SCALE + OBS_OFFSET
        assert raw[-1] == pytest.approx(raw[EAS_INDEX], abs=1e-4)  # goal column = measured EAS column
        assert terms[0, 2] == 0.0  # no airspeed penalty
    assert abs(batch.states[0][EAS_INDEX] - real_goal_mps) > 1e-3  # the speed hold still flies the real goal

    env = SolarUAVAttitudeEnv(2, TaskConfig(external_throttle=0.5), seed=3)
    td = env.rollout(3)
    assert td["next", "speed_free"].shape == (2, 3, 1)
    assert td["next", "speed_free"][:, 0, 0].tolist() == env.batch.external_throttle
    assert "speed_free" not in SolarUAVAttitudeEnv(1, TaskConfig()).observation_spec


def test_speed_hold_is_the_pid_airspeed_loop():
    """``throttle()`` (the speed hold) gives the PID's throttle, integrator and anti-windup included."""
    from jsbsim_env.control.pid import PIDAttitudeController

    rng = np.random.default_rng(0)
    full, hold = PIDAttitudeController(), PIDAttitudeController()
    for _ in range(300):
        m = np.zeros(13)
        m[0], m[6] = rng.uniform(0.0, 20_000.0), rng.uniform(6.0, 14.0)
        goal = np.array([0.0, 0.0, rng.uniform(8.0, 12.0)])
        assert hold.throttle(0.04, m[0], m[6], goal[2]) == full.update(0.04, m, goal)[3]
    assert hold.i_throttle == full.i_throttle != 0.0

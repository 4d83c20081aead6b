"""The registered task versions (``jsbsim_env.task.versions``): what each trains on and flies with,
their gymnasium registration, and a clear error for a version the package does not have."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import jsbsim_env
from jsbsim_env.control.observation import OBS_SIZE
from jsbsim_env.control.stack import FINE_RESIDUAL_AUTHORITY, RESIDUAL_AUTHORITY, StackSettings
from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import TaskConfig
from jsbsim_env.task.versions import LATEST, V0, V1, V2, V3, V5, V7, V8, V9, V10, VERSIONS, TaskVersion, task_version


def test_v0_is_the_papers_task_flown_by_the_network_alone():
    assert V0.env_id == "SolarUAVAttitude-v0" and V0.task == TaskConfig() and V0.flight_stack == StackSettings()
    paper = V0.task
    assert paper.core == CoreConfig() and paper.core.delay_s == (0.08, 0.12) and paper.core.turbulence_sigma_mps == 0.5
    assert (paper.surface_trim_gain, paper.external_throttle, paper.penalty_tail) == (0.0, 0.0, 0.0)
    assert (paper.sideslip_weight, paper.roll_weight, paper.pitch_weight) == (1.0, 1.0, 1.0)


def test_v1_is_the_shipped_controllers_task_and_flight_stack():
    assert V1.env_id == "SolarUAVAttitude-v1" == LATEST
    assert V1.flight_stack == StackSettings(window_steps=8, goal_trim_time_constant_s=20.0, surface_trim_gain=2.0)
    task = V1.task
    assert task.surface_trim_gain == 0.5 and task.external_throttle == 0.3 and task.penalty_tail == 0.1
    assert (task.sideslip_weight, task.roll_weight, task.pitch_weight) == (6.0, 2.0, 2.0)
    assert task.core.delay_s == (0.04, 0.12)
    # Its other disturbances are the paper's.
    assert {**task.core.__dict__, "delay_s": None} == {**CoreConfig().__dict__, "delay_s": None}


def test_v2_trains_with_v1s_flight_stack_around_the_network():
    assert V2.env_id == "SolarUAVAttitude-v2" and V2.flight_stack == V1.flight_stack
    assert V2.trained_as_flown and V0.trained_as_flown and not V1.trained_as_flown
    assert (V2.task.surface_trim_gain, V2.task.goal_trim_time_constant_s) == (2.0, 20.0)
    # Everything else is v1's task.
    assert {**V2.task.__dict__, "surface_trim_gain": 0.5, "goal_trim_time_constant_s": 0.0} == V1.task.__dict__


def test_v3_learns_its_integral_action_from_the_error_integrals_with_no_trim_around_the_network():
    assert V3.env_id == "SolarUAVAttitude-v3" and V3.trained_as_flown
    assert V3.flight_stack == StackSettings(window_steps=8, error_integrals=True)
    assert V3.task.error_integrals and V3.task.observation_size == OBS_SIZE + 3
    # Everything else is v1's task.
    assert {**V3.task.__dict__, "surface_trim_gain": 0.5, "error_integrals": False} == V1.task.__dict__


def test_v7_is_v5_with_goals_held_longer():
    assert V7.env_id == "SolarUAVAttitude-v7" and V7.trained_as_flown and V7.flight_stack == V5.flight_stack
    assert V7.task.goal_hold_s == (10.0, 30.0) and V5.task.goal_hold_s == (3.0, 10.0)
    assert {**V7.task.__dict__, "goal_hold_s": V5.task.goal_hold_s} == V5.task.__dict__


def test_v8_is_v5_trained_on_long_delays_and_slow_servos_too():
    assert V8.env_id == "SolarUAVAttitude-v8" and V8.trained_as_flown and V8.flight_stack == V5.flight_stack
    assert V8.task.core.delay_s == (0.040, 0.200) and V8.task.core.servo_rate_scale == (0.1, 1.0)
    assert replace(V8.task.core, delay_s=V5.task.core.delay_s, servo_rate_scale=(1.0, 1.0)) == V5.task.core
    assert {**V8.task.__dict__, "core": V5.task.core} == V5.task.__dict__


def test_v9_is_v7_on_the_lqi_tuned_with_stressed_flights():
    assert V9.env_id == "SolarUAVAttitude-v9" and V9.trained_as_flown and V9.task.residual_on == "lqi_stressed"
    assert V9.flight_stack == replace(V7.flight_stack, residual_on="lqi_stressed")
    assert replace(V9.task, residual_on=V7.task.residual_on) == V7.task


def test_v10_is_v7_with_a_twentieth_of_the_travel_as_its_correction():
    assert V10.env_id == "SolarUAVAttitude-v10" and V10.trained_as_flown and V10.task.residual_on == "lqi_tuned"
    assert V10.flight_stack == replace(V7.flight_stack, residual_authority=FINE_RESIDUAL_AUTHORITY)
    assert V10.task.residual_authority == FINE_RESIDUAL_AUTHORITY < RESIDUAL_AUTHORITY == V7.task.residual_authority
    assert replace(V10.task, residual_authority=V7.task.residual_authority) == V7.task


def test_versions_are_listed_by_id_and_an_unknown_one_is_refused_naming_it():
    assert list(VERSIONS) == ["SolarUAVAttitude-v0", "SolarUAVAttitude-v1", "SolarUAVAttitude-v2",
                              "SolarUAVAttitude-v3", "SolarUAVAttitude-v4", "SolarUAVAttitude-v5",
                              "SolarUAVAttitude-v6", "SolarUAVAttitude-v7",
                              "SolarUAVAttitude-v8", "SolarUAVAttitude-v9", "SolarUAVAttitude-v10"]
    assert all(isinstance(v, TaskVersion) and VERSIONS[v.env_id] is v for v in VERSIONS.values())
    assert task_version("SolarUAVAttitude-v1") is V1 and task_version("SolarUAVAttitude-v0") is V0
    with pytest.raises(ValueError, match="'SolarUAVAttitude-v99'") as err:
        task_version("SolarUAVAttitude-v99")
    assert "SolarUAVAttitude-v0" in str(err.value) and "SolarUAVAttitude-v1" in str(err.value)


@pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")
@pytest.mark.parametrize("version", [V0, V1, V2, V3], ids=lambda v: v.env_id)
def test_every_version_is_registered_with_gymnasium_on_import(version):
    candidate = list(VERSIONS).index(version.env_id) > list(VERSIONS).index(LATEST)
    gym_id = f"candidates/{version.env_id}" if candidate else version.env_id
    assert gym_id in gym.registry and jsbsim_env.ENV_ID in gym.registry
    env = gym.make(gym_id)
    assert env.unwrapped.task.config == version.task
    obs, _ = env.reset(seed=0)
    size = version.flight_stack.observation_size
    assert obs.shape == (size,) == env.observation_space.shape and obs.dtype == np.float32
    assert env.action_space.shape == (4,)
    obs, reward, terminated, truncated, info = env.step(np.zeros(4, np.float32))
    assert obs.shape == (size,) and np.isfinite(reward) and not (terminated or truncated) and "penalty_roll" in info
    jsbsim_env.task.gym_env.register()  # registering again changes nothing
    assert gym.spec(gym_id).kwargs["config"] == version.task


def test_the_default_version_is_the_newest_gymnasium_knows_by_its_name(recwarn):
    # Candidates after the default live in a namespace of their own: making the default does not
    # tell its user to "upgrade" to a candidate.
    assert [k for k in gym.registry if k.startswith("SolarUAVAttitude-")] == list(VERSIONS)[:list(VERSIONS).index(LATEST) + 1]
    gym.make(LATEST)
    assert not [w for w in recwarn if "out of date" in str(w.message)]

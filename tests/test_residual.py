"""The residual stage (``jsbsim_env.control.residual``): a network correcting an LQI, trained as flown."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from conftest import write_untrained_policy

from jsbsim_env.control.factory import make_controller
from jsbsim_env.control.lqi import LQIAttitudeController
from jsbsim_env.control.observation import RESIDUAL_NAMES, command_to_action, observation_size
from jsbsim_env.control.residual import ResidualStage, check_residual
from jsbsim_env.control.stack import StackSettings
from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
from jsbsim_env.task.versions import VERSIONS
from training.evaluation.suite import fly

RESIDUAL_VERSIONS = [v for v in VERSIONS.values() if v.flight_stack.residual_on]


def test_the_residual_versions_are_trained_as_flown_and_read_the_base_controller():
    assert {v.flight_stack.residual_on for v in RESIDUAL_VERSIONS} == {"lqi", "lqi_tuned", "lqi_robust", "lqi_stressed"}
    for version in RESIDUAL_VERSIONS:
        assert version.trained_as_flown
        assert version.task.observation_size == observation_size() + len(RESIDUAL_NAMES) == 28
        assert version.task.surface_trim_gain == 0.0 and not version.task.error_integrals


@pytest.mark.parametrize(("base", "authority", "words"), [
    ("pid", 0.25, "residual_on must be one of"), ("lqi", 0.0, "residual_authority must lie in"),
    ("lqi", 1.5, "residual_authority must lie in"), ("lqi", math.nan, "finite number"),
    ("", 0.25, "needs a residual_on"), ("lqi", True, "finite number")])
def test_a_residual_setting_out_of_range_is_refused_by_name(base, authority, words):
    with pytest.raises(ValueError, match=words):
        check_residual(base, authority)
    with pytest.raises(ValueError, match=words):
        TaskConfig(residual_on=base, residual_authority=authority)
    with pytest.raises(ValueError, match=words):
        StackSettings(residual_on=base, residual_authority=authority)


def test_a_zero_correction_flies_exactly_the_lqi_and_a_full_one_stays_within_its_authority():
    task = replace(VERSIONS["SolarUAVAttitude-v4"].task, external_throttle=0.0)
    residual, alone = AttitudeTaskBatch(1, task), AttitudeTaskBatch(1, replace(task, residual_on="",
                                                                                 residual_authority=0.0))
    lqi = LQIAttitudeController()
    residual.reset_one(0, 5)
    alone.reset_one(0, 5)
    for _ in range(300):
        command = lqi.update(alone.cores[0].setup.control_interval_s, alone.measurements()[0], alone.goals[0])
        alone.step(np.clip(command_to_action(command, alone.action_scale), -1.0, 1.0)[None])
        residual.step(np.zeros((1, 4)))
    np.testing.assert_allclose(residual.states, alone.states, rtol=0.0, atol=1e-9)

    stage = ResidualStage("lqi", 0.25)
    stage.observe(0.05, residual.measurements()[0].tolist(), [0.0, 0.0, 10.0])
    base = np.array(stage.base_command)
    for action in ([1.0, 1.0, 1.0, 1.0], [-1.0, -1.0, -1.0, -1.0]):
        command = np.array(stage.command(action))
        reach = 0.25 * np.array([30.0, 30.0, 20.0, 0.5])
        assert np.all(np.abs(command - base) <= reach + 1e-9)
        assert np.all(command >= [-30.0, -30.0, -20.0, 0.0]) and np.all(command <= [30.0, 30.0, 20.0, 1.0])
        assert stage.controller.last_command == list(command)  # the base holds what reached the actuators


def test_an_untrained_residual_policy_flies_its_lqi_through_the_runtime(tmp_path):
    # The trainer starts a residual's network at zero, so before any training its policy file,
    # flown by the runtime through its control stack, is its base controller step for step.
    path = write_untrained_policy(tmp_path / "residual.pt", task="SolarUAVAttitude-v4")
    policy = make_controller("policy", policy=path, backend="torch")
    assert policy.stack.residual is not None and policy.stack.residual.base_name == "lqi"
    config = TaskConfig(core=CoreConfig.ideal(perturb_attitude_deg=2.0, perturb_rate_degps=1.0))
    flights = []
    for controller in (policy, LQIAttitudeController()):
        recorder, end = fly(controller, AttitudeTaskBatch(1, config), seed=3, steps=200,
                            goal_fn=lambda t: np.array([math.radians(3.0) if t > 2.0 else 0.0, 0.0, 10.0]))
        assert not end["terminated"]
        flights.append(recorder.arrays()["true_state"])
    np.testing.assert_allclose(flights[0], flights[1], rtol=0.0, atol=1e-6)

"""The controller shipped in the package: where it came from, and one disturbed episode."""

from __future__ import annotations

import json
import math

import numpy as np

from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.control.policy import PolicyRuntime, load_policy, onnx_source_digest, policy_digest, shipped_policy_path
from jsbsim_env.control.stack import StackSettings
from jsbsim_env.sim.core import CoreConfig, FlightCore
from jsbsim_env.task.attitude import EAS_INDEX, AttitudeTaskBatch, TaskConfig
from training.evaluation.suite import EVAL_EPISODE_SEED, fly

RANDOM_ACTIONS_RETURN = 0.13  # normalised return of uniformly random actions on these episodes


def test_shipped_record_names_command_seed_and_commit():
    path = shipped_policy_path()
    record = json.loads(path.with_suffix(".json").read_text())
    _, meta = load_policy(path)
    assert record["seed"] == meta["seed"] and record["frames"] == meta["frames"]
    assert record["command"].startswith("python scripts/train_torchrl.py") and len(record["commit"]) == 40
    assert all(s["frames_at_start"] < meta["frames"] for s in record["sessions"])
    assert record["evaluation"]["episodes"]["count"] >= 50
    assert onnx_source_digest(path.with_suffix(".onnx")) == policy_digest(path)  # the export of this very file
    assert len(record["aircraft_model"]) == 64  # the fingerprint of the aircraft model it was trained on


def test_shipped_policy_loads_with_its_control_stack():
    """The shipped file (written before the ``stack`` entry, with flat settings) loads with the stack
    it flies with, the task version SolarUAVAttitude-v1's."""
    from jsbsim_env.task.versions import V1

    path = shipped_policy_path()
    _, meta = load_policy(path)
    assert meta["stack"] == StackSettings(8, 20.0, 2.0) == V1.flight_stack
    runtime = PolicyRuntime()
    assert runtime.stack.settings == meta["stack"] and runtime.window == 8 and runtime.observation_size == 20


def test_shipped_policy_flies_a_disturbed_episode_without_early_end():
    """A training-style episode (delay, noise, random interval, randomised coefficients,
    turbulence) that the evaluation suite does not use."""
    batch = AttitudeTaskBatch(1, TaskConfig())
    steps = 300
    _, end = fly(PolicyRuntime(), batch, seed=EVAL_EPISODE_SEED - 1, steps=steps)
    assert end["steps"] == steps and not end["terminated"], end
    assert end["return"] / steps > 2 * RANDOM_ACTIONS_RETURN


def pitch_errors_in_a_dive_for_speed(controller, pitch_cmd_deg: float = -10.0, duration_s: float = 20.0):
    """Calm air at 10 km from trimmed flight at 8 m/s EAS, as a route leaves the aircraft after a gust:
    TECS asks for ``pitch_cmd_deg`` to regain the route's 10 m/s and flies the throttle (held at 0.35
    here), and the attitude controller gets its measured EAS as demand
    (``RouteConfig.attitude_eas_demand``). Returns the pitch error (deg) at each control step from
    2 s after the demand until the aircraft is back at 10 m/s, when TECS would ease it."""
    dt_s = 0.04
    core = FlightCore(CoreConfig.ideal(control_interval_s=(dt_s, dt_s), delay_s=(dt_s, dt_s)))
    measurement = core.reset(0, altitude_m=10_000.0, airspeed_eas_mps=8.0)
    errors = []
    for k in range(int(duration_s / dt_s)):
        demand = np.array([0.0, math.radians(pitch_cmd_deg), measurement[EAS_INDEX]])
        command = np.array(controller.update(dt_s, np.asarray(measurement), demand), dtype=float)
        command[3] = 0.35
        measurement = core.step(command)
        if core.last_true_state[EAS_INDEX] >= 10.0:
            break
        if k * dt_s >= 2.0:
            errors.append(math.degrees(core.last_true_state[2]) - pitch_cmd_deg)
    return np.array(errors)


def test_shipped_policy_follows_a_dive_demand_when_tecs_flies_the_speed():
    """Given its measured EAS as demand, a policy trained only to hold the airspeed goal with its own
    throttle keeps the pitch that holds its speed: one such policy held +2 deg for minutes against
    TECS's -10 deg on the turbulent leg. The shipped one must follow, as the PID does."""
    for controller in (PIDAttitudeController(), PolicyRuntime()):
        errors = np.abs(pitch_errors_in_a_dive_for_speed(controller))
        assert errors.size > 0 and errors.mean() < 1.5, (type(controller).__name__, errors.size, errors.mean())

"""Bad input to the controller runtime and the environments gets one clear error naming the
problem, before anything moves: one test per case of docs/reliability.md's table for the runtime
and the environments (the training cases are in ``test_reliability_training.py``, the scripts' in
``test_reliability_scripts.py``)."""

from __future__ import annotations

import math
import shutil
from dataclasses import replace

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from jsbsim_env.control.checked_io import atomic_save, checked_load
from jsbsim_env.control.observation import OBS_SIZE, ActionError
from jsbsim_env.control.policy import PolicyFileError, PolicyRuntime, load_policy, shipped_policy_path
from jsbsim_env.sim.core import CoreConfig, FlightCore
from jsbsim_env.task.attitude import AttitudeTask, AttitudeTaskBatch, TaskConfig
from jsbsim_env.task.gym_env import SolarUAVAttitudeGymEnv
from jsbsim_env.task.torchrl_env import SolarUAVAttitudeEnv, make_env

LEVEL = np.array([10000.0, 0.0, 0.02, 0, 0, 0, 10.0, 0.02, 0, 0, -0.05, 0, 0.5])  # core.STATE_NAMES
GOAL = np.array([0.0, 0.02, 10.0])  # roll, pitch rad; EAS m/s


@pytest.fixture(scope="module")
def shipped_copy(tmp_path_factory):
    """The shipped policy file and its ONNX export, copied to a folder of their own."""
    folder = tmp_path_factory.mktemp("shipped")
    policy = folder / "policy.pt"
    shutil.copyfile(shipped_policy_path(), policy)
    shutil.copyfile(shipped_policy_path().with_suffix(".onnx"), folder / "policy.onnx")
    return policy


@pytest.fixture(scope="module")
def runtimes():
    return {backend: PolicyRuntime(backend=backend) for backend in ("onnx", "torch")}


@pytest.fixture(scope="module")
def gym_env():
    return SolarUAVAttitudeGymEnv(TaskConfig(core=CoreConfig.ideal()))


# ----------------------------------------------------------------------------- the runtime's inputs

@pytest.mark.parametrize(("measurement", "goal", "named"), [
    (np.append(LEVEL, 1.0), GOAL, r"measurement must have shape \(13,\).*got \(14,\)"),  # a zip truncated it
    (LEVEL[:12], GOAL, r"measurement must have shape \(13,\).*got \(12,\)"),  # was an IndexError
    (LEVEL[None], GOAL, r"measurement must have shape \(13,\).*got \(1, 13\)"),
    (LEVEL, GOAL[:2], r"goal must have shape \(3,\).*got \(2,\)"),
    (LEVEL, np.append(GOAL, 0.0), r"goal must have shape \(3,\).*got \(4,\)"),
    (LEVEL, GOAL[:, None], r"goal must have shape \(3,\).*got \(3, 1\)"),
])
@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_act_refuses_a_measurement_or_goal_of_the_wrong_shape_by_name(runtimes, backend, measurement, goal, named):
    runtime = runtimes[backend]
    runtime.reset()
    with pytest.raises(ValueError, match=named):
        runtime.act(measurement, goal, 0.04)
    assert runtime.stack.last_action is None  # refused before any stage moved


def test_a_refused_control_interval_on_the_first_step_leaves_nothing_behind(runtimes):
    runtime = runtimes["torch"]
    runtime.reset()
    fresh = runtime.act(LEVEL, GOAL, 0.04)
    for bad in (float("nan"), 0.0, -0.04, float("inf")):
        runtime.reset()
        with pytest.raises(ValueError, match="control interval dt_s = .* s is outside"):
            runtime.act(LEVEL, GOAL, bad)
        np.testing.assert_array_equal(runtime.act(LEVEL, GOAL, 0.04), fresh)  # as if the refused call never was


@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_act_scaled_refuses_a_non_finite_observation_on_either_backend(runtimes, backend):
    runtime = runtimes[backend]
    runtime.reset()
    for bad in (math.nan, math.inf):
        observation = np.zeros(OBS_SIZE)
        observation[3] = bad
        with pytest.raises(ValueError, match="observation .* is not finite"):  # onnxruntime gave a finite action
            runtime.act_scaled(observation)
    with pytest.raises(ValueError, match=r"observation must have shape \(20,\), got \(21,\)"):
        runtime.act_scaled(np.zeros(OBS_SIZE + 1))


@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_the_bare_network_call_refuses_a_window_of_another_shape_or_not_finite(runtimes, backend):
    runtime = runtimes[backend]
    with pytest.raises(ValueError, match=r"window must have shape \(8, 20\).*got \(4, 20\)"):  # torch read it
        runtime.action(np.zeros((4, OBS_SIZE)))
    window = np.zeros((8, OBS_SIZE))
    window[0, 0] = math.nan
    with pytest.raises(ValueError, match="window is not finite"):
        runtime.action(window)


# ----------------------------------------------------------------------------- the ONNX export beside a policy

def _actions_agree(path, window):
    onnx, torch_ = PolicyRuntime(path, backend="onnx"), PolicyRuntime(path, backend="torch")
    np.testing.assert_allclose(onnx.action(window), torch_.action(window), atol=1e-5)


@pytest.mark.parametrize("damage", ["truncated", "empty", "garbage"])
def test_an_unreadable_onnx_export_beside_a_policy_is_exported_afresh_elsewhere(shipped_copy, tmp_path, damage):
    policy = tmp_path / "policy.pt"
    shutil.copyfile(shipped_copy, policy)
    export = shipped_copy.with_suffix(".onnx").read_bytes()
    broken = {"truncated": export[:len(export) // 2], "empty": b"", "garbage": b"\xff" * 1000}[damage]
    policy.with_suffix(".onnx").write_bytes(broken)
    window = np.random.default_rng(2).normal(size=(8, OBS_SIZE)).astype(np.float32)
    _actions_agree(policy, window)  # was a protobuf DecodeError
    assert policy.with_suffix(".onnx").read_bytes() == broken  # the user's file is left as it was
    assert sorted(p.name for p in tmp_path.iterdir()) == ["policy.onnx", "policy.pt"]


def test_an_onnx_export_whose_weights_changed_after_it_was_written_is_not_used(shipped_copy, tmp_path):
    import onnx

    policy = tmp_path / "policy.pt"
    shutil.copyfile(shipped_copy, policy)
    model = onnx.load(str(shipped_copy.with_suffix(".onnx")))  # its digest still names the policy file
    bias = next(t for t in model.graph.initializer if t.name.endswith("head.4.bias"))  # the output layer's
    values = np.frombuffer(bias.raw_data, dtype=np.float32).copy()
    values[0] = -values[0] - 0.5  # a flipped sign bit, in a copy or on disk
    bias.raw_data = values.tobytes()
    onnx.save(model, str(policy.with_suffix(".onnx")))
    _actions_agree(policy, np.random.default_rng(3).normal(size=(8, OBS_SIZE)).astype(np.float32))


# ----------------------------------------------------------------------------- what is given as a policy file

def test_a_training_checkpoint_given_as_a_policy_is_named_as_one(tmp_path):
    checkpoint = tmp_path / "checkpoint.pt"  # training.checkpoint.save_checkpoint's keys
    atomic_save({"format_version": 1, "fingerprint": "abc", "config": {}, "sac": {"w": torch.zeros(2)},
                 "optimizer": {}, "buffer": {}, "counters": {}}, checkpoint)
    with pytest.raises(PolicyFileError,
                       match=f"^{checkpoint} is a training checkpoint, not a policy file: give the run's best_policy.pt"):
        PolicyRuntime(checkpoint)


@pytest.mark.parametrize(("obj", "said"), [(torch.zeros(3), r"a tensor of shape \(3,\)"),
                                           ({"weight": torch.zeros(2)}, "a dict with keys weight"),
                                           ([1, 2], "a list of 2 items")])
def test_another_torch_file_given_as_a_policy_says_what_it_holds(tmp_path, obj, said):
    path = tmp_path / "other.pt"
    torch.save(obj, path)
    with pytest.raises(PolicyFileError, match=f"{path} is not a policy file of this package .*it holds {said}"):
        load_policy(path)


def test_an_onnx_export_given_as_the_policy_file_is_named_as_one(shipped_copy):
    onnx_path = shipped_copy.with_suffix(".onnx")
    with pytest.raises(PolicyFileError, match=f"^{onnx_path} is an ONNX export, not a policy file"):
        PolicyRuntime(onnx_path)


def test_a_policy_file_whose_network_does_not_fit_its_weights_is_refused_in_one_line(shipped_copy, tmp_path):
    data = checked_load(shipped_copy)
    data["network"] = {**data["network"], "lstm_hidden": data["network"]["lstm_hidden"] + 1}
    atomic_save(data, tmp_path / "policy.pt")
    with pytest.raises(PolicyFileError, match="is not a usable policy file: .*size mismatch") as err:
        load_policy(tmp_path / "policy.pt")
    assert "\n" not in str(err.value)


# ----------------------------------------------------------------------------- episode starts

@pytest.mark.parametrize(("options", "named"), [
    ({"altitude_m": 25000}, r"altitude_m 25000 m is outside where an episode can start: -82.5..20000 m"),
    ({"altitude_m": -90}, r"altitude_m -90 m is outside .*-82.5..20000 m"),  # flown before
    ({"altitude_m": math.nan}, r"altitude_m nan m is outside"),  # "cannot convert float NaN to integer"
    ({"airspeed_eas_mps": 40}, r"airspeed_eas_mps 40 m/s is outside where an episode can start: 8..12 m/s"),
    ({"airspeed_eas_mps": 3}, r"airspeed_eas_mps 3 m/s is outside .*8..12 m/s"),  # "math domain error"
    ({"airspeed_eas_mps": 0}, r"airspeed_eas_mps 0 m/s is outside .*8..12 m/s"),  # a wind, it said
    ({"airspeed_eas_mps": "fast"}, r"airspeed_eas_mps must be a number, got 'fast'"),
    ({"heading_deg": math.nan}, r"heading_deg must be a finite number"),  # a wind, it said
    ({"altitude": 1000.0}, r"unknown episode-start option\(s\) 'altitude': use altitude_m, airspeed_eas_mps"),
])
def test_an_episode_start_outside_the_envelope_is_refused_with_the_limits(gym_env, options, named):
    with pytest.raises(ValueError, match=named):
        gym_env.reset(seed=0, options=options)


def test_every_caller_of_the_flight_core_gets_the_same_refusal():
    core = FlightCore(CoreConfig.ideal())
    with pytest.raises(ValueError, match="altitude_m 25000 m is outside"):
        core.reset(0, altitude_m=25000.0)
    assert core.setup is None  # nothing started
    batch = AttitudeTaskBatch(1, TaskConfig(core=CoreConfig.ideal()))
    with pytest.raises(ValueError, match="airspeed_eas_mps 40 m/s is outside"):
        batch.reset_one(0, 0, airspeed_eas_mps=40.0)
    # A route (jsbsim_env.missions) starts where its configuration says.
    from jsbsim_env.missions import RouteConfig, RouteFlight

    with pytest.raises(ValueError, match="altitude_m 25000 m is outside"):
        RouteFlight(RouteConfig(altitude_m=25000.0, duration_s=10.0))
    with pytest.raises(ValueError, match="airspeed_eas_mps 3 m/s is outside"):
        RouteFlight(RouteConfig(eas_mps=3.0, duration_s=10.0))
    # A sweep's condition or a task with a start range the aircraft cannot start in: refused when built.
    from training.evaluation.sweep import condition_config

    with pytest.raises(ValueError, match="CoreConfig.eas_range_mps 40 m/s is outside where an episode can start"):
        AttitudeTaskBatch(1, condition_config({"eas_mps": 40.0}))
    for name, bad in (("altitude_range_m", (25000.0, 25000.0)), ("eas_range_mps", (3.0, 3.0))):
        with pytest.raises(ValueError, match=f"CoreConfig.{name} .* is outside where an episode can start"):
            FlightCore(replace(CoreConfig.ideal(), **{name: bad}))


def test_an_aircraft_index_outside_the_batch_is_refused_and_a_trim_lookup_of_nan_is_a_trim_error():
    from jsbsim_env.sim.simulation import TrimError
    from jsbsim_env.sim.trim_table import TrimTable

    batch = AttitudeTaskBatch(2, TaskConfig(core=CoreConfig.ideal()))
    for bad in (2, -1, 0.0):  # -1 reset the last aircraft under another name
        with pytest.raises(IndexError, match=r"aircraft index must be a whole number in 0..1"):
            batch.reset_one(bad, 0)
    with pytest.raises(TrimError, match="must be finite"):  # "cannot convert float NaN to integer"
        TrimTable.shared().lookup(math.nan, 10.0)


@pytest.mark.parametrize(("settings", "named"), [
    ({"eas_range_mps": (12.0, 8.0)}, "eas_range_mps must be a finite range"),
    ({"altitude_range_m": (math.nan, 1000.0)}, "altitude_range_m must be a finite range"),
    ({"perturb_attitude_deg": math.nan}, "perturb_attitude_deg must be finite"),
    ({"perturb_eas_mps": -1.0}, "perturb_eas_mps must be finite and >= 0"),
    ({"backlash_deg": math.inf}, "backlash_deg must be finite"),
    ({"sim_rate_hz": 0.0}, "sim_rate_hz must be positive"),
    ({"max_steps": 0}, "max_steps must be a whole number >= 1"),
    ({"parameters": "heavy"}, "unknown parameter set 'heavy'"),
])
def test_core_settings_that_would_fly_wrongly_are_refused_by_name(settings, named):
    with pytest.raises(ValueError, match=named):
        CoreConfig(**settings)


def test_a_goal_hold_that_is_not_a_positive_range_is_refused():
    for bad in ((math.nan, 5.0), (5.0, 3.0), (0.0, 1.0), (1.0, math.inf)):
        with pytest.raises(ValueError, match="goal_hold_s must be a finite range"):
            TaskConfig(goal_hold_s=bad)


def test_a_scripted_goal_that_is_not_three_finite_values_is_refused(gym_env):
    gym_env.reset(seed=0)
    batch = gym_env.task.batch
    for bad in ([0.0, math.nan, 10.0], [0.0, 0.0], 10.0):
        with pytest.raises(ValueError, match="goal must be 3 finite values"):  # NaN rewards before
            batch.set_goal(0, bad)
    assert np.all(np.isfinite(batch.goals[0]))


# ----------------------------------------------------------------------------- environments

@pytest.mark.parametrize(("build", "named"), [
    (lambda: make_env(0), "num_envs must be a whole number of aircraft >= 1, got 0"),
    (lambda: make_env(1, window=0), r"window must be a whole number of steps in \[1, 64\], got 0"),
    (lambda: SolarUAVAttitudeEnv(0), "num_envs must be a whole number of aircraft >= 1, got 0"),
    (lambda: SolarUAVAttitudeEnv(2.5), "num_envs must be a whole number of aircraft >= 1, got 2.5"),
    (lambda: AttitudeTaskBatch(0), "num_envs must be a whole number of aircraft >= 1, got 0"),
])
def test_an_environment_of_no_aircraft_or_no_window_is_refused_by_name(build, named):
    with pytest.raises(ValueError, match=named):
        build()


def test_a_torchrl_step_without_an_action_names_the_missing_key():
    env = SolarUAVAttitudeEnv(2, TaskConfig(core=CoreConfig.ideal()))
    with pytest.raises(RuntimeError, match=r"aircraft \[0, 1\] have no episode yet: call reset\(\) before step\(\)"):
        env.step(TensorDict({"action": torch.zeros(2, 4)}, batch_size=[2]))
    env.reset()
    with pytest.raises(ActionError, match="has no 'action' entry .*its keys: \\['actions'\\]"):
        env.step(TensorDict({"actions": torch.zeros(2, 4)}, batch_size=[2]))


def test_a_step_before_reset_says_to_reset_first():
    env = SolarUAVAttitudeGymEnv(TaskConfig(core=CoreConfig.ideal()))  # unwrapped: no OrderEnforcing
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        env.step(np.zeros(4, dtype=np.float32))
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        AttitudeTask(TaskConfig(core=CoreConfig.ideal())).step(np.zeros(4))
    core = FlightCore(CoreConfig.ideal())
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        core.step(np.array([0.0, 0.0, 0.0, 0.5]))


def test_act_refuses_a_finite_measurement_too_large_for_the_network():
    """1e39 is a finite float64, but infinite in the network's float32 window: refused, not flown."""
    runtime = PolicyRuntime(backend="torch")
    for index in (1, 6):  # roll, EAS
        huge = np.array(LEVEL, dtype=float)
        huge[index] = 1e39
        with pytest.raises(ValueError, match="is outside what solar_uav in flight can give"):
            runtime.act(huge, GOAL, 0.04)


# ----------------------------------------------------------------------------- inputs no aircraft could give

_DEG = math.pi / 180.0


def _with(values, index, value):
    out = np.array(values, dtype=float)
    out[index] = value
    return out


@pytest.mark.parametrize(("measurement", "goal", "named"), [
    (LEVEL, np.array([3.0, 1.15, 10.0]), r"goal roll = 3 rad \(171.9 deg\) is outside .* to 0.174533 rad"),  # degrees
    (LEVEL, np.array([0.0, 1.15, 10.0]), r"goal pitch = 1.15 rad .* is outside"),
    (LEVEL, np.array([0.0, 0.0, -10.0]), r"goal EAS = -10 m/s is outside .* \(-1 m/s to 36 m/s"),
    (LEVEL, np.array([0.0, 0.0, 1000.0]), r"goal EAS = 1000 m/s is outside"),
    (_with(LEVEL, 0, 10000.0 / 0.3048), GOAL, r"measurement altitude_m = 32808.4 m is outside .* to 25000 m"),  # feet
    (_with(LEVEL, 1, 200.0), GOAL, r"measurement roll_rad = 200 rad .* is outside .* to 3.14159 rad"),  # degrees
    (_with(LEVEL, 2, 30.0), GOAL, r"measurement pitch_rad = 30 rad .* to 1.5708 rad"),
    (_with(LEVEL, 3, 90.0), GOAL, r"measurement p_radps = 90 rad/s .* to 6.28319 rad/s"),  # deg/s
    (_with(LEVEL, 6, 100.0), GOAL, r"measurement airspeed_eas_mps = 100 m/s .* to 36 m/s"),
    (_with(LEVEL, 10, 5.0), GOAL, r"measurement elevator_rad = 5 rad .* to 0.654498 rad"),  # degrees
    (_with(LEVEL, 12, 50.0), GOAL, r"measurement throttle = 50 0..1 .* to 1.25 0..1"),  # percent
    (LEVEL.astype(complex), GOAL, r"measurement must hold real numbers, got complex128"),
    (LEVEL, GOAL + 0j, r"goal must hold real numbers"),
    (LEVEL.astype(str), GOAL, r"measurement must hold real numbers"),
])
@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_act_refuses_goals_and_measurements_no_aircraft_could_give_by_value_unit_and_limit(
        runtimes, backend, measurement, goal, named):
    runtime = runtimes[backend]
    runtime.reset()
    with pytest.raises(ValueError, match=named):
        runtime.act(measurement, goal, 0.04)
    assert runtime.stack.last_action is None  # refused before any stage moved


@pytest.mark.parametrize(("dt_s", "named"), [
    (40, r"dt_s = 40 s is outside the 0.02 to 0.12 s"),  # milliseconds
    (0.001, r"dt_s = 0.001 s is outside"),
    (True, r"dt_s must be a real number of seconds, got True \(bool\)"),
    ("0.04", r"dt_s must be a real number of seconds, got '0.04' \(str\)"),
    (0.04 + 0j, r"dt_s must be a real number of seconds"),
])
def test_act_refuses_an_interval_no_task_flies_at(runtimes, dt_s, named):
    runtime = runtimes["torch"]
    runtime.reset()
    fresh = runtime.act(LEVEL, GOAL, 0.04)
    runtime.reset()
    with pytest.raises(ValueError, match=named):
        runtime.act(LEVEL, GOAL, dt_s)
    np.testing.assert_array_equal(runtime.act(LEVEL, GOAL, np.float32(0.04)), fresh.astype(float))


def test_act_flies_the_edges_of_what_the_task_asks(runtimes):
    runtime = runtimes["torch"]
    # The last: a speed-free route gives the measured EAS as the goal, in a dive beyond any goal drawn.
    for goal in ([10 * _DEG, 20 * _DEG, 6.0], [-10 * _DEG, -20 * _DEG, 14.0], [0.0, 0.0, 20.0]):
        runtime.reset()
        assert runtime.act(LEVEL, np.array(goal), 0.04).shape == (4,)
    noisy = LEVEL.copy()
    noisy[12] = 1.0 + 3e-3  # a throttle at its stop, measured with its sensor noise
    runtime.reset()
    assert runtime.act(noisy, GOAL, 0.04).shape == (4,)
    tumbling = np.array([-4000.0, math.pi, -math.pi / 2, 6, -6, 6, 0.0, -math.pi, math.pi, 0.6, -0.6, 0.4, 1.0])
    runtime.reset()
    assert runtime.act(tumbling, GOAL, 0.12).shape == (4,)

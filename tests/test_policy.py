"""The deployed controller: loading, ONNX export against PyTorch, the runtime's window and mapping."""

from __future__ import annotations

import re

import numpy as np
import pytest
import torch

from jsbsim_env.control.goal_trim import GoalTrim
from jsbsim_env.task.attitude import (
    OBS_OFFSET,
    OBS_SCALE,
    OBS_SIZE,
    TRIM_SCALE_DEG,
    ActionError,
    AttitudeTask,
    TaskConfig,
    action_to_command,
)
from training.checkpoint import atomic_save, checked_load
from training.config import TrainConfig
from jsbsim_env.control.policy import (
    PolicyFileError,
    PolicyRuntime,
    export_onnx,
    load_policy,
    policy_digest,
    set_goal_trim,
    set_integral_trim,
)
from training.trainer import Trainer


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory):
    """A policy file written by the trainer from freshly initialised networks."""
    run = tmp_path_factory.mktemp("run")
    c = TrainConfig(seed=1)
    c.env.num_envs = 1
    c.buffer.capacity = 10
    c.log.progress = False
    trainer = Trainer(c, run)
    path = run / "policy.pt"
    trainer.save_policy(path, {"return_norm": 0.0})
    return path, trainer


def test_loaded_policy_is_the_trainers_deterministic_actor(policy_file):
    path, trainer = policy_file
    actor, meta = load_policy(path)
    assert meta["window"] == 8 and meta["seed"] == 1
    window = torch.randn(5, 8, OBS_SIZE)
    loc, _ = trainer.actor.module[0].module(window)
    torch.testing.assert_close(actor(window), torch.tanh(loc))


def test_onnx_export_gives_the_pytorch_actions(policy_file, tmp_path):
    path, _ = policy_file
    actor, _ = load_policy(path)
    onnx_path = export_onnx(actor, tmp_path / "policy.onnx")
    import onnxruntime as ort

    session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    for _ in range(20):
        window = rng.normal(size=(1, 8, OBS_SIZE)).astype(np.float32)
        expected = actor(torch.from_numpy(window)).detach().numpy()
        np.testing.assert_allclose(session.run(None, {"window": window})[0], expected, atol=1e-5)


def test_runtime_window_matches_catframes_and_backends_agree(policy_file, tmp_path):
    path, _ = policy_file
    runtime_onnx = PolicyRuntime(path, backend="onnx")
    runtime_torch = PolicyRuntime(path, backend="torch")
    obs = [np.full(OBS_SIZE, float(k), np.float32) for k in range(10)]
    w = runtime_onnx.push(obs[0])
    assert np.all(w == 0.0) and w.shape == (8, OBS_SIZE)  # a new episode repeats its first observation
    for k in range(1, 10):
        w = runtime_onnx.push(obs[k])
    np.testing.assert_array_equal(w[:, 0], np.arange(2, 10))  # oldest first
    runtime_onnx.reset()
    for k in range(10):
        a, b = runtime_onnx.act_scaled(obs[k]), runtime_torch.act_scaled(obs[k])
        np.testing.assert_allclose(a, b, atol=1e-5)
    command = runtime_torch.act(np.zeros(13), np.array([0.0, 0.0, 10.0]), 0.04)
    assert command.shape == (4,) and -30 <= command[0] <= 30 and 0 <= command[3] <= 1
    runtime_torch.reset()
    a = runtime_torch.action(runtime_torch.push(np.zeros(OBS_SIZE)))
    runtime_torch.reset()
    np.testing.assert_allclose(runtime_torch.act(np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5]),
                                                 np.array([0.0, 0.0, 10.0]), 0.04),
                               action_to_command(a), atol=1e-6)  # the integral trims start at zero


@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_a_nan_measurement_is_a_clear_error_not_a_command(policy_file, backend):
    path, _ = policy_file
    runtime = PolicyRuntime(path, backend=backend)
    measurement = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5])
    runtime.act(measurement, np.array([0.0, 0.0, 10.0]), 0.04)
    for index in (1, 6, 10):  # onnxruntime's LSTM turns a NaN input into finite actions: refused before it
        bad = measurement.copy()
        bad[index] = np.nan
        with pytest.raises(ValueError, match="measurement .* is not finite"):
            runtime.act(bad, np.array([0.0, 0.0, 10.0]), 0.04)
    with pytest.raises(ValueError, match="measurement .* is not finite"):
        runtime.act(measurement, np.array([0.0, np.inf, 10.0]), 0.04)
    for dt_s in (float("nan"), 0.0, -0.04):  # a NaN interval would stay in the trims for good
        with pytest.raises(ValueError, match="control interval must be positive"):
            runtime.act(measurement, np.array([0.0, 0.0, 10.0]), dt_s)
    runtime.actor.net.encoder.lstm.weight_ih_l0.data[:] = np.nan  # a network that gives NaN: not a command
    runtime.backend = "torch"
    with pytest.raises(ActionError, match="not finite"):
        runtime.act(measurement, np.array([0.0, 0.0, 10.0]), 0.04)
    assert runtime._last_action is None and runtime._trim.trim_deg == [0.0, 0.0]  # reset: the next call starts afresh


def test_the_runtimes_goal_trim_is_goal_trim_around_the_policy(tmp_path):
    """A policy file with ``goal_trim_s`` flies as ``GoalTrim`` around the same policy without it."""
    c = TrainConfig(seed=3)
    c.env.num_envs, c.buffer.capacity, c.log.progress = 1, 10, False
    trainer = Trainer(c, tmp_path / "run")
    with_goal_trim, without = tmp_path / "with.pt", tmp_path / "without.pt"
    trainer.save_policy(with_goal_trim, {"return_norm": 0.0})
    c.env.goal_trim_s = 0.0
    trainer.save_policy(without, {"return_norm": 0.0})
    runtime = PolicyRuntime(with_goal_trim, backend="torch")
    wrapped = GoalTrim(PolicyRuntime(without, backend="torch"), TrainConfig().env.goal_trim_s)
    assert runtime.meta["goal_trim_s"] == 20.0 and load_policy(without)[1]["goal_trim_s"] == 0.0
    rng = np.random.default_rng(0)
    base = np.array([5000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5])
    goal = np.array([0.004, -0.003, 10.0])  # a fraction of a degree off: the goal trim integrates
    for _ in range(30):
        measurement = base + rng.normal(size=13) * 1e-3
        np.testing.assert_array_equal(runtime.act(measurement, goal, 0.04), wrapped.update(0.04, measurement, goal))
    assert np.abs(wrapped.offset_deg).min() > 0.0
    with pytest.raises(ValueError, match="control interval"):
        runtime.act(base, goal)


def test_set_goal_trim_rewrites_only_that_setting(policy_file, tmp_path):
    path, _ = policy_file
    copy = tmp_path / "policy.pt"
    copy.write_bytes(path.read_bytes())
    set_goal_trim(copy, 8.0)
    before, after = checked_load(path), checked_load(copy)
    assert load_policy(copy)[1]["goal_trim_s"] == 8.0
    assert {k for k in before if k != "actor" and before[k] != after[k]} == {"goal_trim_s"}
    digest = policy_digest(copy)
    with pytest.raises(ValueError, match="goal trim time constant"):
        set_goal_trim(copy, 0.01)
    assert policy_digest(copy) == digest  # a refused setting leaves the file as it was


def test_set_integral_trim_changes_only_the_trim_gains_of_a_policy_trained_with_hidden_trims(policy_file, tmp_path):
    path, _ = policy_file
    copy = tmp_path / "policy.pt"
    copy.write_bytes(path.read_bytes())
    # The trainer writes the flight trim gains (env.flight_integral_trim, 2 by default), not training's 0.5.
    assert load_policy(path)[1]["integral_trim"] == 2.0 and not load_policy(path)[1]["observe_trims"]
    set_integral_trim(copy, 1.0)
    before, after = checked_load(path), checked_load(copy)
    assert {k for k in before if k != "actor" and before[k] != after[k]} == {"integral_trim"}
    assert PolicyRuntime(copy, backend="torch")._trim.fraction == 1.0
    digest = policy_digest(copy)
    for bad in (0.0, -1.0, float("nan"), 2.5):
        with pytest.raises(ValueError, match="integral_trim"):
            set_integral_trim(copy, bad)
    untrimmed = tmp_path / "untrimmed.pt"
    atomic_save({**before, "integral_trim": 0.0}, untrimmed)
    with pytest.raises(ValueError, match="hidden integral trims"):
        set_integral_trim(untrimmed, 1.0)
    assert policy_digest(copy) == digest  # a refused setting leaves the file as it was


def test_the_trainer_writes_the_flight_trim_and_refuses_one_its_policy_cannot_fly(tmp_path):
    c = TrainConfig(seed=1)
    c.env.num_envs, c.buffer.capacity, c.log.progress = 1, 10, False
    c.env.flight_integral_trim = 1.5
    trainer = Trainer(c, tmp_path / "run")
    assert trainer.task_config.integral_trim == 0.5 == trainer.eval_task_config.integral_trim  # training keeps its own
    trainer.save_policy(tmp_path / "policy.pt", {"return_norm": 0.0})
    assert load_policy(tmp_path / "policy.pt")[1]["integral_trim"] == 1.5 == c.env.flown_integral_trim
    c.env.flight_integral_trim = 0.0  # 0: the training gains in flight too
    Trainer(c, tmp_path / "run0").save_policy(tmp_path / "policy0.pt", {"return_norm": 0.0})
    assert load_policy(tmp_path / "policy0.pt")[1]["integral_trim"] == 0.5 == c.env.flown_integral_trim
    refused = (({"integral_trim": 0.0}, "hidden integral trims"), ({"observe_trims": True}, "hidden integral trims"),
               ({"flight_integral_trim": 2.5}, r"\[0, 2\]"), ({"flight_integral_trim": float("nan")}, "must be > 0"))
    for i, (settings, problem) in enumerate(refused):
        bad = TrainConfig.from_dict(c.to_dict())
        bad.env.flight_integral_trim = 2.0
        for key, value in settings.items():
            setattr(bad.env, key, value)
        with pytest.raises(ValueError, match="env.flight_integral_trim") as err:
            Trainer(bad, tmp_path / f"bad{i}")
        assert re.search(problem, str(err.value)), str(err.value)
    assert TrainConfig.preset("paper").env.flight_integral_trim == 0.0


@pytest.mark.parametrize(("settings", "problem"), [({"integral_trim": 0.5, "observe_trims": True, "rudder_trim_s": 4.0},
                                                     "room for two trims"),
                                                    ({"integral_trim": 0.5, "observe_trims": False,
                                                      "rudder_trim_s": 0.1}, "rudder_trim_s must be 0"),
                                                    ({"goal_trim_s": 0.1}, "goal trim time constant")])
def test_a_policy_file_with_trim_settings_that_cannot_go_together_is_refused(policy_file, tmp_path, settings, problem):
    path, _ = policy_file
    data = checked_load(path)
    data.update(settings)
    bad = tmp_path / "bad.pt"
    atomic_save(data, bad)
    with pytest.raises(PolicyFileError, match=problem):
        load_policy(bad)


def test_a_stale_onnx_export_beside_a_rewritten_policy_is_not_used(policy_file, tmp_path):
    """A run rewrites best_policy.pt; the .onnx exported beside the older one must be redone."""
    import shutil

    path = tmp_path / "best_policy.pt"
    shutil.copyfile(policy_file[0], path)
    window = np.random.default_rng(1).normal(size=(8, OBS_SIZE)).astype(np.float32)
    first = PolicyRuntime(path, backend="onnx").action(window)
    data = checked_load(path)
    key = next(k for k in data["actor"] if k.endswith("weight_ih_l0"))
    data["actor"][key] = data["actor"][key] + 0.5
    atomic_save(data, path)
    onnx_now = PolicyRuntime(path, backend="onnx").action(window)
    np.testing.assert_allclose(onnx_now, PolicyRuntime(path, backend="torch").action(window), atol=1e-5)
    assert np.abs(onnx_now - first).max() > 1e-3


def test_broken_policy_file_gives_a_clear_error(tmp_path):
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"garbage")
    with pytest.raises(PolicyFileError, match="not a usable policy"):
        load_policy(bad)
    torch.save({"actor": {}, "window": 8}, tmp_path / "incomplete.pt")
    with pytest.raises(PolicyFileError):
        load_policy(tmp_path / "incomplete.pt")


def test_missing_shipped_controller_is_a_clear_error(monkeypatch, tmp_path):
    from jsbsim_env.control import policy

    monkeypatch.setattr(policy, "shipped_policy_path", lambda: tmp_path / "absent.pt")
    with pytest.raises(PolicyFileError, match="no trained controller ships"):
        PolicyRuntime()


def test_ship_policy_needs_the_runs_first_command_and_commit(policy_file, tmp_path):
    """A run whose sessions.jsonl misses its first session (or has none) is refused before the
    shipped files are touched."""
    import json
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from training.provenance import SESSIONS_FILE

    path, _ = policy_file
    run = tmp_path / "run"
    run.mkdir()
    shutil.copyfile(path, run / "best_policy.pt")
    script = Path(__file__).resolve().parents[1] / "scripts" / "ship_policy.py"
    shipped = [p.stat().st_mtime_ns for p in sorted(Path(script).parents[1].glob("jsbsim_env/control/shipped/*"))]
    resumed_only = json.dumps({"command": "python scripts/train_torchrl.py --resume r", "commit": "abc",
                               "dirty": False, "frames_at_start": 5000})
    for sessions in ("", resumed_only + "\n"):
        (run / SESSIONS_FILE).write_text(sessions)
        done = subprocess.run([sys.executable, str(script), str(run)], capture_output=True, text=True,
                              check=False, timeout=120)
        assert done.returncode == 2 and "give its --command and --commit" in done.stderr
    # A whole run whose sessions do not say how many cores it had needs --cores.
    (run / SESSIONS_FILE).write_text(resumed_only.replace("5000", "0") + "\n")
    done = subprocess.run([sys.executable, str(script), str(run)], capture_output=True, text=True, check=False,
                          timeout=120)
    assert done.returncode == 2 and "cores the run trained on are unknown: give --cores" in done.stderr
    assert [p.stat().st_mtime_ns for p in sorted(Path(script).parents[1].glob("jsbsim_env/control/shipped/*"))] == shipped


@pytest.mark.parametrize(("decay", "trim", "observe", "in_surfaces", "rudder_s"),
                         [(0.0, 0.0, True, True, 0.0), (0.99, 0.0, True, True, 0.0), (0.0, 0.5, True, True, 0.0),
                          (0.99, 0.5, True, True, 0.0), (0.99, 0.5, False, True, 0.0),
                          (0.0, 0.5, False, False, 0.0), (0.0, 0.5, False, False, 2.0)])
def test_runtime_builds_the_environments_observation(tmp_path, decay, trim, observe, in_surfaces, rudder_s):
    """Flying from measurements (with its own last action, and error integrals and integral trim, seen
    or hidden, in the surface positions or taken off them, where the policy has them) gives the same
    commands as flying from the environment's observations."""
    c = TrainConfig(seed=2)
    c.env.num_envs, c.buffer.capacity, c.log.progress = 1, 10, False
    c.env.error_integral_decay, c.env.integral_trim, c.env.observe_trims = decay, trim, observe
    c.env.trims_in_surfaces, c.env.rudder_trim_s = in_surfaces, rudder_s
    c.env.goal_trim_s = 0.0  # flight-time only: the environment's goals are not moved
    c.env.flight_integral_trim = 0.0  # flight-time only: the policy flies with the environment's trim gains
    path = tmp_path / "policy.pt"
    Trainer(c, tmp_path / "run").save_policy(path, {"return_norm": 0.0})
    from_env, from_measurement = PolicyRuntime(path, backend="torch"), PolicyRuntime(path, backend="torch")
    task = AttitudeTask(TaskConfig(error_integral_decay=decay, integral_trim=trim, observe_trims=observe,
                                   trims_in_surfaces=in_surfaces, rudder_trim_s=rudder_s))
    assert from_env.observation_size == task.config.observation_size
    obs, _ = task.reset(4)
    trims_seen = []
    for _ in range(40):
        a_env = np.clip(from_env.act_scaled(obs).astype(np.float64), -1, 1)
        command_env = action_to_command(a_env)
        if trim > 0.0:  # the environment adds its trims (those it shows in the observation, where it does)
            trims_seen.append(np.array(task.batch._trims[0].trim_deg))
            if observe:
                np.testing.assert_allclose(obs[OBS_SIZE - 3:OBS_SIZE - 1] * TRIM_SCALE_DEG, trims_seen[-1], atol=1e-4)
            trimmed = slice(9, 9 + len(trims_seen[-1]))  # aileron, elevator, and rudder where trimmed
            surfaces_rad = obs[trimmed] * OBS_SCALE[trimmed] + OBS_OFFSET[trimmed]
            measured_rad = task.batch.measurements()[0, trimmed]
            np.testing.assert_allclose(surfaces_rad, measured_rad - (0.0 if in_surfaces else np.radians(trims_seen[-1])),
                                       atol=1e-5)
            command_env[:len(trims_seen[-1])] += trims_seen[-1]
        dt_s = task.core.setup.control_interval_s
        command = from_measurement.act(task.batch.measurements()[0], task.batch.goals[0], dt_s)
        np.testing.assert_allclose(command_env, command, atol=1e-4)
        obs, _, terminated, truncated, _ = task.step(a_env)
        assert not (terminated or truncated)
    if trim > 0.0:
        assert np.abs(trims_seen[-1]).min() > 0.01  # every trim moved, the rudder's too where there is one

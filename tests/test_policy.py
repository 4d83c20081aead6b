"""The deployed controller: loading, ONNX export against PyTorch, the runtime's window, stack and mapping."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
import torch

from jsbsim_env.control.checked_io import atomic_save, checked_load
from jsbsim_env.control.observation import OBS_SIZE, ActionError, action_to_command
from jsbsim_env.control.policy import PolicyFileError, PolicyRuntime, export_onnx, load_policy, shipped_policy_path
from jsbsim_env.control.stack import FLIGHT_STACKS, StackSettings
from jsbsim_env.task.attitude import AttitudeTask, TaskConfig
from jsbsim_env.task.versions import LATEST, V0, V1, V3

LEVEL = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5])  # scales to zeros, as does GOAL
GOAL = np.array([0.0, 0.0, 10.0])


@pytest.fixture(scope="module")
def trained(tmp_path_factory, untrained_trainer):
    """A policy file written by the trainer (the latest task version) from freshly initialised networks."""
    run = tmp_path_factory.mktemp("run")
    trainer = untrained_trainer(run, seed=1)
    path = run / "policy.pt"
    trainer.save_policy(path, {"return_norm": 0.0})
    return path, trainer


@pytest.fixture(scope="module")
def policy_file(trained):
    return trained[0]


def _with(path, tmp_path, name: str = "policy.pt", drop=(), **entries):
    """A copy of the policy file at ``path`` with ``entries`` set and the keys ``drop`` left out."""
    data = checked_load(path)
    for key in drop:
        data.pop(key)
    data.update(entries)
    out = tmp_path / name
    atomic_save(data, out)
    return out


def test_loaded_policy_is_the_trainers_deterministic_actor(trained):
    path, trainer = trained
    actor, meta = load_policy(path)
    assert meta["seed"] == 1 and meta["task"] == LATEST
    assert isinstance(meta["stack"], StackSettings) and meta["stack"] == V1.flight_stack == StackSettings(8, 20.0, 2.0)
    window = torch.randn(5, 8, OBS_SIZE)
    loc, _ = trainer.actor.module[0].module(window)
    torch.testing.assert_close(actor(window), torch.tanh(loc))


def test_onnx_export_gives_the_pytorch_actions(policy_file, tmp_path):
    path = policy_file
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
    path = policy_file
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
    assert runtime_onnx.window == 8 and runtime_onnx.observation_size == OBS_SIZE
    command = runtime_torch.act(np.zeros(13), GOAL, 0.04)
    assert command.shape == (4,) and -30 <= command[0] <= 30 and 0 <= command[3] <= 1
    runtime_torch.reset()
    a = runtime_torch.action(runtime_torch.push(np.zeros(OBS_SIZE)))
    runtime_torch.reset()
    # The level measurement and goal scale to zeros, with the measured surfaces as the last action.
    np.testing.assert_allclose(runtime_torch.act(LEVEL, GOAL, 0.04), action_to_command(a),
                               atol=1e-6)  # the trims start at zero


@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_a_nan_measurement_is_a_clear_error_not_a_command(policy_file, backend):
    path = policy_file
    runtime = PolicyRuntime(path, backend=backend)
    measurement = np.array([10000.0, 0, 0, 0, 0, 0, 10.0, 0, 0, 0, 0, 0, 0.5])
    runtime.act(measurement, np.array([0.0, 0.0, 10.0]), 0.04)
    for index in (1, 6, 10):  # onnxruntime's LSTM turns a NaN input into finite actions: refused before it
        bad = measurement.copy()
        bad[index] = np.nan
        with pytest.raises(ValueError, match="measurement .* is not finite"):
            runtime.act(bad, np.array([0.0, 0.0, 10.0]), 0.04)
    with pytest.raises(ValueError, match="goal pitch = inf is not finite"):
        runtime.act(measurement, np.array([0.0, np.inf, 10.0]), 0.04)
    for dt_s in (float("nan"), 0.0, -0.04):  # a NaN interval would stay in the trims for good
        with pytest.raises(ValueError, match="control interval dt_s = .* s is outside"):
            runtime.act(measurement, np.array([0.0, 0.0, 10.0]), dt_s)
    runtime.actor.net.encoder.lstm.weight_ih_l0.data[:] = np.nan  # a network that gives NaN: not a command
    runtime.backend = "torch"
    with pytest.raises(ActionError, match="not finite"):
        runtime.act(measurement, np.array([0.0, 0.0, 10.0]), 0.04)
    stack = runtime.stack  # reset: the next call starts afresh
    assert stack.last_action is None and stack.surface_trim.trim_deg == [0.0, 0.0] == stack.goal_trim.offset_rad


@pytest.mark.parametrize("version", [V0, V1, V3], ids=lambda v: v.env_id)
def test_the_trainer_writes_its_task_version_and_flight_stack_and_the_runtime_flies_it(version, tmp_path,
                                                                                       untrained_policy):
    path = untrained_policy(tmp_path / "policy.pt", seed=3, task=version.env_id)
    data = checked_load(path)
    assert data["task"] == version.env_id and data["stack"] == version.flight_stack.to_dict()
    assert not {"window", "integral_trim", "goal_trim_s", "observe_trims"} & set(data)  # the flat keys are gone
    runtime = PolicyRuntime(path, backend="torch")
    assert runtime.meta["stack"] == runtime.stack.settings == version.flight_stack and runtime.window == 8
    assert (runtime.stack.goal_trim is None) == (version.flight_stack.goal_trim_time_constant_s == 0.0)
    assert (runtime.stack.surface_trim is None) == (version.flight_stack.surface_trim_gain == 0.0)
    assert runtime.observation_size == version.task.observation_size == runtime.actor.net.obs_size
    if runtime.stack.needs_interval:
        with pytest.raises(ValueError, match="control interval dt_s"):
            runtime.act(LEVEL, GOAL)
    else:
        assert runtime.act(LEVEL, GOAL).shape == (4,)  # the network alone needs no interval


def test_the_shipped_policys_flat_settings_still_load(policy_file, tmp_path):
    """Policy files written before the ``stack`` entry (the shipped one is such a file) record their
    stages as flat settings; those the stack has load as its settings."""
    flat = {"window": 8, "integral_trim": 2.0, "goal_trim_s": 20.0, "error_integral_decay": 0.0,
            "observe_trims": False, "trims_in_surfaces": False, "rudder_trim_s": 0.0}
    old = _with(policy_file, tmp_path, drop=("stack", "task"), **flat)
    _, meta = load_policy(old)
    assert meta["stack"] == StackSettings(8, 20.0, 2.0)
    paper = _with(policy_file, tmp_path, "paper.pt", drop=("stack", "task"), window=4)  # no trims: the network alone
    assert load_policy(paper)[1]["stack"] == StackSettings(4, 0.0, 0.0)
    shown = _with(policy_file, tmp_path, "shown.pt", drop=("stack", "task"), observe_trims=True, integral_trim=0.0)
    assert load_policy(shown)[1]["stack"] == StackSettings()  # shown trims, but none to show


@pytest.mark.parametrize(("flat", "named"), [
    ({"observe_trims": True, "integral_trim": 0.5}, "observe_trims"),
    ({"observe_trims": False, "integral_trim": 0.5}, "trims_in_surfaces"),  # left in the surfaces when not named
    ({"observe_trims": False, "trims_in_surfaces": True, "integral_trim": 0.5}, "trims_in_surfaces"),
    ({"error_integral_decay": 0.99}, "error_integral_decay"),
    ({"integral_trim": 0.5, "observe_trims": False, "trims_in_surfaces": False, "rudder_trim_s": 2.0},
     "rudder_trim_s"),
    ({"goal_trim_s": 0.1}, "goal_trim_time_constant_s"),
    ({"window": 0}, "window_steps"),
])
def test_an_old_policy_file_with_stages_this_version_does_not_have_is_refused_naming_them(policy_file, tmp_path,
                                                                                          flat, named):
    bad = _with(policy_file, tmp_path, drop=("stack", "task"), **flat)
    with pytest.raises(PolicyFileError, match=named) as err:
        load_policy(bad)
    assert str(bad) in str(err.value)


@pytest.mark.parametrize(("stack", "named"), [({"window_steps": 8, "integral_trim": 0.5}, "integral_trim"),
                                              ({"surface_trim_gain": 3.0}, "surface_trim_gain"),
                                              ({"goal_trim_time_constant_s": 0.1}, "goal_trim_time_constant_s")])
def test_a_policy_file_with_a_stack_this_version_cannot_fly_is_refused(policy_file, tmp_path, stack, named):
    with pytest.raises(PolicyFileError, match=named):
        load_policy(_with(policy_file, tmp_path, stack=stack))


def test_a_policy_file_whose_network_does_not_read_what_its_stack_gives_is_refused_naming_both_sizes(
        tmp_path, untrained_policy):
    path = untrained_policy(tmp_path / "v3.pt", seed=3, task=V3.env_id)
    stripped = _with(path, tmp_path, "stripped.pt", stack=StackSettings(8).to_dict())  # no error integrals
    with pytest.raises(PolicyFileError, match="observations of 23 values, and its control stack gives 20") as err:
        load_policy(stripped)
    assert str(stripped) in str(err.value)


def test_a_stale_onnx_export_beside_a_rewritten_policy_is_not_used(policy_file, tmp_path):
    """A run rewrites best_policy.pt; the .onnx exported beside the older one must be redone."""
    import shutil

    path = tmp_path / "best_policy.pt"
    shutil.copyfile(policy_file, path)
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
    with pytest.raises(PolicyFileError, match=f"^{re.escape(str(bad))} is damaged or not a file of this package"):
        load_policy(bad)
    torch.save({"actor": {}, "window": 8}, tmp_path / "incomplete.pt")
    with pytest.raises(PolicyFileError, match="no actor network"):
        load_policy(tmp_path / "incomplete.pt")
    torch.save({"actor": {}, "network": {"lstm_hidden": 8, "mlp_hidden": 16}}, tmp_path / "empty.pt")
    with pytest.raises(PolicyFileError, match="not a usable policy file"):
        load_policy(tmp_path / "empty.pt")
    with pytest.raises(PolicyFileError, match="no policy file at"):
        load_policy(tmp_path / "absent.pt")


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

    path = policy_file
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


@pytest.mark.parametrize(("task", "stack"), [(TaskConfig(), StackSettings()),
                                             (dataclasses.replace(V1.task, external_throttle=0.0),
                                              StackSettings(8, 0.0, V1.task.surface_trim_gain))],
                         ids=["network alone", "surface trim"])
def test_the_runtime_flying_from_measurements_sees_the_tasks_observations(policy_file, tmp_path, task, stack,
                                                                          monkeypatch):
    """The task and the runtime run the same stages: a policy flown by ``PolicyRuntime.act`` from
    the task's measurements and goals is given the observations the task computes (with the task's
    surface trims taken off the observed surfaces, where it has them), in the window training's
    ``CatFrames`` keeps, and its commands, trims included, are those the task flies."""
    monkeypatch.setitem(FLIGHT_STACKS, "stages-under-test", stack)  # a file's stack is its task version's
    path = _with(policy_file, tmp_path, stack=stack.to_dict(), task="stages-under-test")
    runtime = PolicyRuntime(path, backend="torch")
    windows, actions = [], []
    network = runtime.action

    def recorded(window):
        windows.append(np.array(window))
        actions.append(network(window))
        return actions[-1]

    runtime.action = recorded
    env = AttitudeTask(task)
    obs, _ = env.reset(4)
    seen = [obs]
    for _ in range(40):
        b = env.batch
        command = runtime.act(b.measurements()[0], b.goals[0], env.core.setup.control_interval_s)
        expected = ([seen[0]] * 8 + seen)[-8:]  # a new episode's window is its first observation repeated
        np.testing.assert_allclose(windows[-1], np.array(expected), atol=2e-6)
        action = np.clip(actions[-1].astype(np.float64), -1, 1)
        flown = action_to_command(action)
        if stack.surface_trim_gain:
            trims = b._trims[0].trim_deg
            np.testing.assert_allclose(runtime.stack.surface_trim.trim_deg, trims, atol=1e-9)
            flown[:2] += trims
        np.testing.assert_allclose(command, flown, atol=1e-6)
        obs, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
        seen.append(obs)
    if stack.surface_trim_gain:
        assert min(abs(t) for t in runtime.stack.surface_trim.trim_deg) > 0.01  # both trims moved


@pytest.mark.parametrize(("edit", "named"), [
    ({"stack": {**V1.flight_stack.to_dict(), "window_steps": 2}}, r"its stack .* is not the one .*-v1 flies with"),
    ({"task": "SolarUAVAttitude-v99"}, r"task 'SolarUAVAttitude-v99' is not a task version of this package"),
    ({"drop": ("aircraft", "aircraft_model")}, r"records its task but not aircraft or aircraft_model"),
    ({"drop": ("aircraft_model",)}, r"records its task but not aircraft_model"),
    ({"aircraft_model": "0" * 12}, r"aircraft_model must be a 64-hex fingerprint"),
    ({"frames": -5}, r"frames must be a whole number >= 0, got -5"),
    ({"seed": "1"}, r"seed must be a whole number, got '1'"),
])
def test_an_edited_policy_record_is_refused_naming_the_field(policy_file, tmp_path, edit, named):
    edit = dict(edit)
    path = _with(policy_file, tmp_path, drop=edit.pop("drop", ()), **edit)
    with pytest.raises(PolicyFileError, match=named + ".*not a policy file as the trainer writes it"):
        load_policy(path)


def test_a_policy_record_rewritten_without_its_checksum_is_refused(policy_file, tmp_path):
    """An edit by hand (``torch.save``) writes no checksum: a file that records its task always has one."""
    data = checked_load(policy_file)
    torch.save(data, tmp_path / "policy.pt")
    with pytest.raises(PolicyFileError, match="written without the SHA-256 of its contents"):
        load_policy(tmp_path / "policy.pt")
    load_policy(shipped_policy_path())  # written before the task was recorded: its flat settings, checked as such

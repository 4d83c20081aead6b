"""Bad input gets a clear error naming the problem, and interrupted work loses nothing: one test
per case of the README's reliability table."""

from __future__ import annotations

import json
import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from jsbsim_env.control.observation import ActionError
from jsbsim_env.control.policy import PolicyFileError, PolicyRuntime, load_policy
from training.checkpoint import CheckpointError, atomic_save, checked_load, load_checkpoint
from training.trainer import Trainer

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, tiny_config):
    """A run folder trained for 96 steps (checkpoint and best policy)."""
    run = tmp_path_factory.mktemp("reliability") / "run"
    Trainer(tiny_config(96), run).train()
    return run


def _copy(src: Path, dst_dir: Path) -> Path:
    dst = dst_dir / src.name
    shutil.copyfile(src, dst)
    return dst


def _overwrite_4kib(path: Path) -> None:
    raw = bytearray(path.read_bytes())
    start = len(raw) // 2
    raw[start:start + 4096] = np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    path.write_bytes(bytes(raw))


def test_a_checkpoint_with_4_kib_overwritten_is_refused_on_load(tiny_run, tmp_path):
    path = _copy(tiny_run / "checkpoint.pt", tmp_path)
    _overwrite_4kib(path)
    with pytest.raises(CheckpointError, match="is damaged: its contents do not match the SHA-256"):
        load_checkpoint(path)


def test_a_checkpoint_with_non_finite_weights_is_refused_naming_them(tiny_run, tmp_path):
    data = checked_load(tiny_run / "checkpoint.pt")
    key = next(k for k, v in data["sac"].items() if v.is_floating_point())
    data["sac"][key] = torch.full_like(data["sac"][key], math.nan)
    atomic_save(data, tmp_path / "checkpoint.pt")
    with pytest.raises(CheckpointError, match=f"NaN or infinite values in sac.{key}"):
        load_checkpoint(tmp_path / "checkpoint.pt")


def test_a_checkpoint_with_a_non_finite_replay_buffer_is_refused(tiny_run, tmp_path):
    data = checked_load(tiny_run / "checkpoint.pt")
    data["buffer"]["data"]["observation"][0, 0, 0] = math.inf
    atomic_save(data, tmp_path / "checkpoint.pt")
    with pytest.raises(CheckpointError, match="buffer.data.observation"):
        load_checkpoint(tmp_path / "checkpoint.pt")


def test_a_policy_file_with_nan_weights_is_refused_naming_the_file(tiny_run, tmp_path):
    data = checked_load(tiny_run / "best_policy.pt")
    key = next(iter(data["actor"]))
    data["actor"][key] = torch.full_like(data["actor"][key], math.nan)
    path = tmp_path / "nan_policy.pt"
    atomic_save(data, path)
    with pytest.raises(PolicyFileError, match=f"{path} holds NaN or infinite weights"):
        load_policy(path)


def test_evaluate_refuses_a_damaged_policy_file_naming_it(tiny_run, tmp_path, capsys, load_script):
    path = _copy(tiny_run / "best_policy.pt", tmp_path)
    _overwrite_4kib(path) if path.stat().st_size > 10_000 else path.write_bytes(path.read_bytes()[:-50] + b"x" * 50)
    assert load_script("evaluate").main(["--policy", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "damaged" in err


def test_evaluate_refuses_zero_episodes(capsys, load_script):
    with pytest.raises(SystemExit) as stop:
        load_script("evaluate").main(["--episodes", "0"])
    assert stop.value.code == 2 and "--episodes must be in [1, 1000], got 0" in capsys.readouterr().err


def test_evaluate_json_has_null_and_the_reason_where_a_metric_is_not_finite(load_script):
    from jsbsim_env.task.metrics import json_ready

    nulls: dict[str, str] = {}
    out = json_ready({"doublets": {"500m": {"settling_time_90_s_roll": [2.8, math.nan]}}, "x": np.float64(1.5)},
                     load_script("evaluate").why_null, nulls)
    text = json.dumps(out, allow_nan=False)
    assert json.loads(text)["doublets"]["500m"]["settling_time_90_s_roll"] == [2.8, None]
    assert nulls == {"doublets.500m.settling_time_90_s_roll[1]":
                     "never settled: the error was still outside 10 % of the step when the next step came"}


def test_running_a_policy_writes_nothing_beside_the_users_file(tiny_run, tmp_path):
    path = _copy(tiny_run / "best_policy.pt", tmp_path)
    runtime = PolicyRuntime(path, backend="onnx")
    runtime.act(np.zeros(13) + [1000, 0, 0, 0, 0, 0, 10, 0, 0, 0, 0, 0, 0.4], np.array([0.0, 0.0, 10.0]), 0.04)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_resume_of_a_missing_folder_is_a_one_line_error(tmp_path, capsys, load_script):
    assert load_script("train_torchrl").main(["--resume", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"train_torchrl: no run to resume at {tmp_path / 'nowhere'} (it has no config.json)"]


def test_total_frames_below_the_random_warm_up_is_refused_with_both_numbers(tmp_path, capsys, load_script, tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(32), "--log.run_root", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err
    assert "collector.total_frames (32) must exceed collector.init_random_frames (64)" in err


def test_training_prints_only_json_on_stdout_when_asked(tmp_path, capsys, load_script, tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path),
                                          "--run-name", "run", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)  # the whole of stdout is one JSON document
    assert out["frames"] == 96 and out["run_dir"] == str(tmp_path / "run")


def test_sigint_during_training_writes_a_checkpoint_and_resume_goes_on(tmp_path, tiny_args):
    run = tmp_path / "run"
    cmd = [sys.executable, str(SCRIPTS / "train_torchrl.py"), *tiny_args(1_000_000),
           "--log.run_root", str(tmp_path), "--run-name", "run"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while not (run / "progress.csv").exists() or len((run / "progress.csv").read_text().splitlines()) < 4:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130
    last = err.strip().splitlines()[-1]
    assert last.startswith("train_torchrl: stopped by SIGINT at ") and f"--resume {run}" in last
    assert "Traceback" not in err and out == ""
    frames = load_checkpoint(run / "checkpoint.pt")["counters"]["frames"]
    assert frames >= 96
    resumed = subprocess.run([sys.executable, str(SCRIPTS / "train_torchrl.py"), "--resume", str(run),
                              "--collector.total_frames", str(frames + 64), "--json"],
                             capture_output=True, text=True, timeout=300, check=False)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads(resumed.stdout)["frames"] == frames + 64


@pytest.mark.parametrize("shape", [(1, 4), (2, 2), (4, 1)])
def test_the_gymnasium_env_refuses_an_action_of_the_wrong_shape(shape):
    import gymnasium as gym

    import jsbsim_env  # noqa: F401 - registers the environment

    env = gym.make("SolarUAVAttitude-v0")
    env.reset(seed=0)
    with pytest.raises(ActionError, match=rf"action must have shape \(4,\).*got shape \({shape[0]}, {shape[1]}\)"):
        env.step(np.zeros(shape, dtype=np.float32))


def test_the_torchrl_env_refuses_an_action_of_the_wrong_shape():
    from jsbsim_env.task.torchrl_env import make_env

    env = make_env(2, seed=0)
    td = env.reset()
    td["action"] = torch.zeros(2, 1, 4)
    with pytest.raises(ActionError, match=r"actions must have shape \(2, 4\).*got shape \(2, 1, 4\)"):
        env.step(td)

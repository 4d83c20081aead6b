"""Training: a tiny run end to end, checkpoints, resumption, configuration."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import TaskConfig
from jsbsim_env.task.versions import LATEST, V1
from training.checkpoint import CheckpointError, atomic_save, checked_load, load_checkpoint
from training.config import TrainConfig
from training.trainer import RunLockedError, Trainer

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def _rows(run_dir: Path) -> list[dict]:
    return list(csv.DictReader((run_dir / "progress.csv").open()))


def test_tiny_run_writes_logs_checkpoint_and_policy(tmp_path, tiny_config):
    run = tmp_path / "run"
    Trainer(tiny_config(), run).train()
    assert json.loads((run / "config.json").read_text())["network"]["lstm_hidden"] == 8
    rows = _rows(run)
    assert int(rows[-1]["frames"]) == 192
    # updates_per_step updates per step after the random warm-up
    assert int(rows[-1]["updates"]) == (192 - 64) * tiny_config().optim.updates_per_step
    assert any(r["eval_return_norm"] for r in rows)
    assert any(p.name.startswith("events") for p in (run / "tb").iterdir())
    data = load_checkpoint(run / "checkpoint.pt")
    assert data["counters"]["frames"] == 192 and len(data["buffer"]["data"]) == 192
    policy = checked_load(run / "best_policy.pt")
    assert "actor" in policy and policy["task"] == LATEST == "SolarUAVAttitude-v1"
    assert policy["stack"] == V1.flight_stack.to_dict() and policy["stack"]["window_steps"] == 8


def test_resume_continues_counting_with_the_buffer(tmp_path, tiny_config):
    run = tmp_path / "run"
    Trainer(tiny_config(96), run).train()
    first = load_checkpoint(run / "checkpoint.pt")
    resumed = Trainer(tiny_config(192), run, resume=True)
    assert resumed.counters.frames == 96 and resumed.counters.updates == first["counters"]["updates"]
    assert len(resumed.buffer) == 96
    torch.testing.assert_close(resumed.buffer[:96]["action"], first["buffer"]["data"]["action"])
    resumed.train()
    frames = [int(r["frames"]) for r in _rows(run)]
    assert frames == sorted(frames) and frames[-1] == 192
    assert load_checkpoint(run / "checkpoint.pt")["counters"]["updates"] == (192 - 64) * tiny_config().optim.updates_per_step


def test_corrupt_or_mismatched_checkpoints_give_clear_errors(tmp_path, tiny_config):
    run = tmp_path / "run"
    Trainer(tiny_config(96), run).train()
    other = tiny_config(96)
    other.network.lstm_hidden = 16
    with pytest.raises(CheckpointError, match="other settings"):
        Trainer(other, run, resume=True)
    # A checkpoint of another version of the package (a setting this one does not have) is refused naming it.
    saved = checked_load(run / "checkpoint.pt")
    older = tmp_path / "older"
    older.mkdir()
    saved["config"]["env"]["integral_trim"] = 0.5
    atomic_save(saved, older / "checkpoint.pt")
    with pytest.raises(CheckpointError, match="unreadable settings.*env.integral_trim"):
        Trainer(tiny_config(96), older, resume=True)
    (run / "checkpoint.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="damaged"):
        Trainer(tiny_config(96), run, resume=True)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        load_checkpoint(tmp_path / "missing.pt")
    atomic_save({"something": 1}, tmp_path / "foreign.pt")
    with pytest.raises(CheckpointError, match="unknown format"):
        load_checkpoint(tmp_path / "foreign.pt")


def test_config_round_trip_and_command_line():
    import argparse

    parser = argparse.ArgumentParser()
    TrainConfig.add_arguments(parser)
    ns = parser.parse_args(["--seed", "7", "--optim.lr", "0.001", "--env.disturbances", "false",
                            "--env.task", "SolarUAVAttitude-v0"])
    c = TrainConfig.from_namespace(ns)
    assert c.seed == 7 and c.optim.lr == 0.001 and c.env.disturbances is False and c.env.task == "SolarUAVAttitude-v0"
    assert c.buffer.batch_size == 256 and c.caps.kappa_spatial == 0.5  # untouched settings keep their defaults
    assert TrainConfig().env.task == LATEST
    assert TrainConfig.from_dict(json.loads(c.to_json())) == c
    # A list setting takes one value per entry, and a config's list is its own.
    ns = parser.parse_args(["--caps.action_weights", "1", "1", "0.5", "1"])
    c = TrainConfig.from_namespace(ns)
    assert c.caps.action_weights == [1.0, 1.0, 0.5, 1.0]
    assert TrainConfig.from_dict(json.loads(c.to_json())) == c
    assert TrainConfig().caps.action_weights == [1.0, 1.0, 1.0, 1.0] != c.caps.action_weights
    with pytest.raises(SystemExit):
        parser.parse_args(["--caps.action_weights", "0.5", "1"])
    with pytest.raises(ValueError, match="SolarUAVAttitude-v99"):
        TrainConfig.from_namespace(parser.parse_args(["--env.task", "SolarUAVAttitude-v99"]))


@pytest.mark.parametrize("text", ["yes", "no", "0", "1", "on", "True", "FALSE", "flase", ""])
def test_a_boolean_option_takes_exactly_true_or_false(text, capsys):
    import argparse

    parser = argparse.ArgumentParser()
    TrainConfig.add_arguments(parser)
    assert TrainConfig.from_namespace(parser.parse_args(["--env.disturbances", "false"])).env.disturbances is False
    assert TrainConfig.from_namespace(parser.parse_args(["--log.progress", "true"])).log.progress is True
    with pytest.raises(SystemExit):
        parser.parse_args(["--env.disturbances", text])
    assert f"must be true or false, got {text!r}" in capsys.readouterr().err


@pytest.mark.parametrize(("data", "named"), [
    ({"env": {"integral_trim": 0.5}}, "env.integral_trim"),
    ({"env": {"task": "SolarUAVAttitude-v1", "delay_ms": [80.0, 120.0]}}, "env.delay_ms"),
    ({"optim": {"learning_rate": 1e-3}}, "optim.learning_rate"),
    ({"optim": {"recurrent_lr": 3e-5, "lr_end_fraction": 0.1}}, "optim.lr_end_fraction, optim.recurrent_lr"),
    ({"log": {"eval_max_steps": 10}}, "log.eval_max_steps"),
    ({"preset": "paper"}, "preset"),
])
def test_a_configuration_from_another_version_is_refused_naming_its_settings(data, named):
    """Settings this version does not have (removed options, an older run's flat task settings) are
    refused by name: only the version the run was made with trains as it did."""
    with pytest.raises(ValueError, match="do not exist in this version of the package") as err:
        TrainConfig.from_dict(data)
    assert named in str(err.value) and "configuration is from another version" in str(err.value)


def test_a_task_version_the_package_does_not_have_is_refused_naming_it():
    with pytest.raises(ValueError, match="'SolarUAVAttitude-v99'") as err:
        TrainConfig.from_dict({"env": {"task": "SolarUAVAttitude-v99"}})
    assert "SolarUAVAttitude-v0" in str(err.value) and "SolarUAVAttitude-v1" in str(err.value)  # the known ones
    assert TrainConfig.from_dict({"env": {"task": "SolarUAVAttitude-v0"}}).env.task == "SolarUAVAttitude-v0"


def test_training_benchmark_prints_only_its_figures_on_stdout():
    """TorchRL logs to stdout; with --json the benchmark's stdout must be one JSON object."""
    done = subprocess.run([sys.executable, str(SCRIPTS / "bench_train.py"), "--json", "--updates", "2", "--rounds", "1"],
                          capture_output=True, text=True, check=False, timeout=300)
    assert done.returncode == 0, done.stderr
    figures = json.loads(done.stdout)
    assert figures["update_ms"] > 0 and figures["reference_update_ms"] > 0 and figures["batch_size"] == 256


def test_train_script_help_lists_the_settings():
    done = subprocess.run([sys.executable, str(SCRIPTS / "train_torchrl.py"), "--help"], capture_output=True,
                          text=True, check=False, timeout=120)
    assert done.returncode == 0, done.stderr
    for option in ("--resume", "--seed", "--optim.lr", "--caps.kappa_spatial", "--collector.total_frames",
                   "--env.task"):
        assert option in done.stdout
    for removed in ("--preset", "--env.integral_trim", "--env.window", "--log.eval_max_steps"):
        assert removed not in done.stdout


def test_train_script_records_each_session_for_the_shipped_record(tmp_path, load_script, tiny_args, capsys):
    script = load_script("train_torchrl")
    tiny = [*tiny_args(None), "--log.run_root", str(tmp_path), "--run-name", "run"]
    assert script.main([*tiny, "--collector.total_frames", "96"]) == 0
    run = tmp_path / "run"
    capsys.readouterr()
    assert script.main(["--resume", str(run), "--collector.total_frames", "128"]) == 0
    assert "train_torchrl: resuming from its checkpoint at 96 of 128 environment steps" in capsys.readouterr().err
    import aircraft
    from training.provenance import git_commit, read_sessions, trained_aircraft_model

    first, second = read_sessions(run)
    assert first["command"].startswith("python scripts/train_torchrl.py --seed 3") and first["frames_at_start"] == 0
    assert "--resume" in second["command"] and second["frames_at_start"] == 96
    assert first["commit"] == git_commit()[0]
    assert first["aircraft_model"] == second["aircraft_model"] == aircraft.model_fingerprint()
    # A policy in the run folder is known to be trained on that model.
    assert trained_aircraft_model(run / "best_policy.pt") == aircraft.model_fingerprint()
    assert int(_rows(run)[-1]["frames"]) == 128
    from training.provenance import training_wall_clock
    from training.runtime import available_cores

    assert first["cpu_cores"] == second["cpu_cores"] == available_cores()
    wall = training_wall_clock(run, 96)
    assert 0 < wall["to_policy_s"] <= wall["whole_run_s"] and wall["frames"] == 128
    assert training_wall_clock(run, 10**9)["to_policy_s"] is None


def test_a_second_trainer_on_a_live_run_is_refused(tmp_path, tiny_config):
    run = tmp_path / "run"
    first = Trainer(tiny_config(96), run)
    with pytest.raises(RunLockedError, match="another process"):
        Trainer(tiny_config(96), run, resume=True)
    del first  # the lock goes with the trainer
    import gc

    gc.collect()


def test_training_summary_finds_the_steps_to_90_percent_of_the_final_return(tmp_path, load_script):
    from training.trainer import CSV_FIELDS

    script = load_script("plot_training")
    evals = {10_000: 0.4, 20_000: 0.5, 30_000: 0.8, 40_000: 0.9, 50_000: 1.0, 60_000: 1.0}
    with (tmp_path / "progress.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_FIELDS)
        w.writeheader()
        for frames in range(5_000, 65_000, 5_000):  # rows without an evaluation in between
            w.writerow({"frames": frames, "updates": frames - 5_000, "wall_s": frames / 10.0,
                        "eval_return_norm": evals.get(frames, "")})
    summary = script.run_summary(tmp_path, final_evals=3)
    assert summary["final_eval_return"] == pytest.approx((0.9 + 1.0 + 1.0) / 3)
    assert summary["frames_to_90pct_of_final"] == 40_000  # 0.8 < 0.87 <= 0.9
    assert summary["frames_to_90pct_of_gain"] == 50_000  # 0.4 + 0.9 * (0.967 - 0.4) = 0.91
    with pytest.raises(ValueError, match="at least 1"):
        script.run_summary(tmp_path, final_evals=0)
    assert summary["wall_h"] == pytest.approx(6_000 / 3600) and summary["updates"] == 55_000
    assert summary["best_eval_return"] == 1.0 and summary["best_eval_frames"] == 50_000


def test_a_run_trains_in_its_task_versions_disturbances_and_evaluates_in_the_papers(tmp_path, tiny_config):
    c = tiny_config()
    trainer = Trainer(c, tmp_path / "run")  # the latest version: SolarUAVAttitude-v1
    assert trainer.task_config == V1.task and trainer.task_config.core.delay_s == (0.04, 0.12)
    assert trainer.eval_task_config.core == CoreConfig()
    assert trainer.eval_task_config.surface_trim_gain == trainer.task_config.surface_trim_gain == 0.5
    assert trainer.window == 8 and trainer.env.base_env.batch.config == V1.task
    c.env.task = "SolarUAVAttitude-v0"  # the paper's task, trained and evaluated in the paper's disturbances
    paper = Trainer(c, tmp_path / "paper")
    assert paper.task_config == paper.eval_task_config == TaskConfig()
    c.env.disturbances = False  # the ideal setting stays ideal, in training and in its evaluation
    ideal = Trainer(c, tmp_path / "ideal")
    assert ideal.task_config.core == ideal.eval_task_config.core == CoreConfig.ideal()
    c.env.task = "SolarUAVAttitude-v99"
    with pytest.raises(ValueError, match="SolarUAVAttitude-v99"):
        Trainer(c, tmp_path / "unknown")


def test_an_asymmetric_critic_trains_on_the_privileged_entries_and_the_policy_flies_without_them(tmp_path, tiny_config):
    from jsbsim_env.control.policy import load_policy
    from jsbsim_env.task.attitude import PRIVILEGED_SIZE

    c = tiny_config()
    c.env.task, c.network.asymmetric_critic = "SolarUAVAttitude-v2", True
    run = tmp_path / "run"
    trainer = Trainer(c, run)
    assert all(critic.privileged_size == PRIVILEGED_SIZE for critic in trainer.sac.critics)
    trainer.train()
    data = load_checkpoint(run / "checkpoint.pt")["buffer"]["data"]
    assert data["privileged"].shape == (192, PRIVILEGED_SIZE) and data["next", "privileged"].abs().sum() > 0
    _, meta = load_policy(run / "best_policy.pt")
    assert meta["task"] == "SolarUAVAttitude-v2" and meta["stack"].surface_trim_gain == 2.0


@pytest.mark.parametrize("encoder", ["gru", "mlp"])
def test_each_encoder_trains_and_its_policy_file_flies_with_it(tmp_path, tiny_config, encoder):
    import numpy as np

    from jsbsim_env.control.network import ENCODERS, RecurrentEncoder, WindowMLPEncoder
    from jsbsim_env.control.policy import PolicyRuntime, load_policy
    from training.config import ENCODERS as CONFIG_ENCODERS

    assert CONFIG_ENCODERS == ENCODERS
    c = tiny_config()
    c.network.encoder = encoder
    run = tmp_path / "run"
    trainer = Trainer(c, run)
    kind = {"gru": RecurrentEncoder, "mlp": WindowMLPEncoder}[encoder]
    assert isinstance(trainer.actor.module[0].module.encoder, kind)
    assert encoder != "gru" or isinstance(trainer.actor.module[0].module.encoder.gru, torch.nn.GRU)
    assert all(isinstance(critic.encoder, kind) for critic in trainer.sac.critics)
    trainer.train()
    actor, meta = load_policy(run / "best_policy.pt")
    assert meta["network"]["encoder"] == encoder and isinstance(actor.net.encoder, kind)
    runtime = PolicyRuntime(run / "best_policy.pt")  # exported to ONNX, as the benchmark flies it
    measurement = np.array([1000.0, 0.0, 0.02, 0.0, 0.0, 0.0, 10.0, 0.05, 0.0, 0.0, 0.0, 0.0, 0.4])
    command = runtime.update(0.04, measurement, np.array([0.0, 0.0, 10.0]))
    assert command.shape == (4,) and np.all(np.isfinite(command))


def test_an_unknown_encoder_is_refused_by_name():
    with pytest.raises(ValueError, match="network.encoder must be one of lstm, gru, mlp, got 'transformer'"):
        TrainConfig.from_dict({"network": {"encoder": "transformer"}})


def test_torchrl_log_lines_go_above_the_progress_bar(monkeypatch):
    import io
    import logging
    import re

    from tqdm import tqdm

    from training.runtime import torchrl_logs_to_stderr

    handlers = [h for h in logging.getLogger("torchrl").handlers if isinstance(h, logging.StreamHandler)]
    streams, formatters = [h.stream for h in handlers], [h.formatter for h in handlers]
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    try:
        torchrl_logs_to_stderr()
        bar = tqdm(total=10, desc="train", file=err, mininterval=0)
        bar.update(5)
        logging.getLogger("torchrl").warning("storage ready")
        bar.update(5)
        bar.close()
    finally:
        for handler, stream, formatter in zip(handlers, streams, formatters):
            handler.setStream(stream)
            handler.setFormatter(formatter)
    pieces = re.split("[\r\n]", err.getvalue())
    logged = [p for p in pieces if "storage ready" in p]
    assert logged and not any("train" in p for p in logged)
    assert any(p.startswith("train: 100%") for p in pieces)

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
from training.checkpoint import CheckpointError, atomic_save, checked_load, load_checkpoint
from training.config import TrainConfig
from training.trainer import RunLockedError, Trainer, lr_factor

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def tiny_config(total_frames: int = 192) -> TrainConfig:
    c = TrainConfig(seed=3)
    c.env.num_envs = 4
    c.collector.total_frames = total_frames
    c.collector.frames_per_batch = 32
    c.collector.init_random_frames = 64
    c.buffer.capacity = 5000
    c.buffer.batch_size = 16
    c.network.lstm_hidden = 8
    c.network.mlp_hidden = 16
    c.log.log_every_frames = 32
    c.log.eval_every_frames = 96
    c.log.eval_episodes = 2
    c.log.eval_max_steps = 10
    c.log.checkpoint_every_frames = 96
    c.log.progress = False
    return c


def _script(name: str):
    """A script under scripts/ imported as a module, to call its functions."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _rows(run_dir: Path) -> list[dict]:
    return list(csv.DictReader((run_dir / "progress.csv").open()))


def test_tiny_run_writes_logs_checkpoint_and_policy(tmp_path):
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
    assert policy["window"] == 8 and "actor" in policy


def test_resume_continues_counting_with_the_buffer(tmp_path):
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


def test_corrupt_or_mismatched_checkpoints_give_clear_errors(tmp_path):
    run = tmp_path / "run"
    Trainer(tiny_config(96), run).train()
    other = tiny_config(96)
    other.network.lstm_hidden = 16
    with pytest.raises(CheckpointError, match="other settings"):
        Trainer(other, run, resume=True)
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
    ns = parser.parse_args(["--seed", "7", "--optim.lr", "0.001", "--env.disturbances", "false"])
    c = TrainConfig.from_namespace(ns)
    assert c.seed == 7 and c.optim.lr == 0.001 and c.env.disturbances is False
    assert c.buffer.batch_size == 256 and c.caps.kappa_spatial == 0.5  # untouched settings keep their defaults
    assert TrainConfig.from_dict(json.loads(c.to_json())) == c
    with pytest.raises(ValueError, match="unknown settings"):
        TrainConfig.from_dict({"optim": {"learning_rate": 1}})
    # A list setting takes one value per entry, and a config's list is its own.
    ns = parser.parse_args(["--caps.action_weights", "1", "1", "0.5", "1", "--optim.recurrent_lr", "3e-5"])
    c = TrainConfig.from_namespace(ns)
    assert c.caps.action_weights == [1.0, 1.0, 0.5, 1.0] and c.optim.recurrent_lr == 3e-5
    assert TrainConfig.from_dict(json.loads(c.to_json())) == c
    assert TrainConfig().caps.action_weights == [1.0, 1.0, 1.0, 1.0] != c.caps.action_weights
    with pytest.raises(SystemExit):
        parser.parse_args(["--caps.action_weights", "0.5", "1"])


def test_config_of_an_older_run_keeps_the_settings_it_trained_with():
    from training.config import LEGACY_VALUES

    # Every legacy entry names a setting that exists, with a value of the setting's type.
    for key, value in LEGACY_VALUES.items():
        group, name = key.split(".")
        assert isinstance(value, type(getattr(getattr(TrainConfig(), group), name))), key
    # A run saved before delay_ms, pitch_weight and the CAPS action weights existed resumes with
    # the values it trained with, not the present defaults; what it saved stays its own.
    data = TrainConfig().to_dict()
    for name in ("delay_ms", "pitch_weight", "roll_weight"):
        del data["env"][name]
    del data["caps"]["action_weights"]
    data["env"]["sideslip_weight"] = 6.0
    c = TrainConfig.from_dict(data)
    assert c.env.delay_ms == [80.0, 120.0] and c.env.pitch_weight == 1.0 and c.env.roll_weight == 1.0
    assert c.caps.action_weights == [1.0, 1.0, 1.0, 1.0] and c.env.sideslip_weight == 6.0
    c.caps.action_weights[0] = 0.5  # a config's list is its own, not the table's
    assert LEGACY_VALUES["caps.action_weights"] == [1.0, 1.0, 1.0, 1.0]


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
    assert done.returncode == 0
    for option in ("--resume", "--seed", "--optim.lr", "--caps.kappa_spatial", "--collector.total_frames"):
        assert option in done.stdout


def test_train_script_records_each_session_for_the_shipped_record(tmp_path):
    script = _script("train_torchrl")
    tiny = ["--seed", "3", "--env.num_envs", "4", "--collector.frames_per_batch", "32",
            "--collector.init_random_frames", "64", "--buffer.capacity", "5000", "--buffer.batch_size", "16",
            "--network.lstm_hidden", "8", "--network.mlp_hidden", "16", "--log.eval_every_frames", "96",
            "--log.eval_episodes", "2", "--log.eval_max_steps", "10", "--log.checkpoint_every_frames", "96",
            "--log.log_every_frames", "32", "--log.progress", "false", "--log.run_root", str(tmp_path),
            "--run-name", "run"]
    assert script.main([*tiny, "--collector.total_frames", "96"]) == 0
    run = tmp_path / "run"
    assert script.main(["--resume", str(run), "--collector.total_frames", "128"]) == 0
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


def test_a_second_trainer_on_a_live_run_is_refused(tmp_path):
    run = tmp_path / "run"
    first = Trainer(tiny_config(96), run)
    with pytest.raises(RunLockedError, match="another process"):
        Trainer(tiny_config(96), run, resume=True)
    del first  # the lock goes with the trainer
    import gc

    gc.collect()


def test_training_summary_finds_the_steps_to_90_percent_of_the_final_return(tmp_path):
    from training.trainer import CSV_FIELDS

    script = _script("plot_training")
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


def test_a_run_trains_in_its_turbulence_and_delay_and_evaluates_in_specs(tmp_path):
    c = tiny_config()
    c.env.turbulence_sigma_mps, c.env.delay_ms = 1.0, [40.0, 100.0]
    trainer = Trainer(c, tmp_path / "run")
    assert trainer.task_config.core.turbulence_sigma_mps == 1.0 and trainer.task_config.core.delay_s == (0.04, 0.1)
    assert trainer.eval_task_config.core == CoreConfig()
    assert trainer.eval_task_config.integral_trim == trainer.task_config.integral_trim
    c.env.delay_ms = [40.0]
    with pytest.raises(ValueError, match="delay_ms must be two numbers"):
        Trainer(c, tmp_path / "bad")
    c.env.disturbances = False  # the ideal setting stays ideal, in training and in its evaluation
    c.env.delay_ms = [40.0, 100.0]
    ideal = Trainer(c, tmp_path / "ideal")
    assert ideal.task_config.core == ideal.eval_task_config.core == CoreConfig.ideal()


def test_the_paper_preset_is_spec_section_3():
    paper = TrainConfig.preset("paper")
    assert not paper.optim.auto_alpha and paper.optim.alpha == 0.2 and paper.optim.updates_per_step == 1.0
    assert paper.buffer.relabel_fraction == 0.0 and paper.env.error_integral_decay == 0.0
    assert paper.env.integral_trim == 0.0 and paper.env.sideslip_weight == 1.0 and paper.env.rudder_trim_s == 0.0
    assert paper.env.roll_weight == 1.0 and paper.env.pitch_weight == 1.0 and paper.caps.action_weights == [1.0] * 4
    assert paper.env.external_throttle == 0.0 and paper.env.penalty_tail == 0.0 and paper.env.trims_in_surfaces
    assert (paper.optim.lr, paper.optim.gamma, paper.optim.tau, paper.buffer.batch_size) == (3e-4, 0.99, 0.005, 256)
    assert (paper.caps.kappa_spatial, paper.caps.kappa_temporal, paper.network.lstm_hidden) == (2.0, 1.0, 64)
    assert paper.env.delay_ms == [80.0, 120.0] and paper.env.turbulence_sigma_mps == 0.5
    assert paper.optim.lr_end_fraction == 1.0
    with pytest.raises(ValueError, match="unknown preset"):
        TrainConfig.preset("fast")


def test_a_run_with_state_critics_and_error_integrals_trains_and_resumes(tmp_path):
    """The asymmetric critics read the stored critics' state; the actor still reads its window."""
    c = tiny_config(128)
    c.network.critic = "state"
    c.env.error_integral_decay = 0.99
    run = tmp_path / "run"
    Trainer(c, run).train()
    data = load_checkpoint(run / "checkpoint.pt")
    stored = data["buffer"]["data"]
    assert stored["state"].shape[-1] == TaskConfig(error_integral_decay=0.99).critic_state_size
    assert stored["observation"].shape[-1] == TaskConfig(error_integral_decay=0.99).observation_size
    c.collector.total_frames = 192
    assert int(Trainer(c, run, resume=True).train()["frames"]) == 192


def test_the_learning_rate_schedule_falls_linearly_and_resumes_where_it_stood(tmp_path):
    """lr_end_fraction: constant until the first update, linear to the fraction at total_frames,
    and a function of the frame count, so a resumed run's rates are the uninterrupted run's."""
    assert lr_factor(64, 64, 192, 0.1) == 1.0 and lr_factor(10_000, 64, 192, 1.0) == 1.0
    assert lr_factor(128, 64, 192, 0.1) == pytest.approx(0.55)
    assert lr_factor(192, 64, 192, 0.1) == pytest.approx(0.1) == lr_factor(400, 64, 192, 0.1)
    c = tiny_config(128)
    c.optim.lr_end_fraction = 0.2
    run = tmp_path / "run"
    Trainer(c, run).train()
    c.collector.total_frames = 192
    resumed = Trainer(c, run, resume=True)
    # The first run ended its own schedule at 0.2 of the rates; resumed to 192 frames the schedule
    # stretches and ends at 0.2 again, of the configured rates (of the loaded ones it would be 0.04).
    resumed.train()
    network_lrs = [g["lr"] for g in resumed.sac.optimizer.param_groups[:-1]]
    assert network_lrs == [pytest.approx(c.optim.lr * 0.2)] * len(network_lrs)
    assert resumed.sac.optimizer.param_groups[-1]["lr"] == c.optim.lr  # the temperature's
    for bad in (0.0, -0.5, 1.5, float("nan")):
        c.optim.lr_end_fraction = bad
        with pytest.raises(ValueError, match="lr_end_fraction"):
            Trainer(c, tmp_path / "bad")

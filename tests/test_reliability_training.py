"""Training runs: re-running a command never overwrites a run, interrupted runs keep their best
policy and leave nothing behind, settings out of range and unwritable folders end with one line.
One test (or a few) per case of docs/reliability.md's table about training runs."""

from __future__ import annotations

import argparse
import csv
import dataclasses
import errno
import gc
import json
import shutil
import typing
from pathlib import Path

import pytest

import training.trainer as trainer_module
from training.checkpoint import CheckpointError, checked_load, load_checkpoint
from training.config import TrainConfig
from training.trainer import Trainer


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, tiny_config):
    """A run folder trained for 96 steps (checkpoint and best policy); copy it before changing it."""
    run = tmp_path_factory.mktemp("reliability_training") / "run"
    Trainer(tiny_config(96), run).train()
    return run


def _copy_run(src: Path, root: Path, name: str = "run") -> Path:
    dst = root / name
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns(".lock"))
    return dst


def _frames(run: Path) -> list[int]:
    return [int(r["frames"]) for r in csv.DictReader((run / "progress.csv").open())]


def _errors(capsys, prefix: str = "train_torchrl:") -> tuple[list[str], str]:
    """The script's own lines on stderr (TorchRL's log lines apart), and the whole of stderr."""
    err = capsys.readouterr().err
    return [line for line in err.splitlines() if line.startswith(prefix)], err


def _snapshot(run: Path, names=("config.json", "checkpoint.pt", "best_policy.pt", "progress.csv")) -> dict:
    return {n: (run / n).read_bytes() for n in names if (run / n).exists()}


# ---------------------------------------------------------------------- 1, 4, 9: a run folder used again
def test_a_run_name_used_again_without_resume_is_refused_and_the_run_kept(tmp_path, capsys, load_script, tiny_args):
    script = load_script("train_torchrl")
    common = [*tiny_args(96, seed=None), "--log.run_root", str(tmp_path), "--run-name", "r"]
    assert script.main(["--seed", "3", *common]) == 0
    run = tmp_path / "r"
    before = _snapshot(run)
    assert set(before) == {"config.json", "checkpoint.pt", "best_policy.pt", "progress.csv"}
    capsys.readouterr()
    assert script.main(["--seed", "4", *common]) == 2
    lines, err = _errors(capsys)
    assert lines == [(f"train_torchrl: {run} already holds a run (checkpoint.pt, best_policy.pt): go on with it with "
                     f"--resume {run}, or start afresh under another --run-name")]
    assert "Traceback" not in err
    assert _snapshot(run) == before  # nothing rewritten, replaced or appended
    assert len((run / "sessions.jsonl").read_text().splitlines()) == 1


def test_a_folder_that_is_not_a_run_is_never_cleared_for_a_new_one(tmp_path, capsys, load_script, tiny_args):
    """A run name that falls on a folder of other files (a config.json of something else, a tb/ of
    the user's) is refused; nothing in it is removed."""
    script = load_script("train_torchrl")
    folder = tmp_path / "proj"
    (folder / "tb").mkdir(parents=True)
    (folder / "tb" / "notes.txt").write_text("mine")
    (folder / "config.json").write_text("{}")
    assert script.main([*tiny_args(96, seed=5), "--log.run_root", str(tmp_path), "--run-name", "proj"]) == 2
    lines, _ = _errors(capsys)
    assert len(lines) == 1 and "no run of this package" in lines[0] and "another --run-name" in lines[0]
    assert (folder / "tb" / "notes.txt").read_text() == "mine" and (folder / "config.json").read_text() == "{}"


def test_a_run_stopped_before_its_first_checkpoint_says_so_and_starts_afresh_under_its_name(
        tmp_path, capsys, load_script, tiny_args, tiny_run):
    """A kill during the first checkpoint write leaves config.json, the logs and a temporary: --resume
    says what to do, and the same command as before starts the run afresh, replacing its logs."""
    script = load_script("train_torchrl")
    run = _copy_run(tiny_run, tmp_path)
    (run / "checkpoint.pt").unlink()
    (run / "best_policy.pt").unlink()
    (run / ".checkpoint.pt.k1ll3d_x").write_bytes(b"half a checkpoint")
    (run / "sessions.jsonl").write_text(json.dumps({"command": "python scripts/train_torchrl.py --seed 3 --run-name "
                                                               "run", "frames_at_start": 0}) + "\n")
    assert script.main(["--resume", str(run)]) == 2
    lines, _ = _errors(capsys)
    assert len(lines) == 1 and lines[0].startswith(f"train_torchrl: {run} has no checkpoint: the run stopped before "
                                                   "its first one")
    assert "start it afresh" in lines[0] and "--run-name run" in lines[0] and "delete the folder" in lines[0]
    # Started afresh under its name: a new run, its logs and sessions from the start.
    assert script.main([*tiny_args(96, seed=5), "--log.run_root", str(tmp_path), "--run-name", "run"]) == 0
    lines, _ = _errors(capsys)
    assert any("stopped before its first checkpoint; starting it afresh" in line for line in lines)
    assert json.loads((run / "config.json").read_text())["seed"] == 5
    assert _frames(run) == [32, 64, 96]
    assert len((run / "sessions.jsonl").read_text().splitlines()) == 1
    assert not (run / ".checkpoint.pt.k1ll3d_x").exists()
    # A folder that holds a best policy but no checkpoint is not started afresh over it.
    (run / "checkpoint.pt").unlink()
    policy = (run / "best_policy.pt").read_bytes()
    assert script.main([*tiny_args(96, seed=6), "--log.run_root", str(tmp_path), "--run-name", "run"]) == 2
    lines, _ = _errors(capsys)
    assert len(lines) == 1 and "best_policy.pt" in lines[0] and "another --run-name" in lines[0]
    assert (run / "best_policy.pt").read_bytes() == policy


def test_the_multi_seed_command_again_resumes_and_nothing_overwrites_its_runs(tmp_path, capsys, load_script,
                                                                              tiny_args):
    script = load_script("train_torchrl")
    command = ["--seeds", "3", "--run-name", "base", "--log.run_root", str(tmp_path), *tiny_args(96, seed=None)]
    assert script.main(command) == 0
    run = tmp_path / "base_seed3"
    before = _snapshot(run)
    assert script.main(command) == 0  # resumes: already at its length, nothing rewritten
    assert _snapshot(run) == before
    sessions = [json.loads(line) for line in (run / "sessions.jsonl").read_text().splitlines()]
    assert [s["frames_at_start"] for s in sessions] == [0, 96]
    capsys.readouterr()
    # A single run under the seed's folder name is refused ...
    assert script.main(["--seed", "3", "--run-name", "base_seed3", "--log.run_root", str(tmp_path),
                        *tiny_args(96, seed=None)]) == 2
    assert "already holds a run" in _errors(capsys)[0][0]
    # ... and so is the multi-seed command with other settings (the learning rate and length may change),
    assert script.main([*command, "--optim.gamma", "0.9"]) == 2
    assert "other settings: optim.gamma (0.99 in the checkpoint, 0.9 now)" in _errors(capsys)[0][0]
    # and --resume with --run-name (the run goes on in its own folder).
    assert script.main(["--resume", str(run), "--run-name", "other"]) == 2
    assert _errors(capsys)[0] == [("train_torchrl: --run-name is not used with --resume: the run goes on in its own "
                                  "folder")]
    assert _snapshot(run) == before and not (tmp_path / "other").exists()


# ---------------------------------------------------------------------- 8: run names
@pytest.mark.parametrize("name", ["../../x", "a/b", ".", "..", "", "ABSOLUTE"])
@pytest.mark.parametrize("seeds", [False, True])
def test_a_run_name_that_is_not_a_plain_folder_name_is_refused(name, seeds, tmp_path, capsys, load_script, tiny_args):
    root = tmp_path / "a" / "root"
    name = str(tmp_path / "abs") if name == "ABSOLUTE" else name  # an absolute path, kept inside the test's folder
    args = [*tiny_args(96, seed=None if seeds else 3), "--log.run_root", str(root), "--run-name", name]
    assert load_script("train_torchrl").main([*args, "--seeds", "3"] if seeds else args) == 2
    lines, _ = _errors(capsys)
    assert lines == [(f"train_torchrl: --run-name must be a plain folder name (not empty, '.' or '..', no '/'), "
                     f"got {name!r}")]
    assert not any(p.is_file() for p in tmp_path.rglob("*"))


# ---------------------------------------------------------------------- 2: the best policy's own score
def test_resume_never_replaces_the_best_policy_by_a_lower_score(tmp_path, tiny_config, monkeypatch):
    """SIGKILL after a best-policy save and before the next checkpoint: the checkpoint is older than
    best_policy.pt, so the best score must come from best_policy.pt itself."""
    scores = iter([0.3, 0.8, 0.5, 0.9])
    evaluated = []

    def fake_evaluation(policy, task_config, episodes=8, max_steps=500, window=8, seed=0, stop=None):
        evaluated.append(next(scores))
        return {"return_norm": evaluated[-1], "length": 500.0, "early_ends": 0, "episodes": episodes}

    monkeypatch.setattr(trainer_module, "evaluate_policy", fake_evaluation)

    def config(total):
        c = tiny_config(total)
        c.collector.init_random_frames = 32
        return c

    run = tmp_path / "run"
    Trainer(config(64), run).train()  # evaluation at its end (0.3) and checkpoint at 64
    older = tmp_path / "checkpoint_at_64.pt"
    shutil.copyfile(run / "checkpoint.pt", older)
    Trainer(config(96), run, resume=True).train()  # evaluation at 96: 0.8, best policy, checkpoint at 96
    assert checked_load(run / "best_policy.pt")["evaluation"]["return_norm"] == 0.8
    shutil.copyfile(older, run / "checkpoint.pt")  # killed before the checkpoint at 96 was written
    resumed = Trainer(config(96), run, resume=True)
    assert resumed.counters.best_eval == 0.8
    resumed.train()  # evaluation at 96 again: 0.5 < 0.8
    policy = checked_load(run / "best_policy.pt")
    assert evaluated == [0.3, 0.8, 0.5] and policy["evaluation"]["return_norm"] == 0.8
    del resumed  # its lock on the folder goes with it
    gc.collect()
    Trainer(config(192), run, resume=True).train()  # a better one still replaces it
    assert checked_load(run / "best_policy.pt")["evaluation"]["return_norm"] == 0.9


def test_a_damaged_best_policy_stops_the_resume_naming_it(tmp_path, tiny_config, tiny_run):
    run = _copy_run(tiny_run, tmp_path)
    (run / "best_policy.pt").write_bytes(b"garbage")
    with pytest.raises(CheckpointError, match="best_policy.pt is damaged") as err:
        Trainer(tiny_config(192), run, resume=True)
    assert "\n" not in str(err.value) and "move it away" in str(err.value)


# ---------------------------------------------------------------------- 3: temporaries of killed writes
def test_stale_temporaries_are_removed_on_resume_and_at_the_end_of_training(tmp_path, tiny_config, tiny_run):
    run = _copy_run(tiny_run, tmp_path)
    stale = [".checkpoint.pt.ab12cd_3", ".best_policy.pt.zzzzzzzz", "progress.csv.tmp"]
    kept = [".checkpoint.pt.notes.txt", "checkpoint.pt.bak", ".other.abcdefgh", ".checkpoint.pt.abc"]
    for name in stale + kept:
        (run / name).write_bytes(b"x")
    trainer = Trainer(tiny_config(128), run, resume=True)
    assert [n for n in stale if (run / n).exists()] == [] and all((run / n).exists() for n in kept)
    (run / ".checkpoint.pt.9x8y7w6v").write_bytes(b"x")  # as a writer killed while this one trained would leave
    trainer.train()
    assert not (run / ".checkpoint.pt.9x8y7w6v").exists() and all((run / n).exists() for n in kept)


# ---------------------------------------------------------------------- 5: a torn progress log
def test_a_torn_last_row_of_the_progress_log_is_dropped_on_resume(tmp_path, tiny_config, tiny_run):
    run = _copy_run(tiny_run, tmp_path)
    with (run / "progress.csv").open("ab") as fh:
        fh.write(b"12")  # a partial row, then what power loss leaves: zeros
        fh.write(b"\0" * 300)
    trainer = Trainer(tiny_config(192), run, resume=True)
    assert _frames(run) == [32, 64, 96]
    assert any("progress.csv" in note and "unreadable" in note for note in trainer.notes)
    trainer.train()
    assert _frames(run) == [32, 64, 96, 128, 160, 192]
    del trainer  # its lock on the folder goes with it
    gc.collect()
    # Nothing but zeros (power loss before the header reached the disk): a new log.
    (run / "progress.csv").write_bytes(b"\0" * 100)
    Trainer(tiny_config(224), run, resume=True)
    assert (run / "progress.csv").read_text().splitlines() == [",".join(trainer_module.CSV_FIELDS)]


def test_an_unreadable_progress_log_is_named_on_resume(tmp_path, capsys, load_script, tiny_run):
    run = _copy_run(tiny_run, tmp_path)
    (run / "progress.csv").unlink()
    (run / "progress.csv").mkdir()
    assert load_script("train_torchrl").main(["--resume", str(run)]) == 2
    lines, err = _errors(capsys)
    assert len(lines) == 1 and str(run / "progress.csv") in lines[0] and "Traceback" not in err


# ---------------------------------------------------------------------- 6: settings out of range
NAN, INF = float("nan"), float("inf")
OUT_OF_RANGE = [
    ("optim.updates_per_step", NAN), ("optim.updates_per_step", -1.0), ("optim.updates_per_step", 0.0),
    ("optim.updates_per_step", INF), ("caps.batch_size", 0), ("optim.gamma", 1.5), ("optim.gamma", 1.0),
    ("optim.gamma", -0.1), ("log.eval_episodes", 0), ("buffer.relabel_fraction", 2.0),
    ("buffer.relabel_fraction", -0.5), ("optim.alpha", NAN), ("optim.alpha", 0.0), ("buffer.batch_size", 0),
    ("buffer.capacity", 0), ("log.checkpoint_every_frames", 0), ("env.num_envs", 0), ("optim.lr", INF),
    ("optim.lr", 0.0), ("optim.lr", -3e-4), ("optim.tau", NAN), ("optim.tau", 0.0), ("optim.tau", 1.5),
    ("optim.target_entropy", INF), ("optim.target_entropy", NAN), ("caps.kappa_spatial", -0.1),
    ("caps.kappa_temporal", NAN), ("caps.kappa_spatial", INF), ("caps.sigma_spatial", 0.0),
    ("caps.sigma_spatial", NAN), ("caps.action_weights", [1.0, 1.0, 1.0]), ("caps.action_weights", [1, NAN, 1, 1]),
    ("caps.action_weights", [1, -1, 1, 1]), ("collector.total_frames", -5), ("collector.frames_per_batch", 0),
    ("collector.init_random_frames", -1), ("network.lstm_hidden", 0), ("network.mlp_hidden", -3),
    ("log.log_every_frames", 0), ("log.eval_every_frames", 0), ("threads", -1), ("seed", -1), ("seed", 2**64),
    ("log.run_root", ""), ("device", "gpu"), ("device", "cuda:x"), ("device", "meta"),
]


def _setting(name: str, value) -> dict:
    group, _, key = name.rpartition(".")
    return {group: {key: value}} if group else {key: value}


@pytest.mark.parametrize(("name", "value"), OUT_OF_RANGE)
def test_a_setting_out_of_its_range_is_refused_naming_it_and_its_range(name, value):
    with pytest.raises(ValueError) as err:
        TrainConfig.from_dict(_setting(name, value))
    text = str(err.value)
    assert text.startswith(f"{name} must be ") and "\n" not in text and f"got {value!r}" in text


@pytest.mark.parametrize(("data", "named"), [
    ({"env": {"num_envs": "x"}}, "env.num_envs"), ({"env": {"num_envs": 2.5}}, "env.num_envs"),
    ({"env": {"num_envs": True}}, "env.num_envs"), ({"optim": {"auto_alpha": "yes"}}, "optim.auto_alpha"),
    ({"buffer": {"relabel_fraction": "0.5"}}, "buffer.relabel_fraction"), ({"seed": None}, "seed"),
    ({"caps": {"action_weights": "1 1 1 1"}}, "caps.action_weights"), ({"env": {"task": 1}}, "env.task"),
    ({"env": 5}, "env"), ({"log": [1]}, "log"),
])
def test_a_setting_of_the_wrong_type_is_refused_naming_it(data, named):
    with pytest.raises(ValueError) as err:
        TrainConfig.from_dict(data)
    assert str(err.value).startswith(f"{named} must be ") and "\n" not in str(err.value)


def test_a_configuration_that_is_not_an_object_is_refused():
    with pytest.raises(ValueError, match="a JSON object"):
        TrainConfig.from_dict([1, 2])


def test_every_setting_has_its_allowed_range_next_to_it():
    """A setting without a range cannot be added: the module checks on import, this says so too."""
    from training.config import allowed_values

    names = []
    hints = typing.get_type_hints(TrainConfig)
    for f in dataclasses.fields(TrainConfig):
        if dataclasses.is_dataclass(hints[f.name]):
            names += [f"{f.name}.{g.name}" for g in dataclasses.fields(hints[f.name])]
        else:
            names.append(f.name)
    ranges = allowed_values()
    assert sorted(ranges) == sorted(names) and all(ranges.values())
    TrainConfig().validate()  # the defaults are inside their ranges
    TrainConfig.from_dict({"optim": {"updates_per_step": 1}, "buffer": {"relabel_fraction": 0}})  # ints for floats


def test_frames_per_batch_below_the_number_of_aircraft_is_refused_with_the_configuration(tmp_path, tiny_config):
    with pytest.raises(ValueError, match=r"collector.frames_per_batch \(2\) must be at least env.num_envs \(4\)"):
        TrainConfig.from_dict({"env": {"num_envs": 4}, "collector": {"frames_per_batch": 2}})
    c = tiny_config()
    c.optim.gamma = 1.5  # set after construction: the trainer checks again
    with pytest.raises(ValueError, match=r"optim.gamma must be "):
        Trainer(c, tmp_path / "never")
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize(("option", "value", "line"), [
    ("--optim.updates_per_step", "nan", "optim.updates_per_step must be a finite number > 0, got nan"),
    ("--optim.gamma", "1.5", "optim.gamma must be a finite number in [0, 1), got 1.5"),
    ("--caps.batch_size", "0", "caps.batch_size must be an integer >= 1, got 0"),
    ("--device", "gpu", "device must be cpu, cuda or cuda:N, got 'gpu'"),
])
def test_the_script_refuses_a_setting_out_of_range_with_one_line(option, value, line, tmp_path, capsys, load_script,
                                                                 tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r",
                                              option, value])
    lines, err = _errors(capsys)
    assert code == 2 and lines == [f"train_torchrl: {line}"] and "Traceback" not in err
    assert not (tmp_path / "r").exists()


def test_a_device_that_is_not_here_is_refused_with_one_line(tmp_path, capsys, load_script, tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--device", "cuda:99"])
    lines, err = _errors(capsys)
    assert code == 2 and len(lines) == 1 and lines[0].startswith("train_torchrl: device cuda:99 is not available")
    assert "--device cpu" in lines[0] and "Traceback" not in err


@pytest.mark.parametrize(("text", "named"), [("{not json", "is not valid JSON"),
                                             ('{"env": {"num_envs": "x"}}', "env.num_envs must be"),
                                             ("[1, 2]", "a JSON object"), (b"\xff\xfe\0", "is not valid JSON")])
def test_resume_with_a_broken_config_json_names_the_file(text, named, tmp_path, capsys, load_script):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_bytes(text if isinstance(text, bytes) else text.encode())
    assert load_script("train_torchrl").main(["--resume", str(run)]) == 2
    lines, err = _errors(capsys)
    assert len(lines) == 1 and str(run / "config.json") in lines[0] and named in lines[0] and "Traceback" not in err


def test_bad_seeds_and_workers_are_refused_with_one_line(tmp_path, capsys, load_script, tiny_args):
    script = load_script("train_torchrl")
    base = ["--run-name", "b", "--log.run_root", str(tmp_path), *tiny_args(96, seed=None)]
    assert script.main(["--seeds", "1,x", *base]) == 2
    assert _errors(capsys)[0] == ["train_torchrl: --seeds must be comma-separated integers, got '1,x'"]
    assert script.main(["--seeds", "-1", *base]) == 2
    assert _errors(capsys)[0][0].startswith("train_torchrl: seed must be an integer in [0, ")
    with pytest.raises(SystemExit) as stopped:  # refused by the parser itself
        script.main(["--seeds", "1", "--workers", "0", *base])
    assert stopped.value.code == 2
    assert _errors(capsys)[0] == ["train_torchrl: --workers must be in [1, 1024], got 0"]
    assert not any(tmp_path.iterdir())


# ---------------------------------------------------------------------- 7: an unwritable run folder
# Tests run as root, where a read-only folder still takes writes: the writers are made to fail as
# the operating system makes them fail (PermissionError, ENOSPC), or the folder is really removed.
def test_a_checkpoint_that_cannot_be_written_ends_with_one_line_naming_the_folder(tmp_path, capsys, load_script,
                                                                                  tiny_args, monkeypatch):
    run = tmp_path / "r"
    real_save = trainer_module.save_checkpoint
    calls = []

    def save_then_refuse(path, state, fingerprint):
        calls.append(path)
        if len(calls) == 1:
            return real_save(path, state, fingerprint)
        raise PermissionError(errno.EACCES, "Permission denied", str(run / ".checkpoint.pt.q1w2e3r4"))

    monkeypatch.setattr(trainer_module, "save_checkpoint", save_then_refuse)
    code = load_script("train_torchrl").main([*tiny_args(192), "--log.run_root", str(tmp_path), "--run-name", "r"])
    lines, err = _errors(capsys)
    assert code == 1 and "Traceback" not in err
    assert lines[-1] == (f"train_torchrl: cannot write to the run folder {run} at 192 env steps (Permission denied: "
                         f"{run / '.checkpoint.pt.q1w2e3r4'}); its last checkpoint is at 96 env steps: once the folder "
                         f"can be written, go on with --resume {run}")
    assert load_checkpoint(run / "checkpoint.pt")["counters"]["frames"] == 96


def test_a_progress_log_that_cannot_be_written_ends_with_one_line(tmp_path, capsys, load_script, tiny_args,
                                                                  monkeypatch):
    real_writerow = csv.DictWriter.writerow
    rows = []

    def writerow_then_full(self, row):
        rows.append(row)
        if len(rows) > 2:  # the header and one row, then the disk is full
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_writerow(self, row)

    monkeypatch.setattr(csv.DictWriter, "writerow", writerow_then_full)
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r"])
    lines, err = _errors(capsys)
    assert code == 1 and "Traceback" not in err
    assert lines[-1] == (f"train_torchrl: cannot write to the run folder {tmp_path / 'r'} at 64 env steps (No space "
                         "left on device); it has no checkpoint yet: once the folder can be written, start it afresh")


def test_a_run_folder_removed_during_training_ends_with_one_line(tmp_path, capsys, load_script, tiny_args,
                                                                 monkeypatch):
    run = tmp_path / "r"

    def remove_the_folder(*args, **kwargs):
        shutil.rmtree(run)
        return {"return_norm": 0.5, "length": 500.0, "early_ends": 0, "episodes": 1}

    monkeypatch.setattr(trainer_module, "evaluate_policy", remove_the_folder)
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r"])
    lines, err = _errors(capsys)
    assert code == 1 and "Traceback" not in err
    assert lines[-1].startswith(f"train_torchrl: the run folder {run} was removed or replaced during training, at 96 "
                                "env steps")
    assert not run.exists()  # not made again by the checkpoint's writer


# ---------------------------------------------------------------------- the soak
def test_the_soaks_step_count_skips_a_torn_row(tmp_path, load_script):
    soak = load_script("soak_train")
    (tmp_path / "progress.csv").write_bytes(b"frames,updates\r\n32,0\r\n64,8\r\n\0\0\0\0\0")
    assert soak.frames_done(tmp_path) == 64
    (tmp_path / "progress.csv").write_bytes(b"frames,upd")
    assert soak.frames_done(tmp_path) == 0


def test_the_soak_moves_a_run_stopped_before_its_first_checkpoint_aside(tmp_path, load_script):
    soak = load_script("soak_train")
    args = argparse.Namespace(out=tmp_path, frames=1000, capacity=100, updates_per_step=0.02, seed=0)
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text("{}")
    (run / "best_policy.pt").write_bytes(b"x")
    (tmp_path / "memory.csv").write_text("wall_s,frames,rss_mib\n1,9000,500\n")
    cmd, fresh = soak.training_command(args, run)
    assert fresh and "--run-name" in cmd and "--resume" not in cmd
    assert not run.exists() and not (tmp_path / "memory.csv").exists()
    (aside,) = [p for p in tmp_path.iterdir() if p.name.startswith("run.stopped-")]
    assert (aside / "best_policy.pt").exists() and (aside / "memory.csv").exists()
    run.mkdir()
    (run / "checkpoint.pt").write_bytes(b"x")
    cmd, fresh = soak.training_command(args, run)
    assert not fresh and cmd[:2] == ["--resume", str(run)]


def test_the_soak_never_overwrites_the_samples_of_an_earlier_soak(tmp_path, load_script):
    """A finished soak whose run folder was removed (its checkpoint is large) keeps its memory
    samples: the same command again is refused instead of starting a new memory.csv over them."""
    soak = load_script("soak_train")
    args = argparse.Namespace(out=tmp_path, frames=1000, capacity=100, updates_per_step=0.02, seed=0)
    (tmp_path / "memory.csv").write_text("wall_s,frames,rss_mib\n1,9000,500\n")
    with pytest.raises(soak.OutputFolderError, match="earlier soak"):
        soak.training_command(args, tmp_path / "run")
    assert (tmp_path / "memory.csv").read_text() == "wall_s,frames,rss_mib\n1,9000,500\n"

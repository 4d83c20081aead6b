"""Training runs, third pass: a diverged update never replaces the last good checkpoint, the
progress log keeps every row it can read, a finished run always has its best policy, full disks
and folders in a checkpoint's place end in one line, settings have upper bounds, and a stop request
is honoured at once. One test (or a few) per case of docs/reliability.md's table about training runs."""

from __future__ import annotations

import csv
import errno
import gc
import io
import os
import signal
import time

import pytest

import training.trainer as trainer_module
from training.checkpoint import CheckpointError, checked_load, load_checkpoint
from training.config import TrainConfig
from training.progress_log import read_progress
from training.trainer import Trainer


def _errors(capsys, prefix: str = "train_torchrl:") -> tuple[list[str], str]:
    """The script's own lines on stderr (TorchRL's log lines apart), and the whole of stderr."""
    err = capsys.readouterr().err
    return [line for line in err.splitlines() if line.startswith(prefix)], err


# ---------------------------------------------------------------------- a diverged update
def test_a_diverged_update_stops_in_one_line_and_keeps_the_last_good_checkpoint(tmp_path, capsys, load_script,
                                                                                 tiny_args):
    script = load_script("train_torchrl")
    run = tmp_path / "r"
    # Learning starts after 64 random steps; the checkpoint at 64 is the last one before the updates.
    code = script.main([*tiny_args(192), "--log.checkpoint_every_frames", "32", "--optim.lr", "1e30",
                        "--log.run_root", str(tmp_path), "--run-name", "r"])
    lines, err = _errors(capsys)
    assert code == 1 and "Traceback" not in err and len(lines) == 1
    assert lines[0].startswith("train_torchrl: training diverged at 96 env steps (update ")
    assert "NaN or infinite" in lines[0] and "loss_qvalue" in lines[0]
    assert lines[0].endswith(f"its last good checkpoint (64 env steps) is kept: go on from it with a lower learning "
                             f"rate, e.g. --resume {run} --optim.lr 0.0003")
    assert load_checkpoint(run / "checkpoint.pt")["counters"]["frames"] == 64  # whole, finite, resumable
    # As the line says: resumed with a lower learning rate, the run goes on to its end, and the next
    # resume keeps that rate.
    assert script.main(["--resume", str(run), "--optim.lr", "0.0003"]) == 0
    saved = load_checkpoint(run / "checkpoint.pt")
    assert saved["counters"]["frames"] == 192 and saved["config"]["optim"]["lr"] == 0.0003
    assert '"lr": 0.0003' in (run / "config.json").read_text()


def test_a_diverged_update_before_the_first_checkpoint_writes_none(tmp_path, tiny_config):
    c = tiny_config(192)
    c.optim.lr = 1e30
    with pytest.raises(trainer_module.TrainingDiverged, match="it has no checkpoint yet: start it again with a "
                                                              "lower learning rate"):
        Trainer(c, tmp_path / "r").train()
    assert not (tmp_path / "r" / "checkpoint.pt").exists() and not (tmp_path / "r" / "best_policy.pt").exists()


def test_non_finite_weights_are_never_written(tmp_path, tiny_config):
    trainer = Trainer(tiny_config(96), tmp_path / "r")
    with pytest.raises(trainer_module.TrainingDiverged, match="critics.0.*NaN or infinite"):
        next(trainer.sac.critics[0].parameters()).data[0] = float("nan")
        trainer.save()
    assert not trainer.checkpoint_path.exists()


# ---------------------------------------------------------------------- a changed setting on --resume
def test_a_changed_setting_on_resume_is_named(tmp_path, tiny_config):
    run = tmp_path / "r"
    Trainer(tiny_config(96), run).train()
    other = tiny_config(192)
    other.optim.gamma, other.network.mlp_hidden = 0.9, 32
    with pytest.raises(CheckpointError) as err:
        Trainer(other, run, resume=True)
    text = str(err.value)
    assert "network.mlp_hidden (16 in the checkpoint, 32 now); optim.gamma (0.99 in the checkpoint, 0.9 now)" in text
    assert "\n" not in text and "fingerprint" not in text


# ---------------------------------------------------------------------- a damaged progress-log header
def _progress_log(path, rows: int = 33) -> bytes:
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=trainer_module.CSV_FIELDS)
        w.writeheader()
        for i in range(1, rows + 1):
            w.writerow({"frames": 32 * i, "updates": i, "episodes": 2 * i})
    return path.read_bytes()


@pytest.mark.parametrize("byte", [b"\0", b",", b"x", b"\xff", b"\r", b'"'])
def test_one_damaged_byte_in_the_progress_log_header_loses_no_row(tmp_path, byte):
    path = tmp_path / "progress.csv"
    good = _progress_log(path)
    end = good.index(b"\r\n")  # the header's own bytes (its line break apart)
    for position in range(end):
        path.write_bytes(good[:position] + byte + good[position + 1:])
        rows, dropped = read_progress(path, trainer_module.CSV_FIELDS)
        assert (len(rows), dropped) == (33, 0), position
        assert [r["updates"] for r in rows] == [str(i) for i in range(1, 34)], position
        assert list(rows[0]) == list(trainer_module.CSV_FIELDS), position


def test_a_progress_log_of_an_older_layout_is_still_read_by_its_own_header(tmp_path):
    path = tmp_path / "progress.csv"
    path.write_text("frames,wall_s\n32,0.5\n64,1.0\n")
    rows, dropped = read_progress(path, trainer_module.CSV_FIELDS)
    assert rows == [{"frames": "32", "wall_s": "0.5"}, {"frames": "64", "wall_s": "1.0"}] and dropped == 0


def test_resume_keeps_every_row_under_a_damaged_header(tmp_path, tiny_config):
    run = tmp_path / "r"
    Trainer(tiny_config(96), run).train()
    good = (run / "progress.csv").read_bytes()
    (run / "progress.csv").write_bytes(b"fr\0mes" + good[6:])
    resumed = Trainer(tiny_config(192), run, resume=True)
    assert resumed.notes == []
    assert (run / "progress.csv").read_bytes() == good  # the header written again, every row kept


# ---------------------------------------------------------------------- the best policy of a run
def test_a_run_shorter_than_its_evaluation_interval_still_evaluates_at_its_end(tmp_path, capsys, load_script,
                                                                               tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(128), "--log.eval_every_frames", "10000",
                                              "--log.run_root", str(tmp_path), "--run-name", "r"])
    out = capsys.readouterr().out
    best = tmp_path / "r" / "best_policy.pt"
    assert code == 0 and best.is_file() and out.strip().endswith(f"best policy: {best}")
    assert checked_load(best)["evaluation"]["frames"] == 128


def test_the_script_never_names_a_best_policy_that_is_not_there(tmp_path, capsys, load_script, tiny_args,
                                                                 monkeypatch):
    monkeypatch.setattr(Trainer, "save_policy", lambda self, path, evaluation: None)
    assert load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r"]) == 0
    out = capsys.readouterr().out
    assert "best_policy.pt" not in out and "no best policy" in out


# ---------------------------------------------------------------------- a full disk, a folder for a file
def test_a_full_disk_during_a_checkpoint_write_ends_in_one_line_and_keeps_the_last_checkpoint(
        tmp_path, capsys, load_script, tiny_args, monkeypatch):
    """torch's writer reports a failed write as a ``RuntimeError``: the disk's own error is what is told."""
    real_fdopen = os.fdopen
    written = []

    class FullDisk(io.RawIOBase):
        def __init__(self, fh):
            self.fh, self.size = fh, 0

        def writable(self):
            return True

        def write(self, data):
            self.size += len(data)
            if self.size > 4096:
                raise OSError(errno.ENOSPC, "No space left on device")
            return self.fh.write(data)

        def __getattr__(self, name):
            return getattr(self.fh, name)

    def fdopen(fd, *args, **kwargs):
        fh = real_fdopen(fd, *args, **kwargs)
        if ".checkpoint.pt." not in os.readlink(f"/proc/self/fd/{fd}"):
            return fh
        written.append(fd)
        return fh if len(written) == 1 else FullDisk(fh)

    monkeypatch.setattr(os, "fdopen", fdopen)
    run = tmp_path / "r"
    code = load_script("train_torchrl").main([*tiny_args(192), "--log.run_root", str(tmp_path), "--run-name", "r"])
    lines, err = _errors(capsys)
    assert code == 1 and "Traceback" not in err and len(written) == 2
    assert lines[-1] == (f"train_torchrl: cannot write to the run folder {run} at 192 env steps (No space left on "
                         f"device); its last checkpoint is at 96 env steps: once the folder can be written, go on with "
                         f"--resume {run}")
    assert load_checkpoint(run / "checkpoint.pt")["counters"]["frames"] == 96
    assert not [p.name for p in run.iterdir() if p.name.startswith(".checkpoint.pt.")]


@pytest.mark.parametrize("resume", [True, False])
def test_a_checkpoint_that_is_a_folder_is_named_as_one(resume, tmp_path, capsys, load_script, tiny_args):
    run = tmp_path / "r"
    (run / "checkpoint.pt").mkdir(parents=True)
    (run / "config.json").write_text(TrainConfig().to_json())
    command = ["--resume", str(run)] if resume else [*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r"]
    assert load_script("train_torchrl").main(command) == 2
    lines, err = _errors(capsys)
    assert "Traceback" not in err
    assert lines == [(f"train_torchrl: {run / 'checkpoint.pt'} is a folder, not the file a run writes there: move it "
                      "away, then resume from a copy of the run's checkpoint or start the run afresh")]
    with pytest.raises(CheckpointError, match="is a folder"):
        load_checkpoint(run / "checkpoint.pt")


# ---------------------------------------------------------------------- stop requests
def test_a_stop_request_is_honoured_between_two_updates(tmp_path, tiny_config, monkeypatch):
    """A million updates per step: Ctrl-C stops the round at once, and the updates still owed are
    the resumed run's."""
    c = tiny_config(192)
    c.optim.updates_per_step = 1e6
    trainer = Trainer(c, tmp_path / "r")
    real_update = Trainer._update

    def update_then_ctrl_c(self, batch):
        real_update(self, batch)
        if self.counters.updates == 3:
            signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(Trainer, "_update", update_then_ctrl_c)
    start = time.perf_counter()
    with pytest.raises(trainer_module.TrainingInterrupted, match="SIGINT at 96 env steps"):
        trainer.train()
    assert time.perf_counter() - start < 30 and trainer.counters.updates == 3
    saved = load_checkpoint(tmp_path / "r" / "checkpoint.pt")
    assert saved["counters"]["updates"] == 3 and saved["counters"]["update_debt"] == 32e6 - 3
    del trainer
    gc.collect()
    assert Trainer(c, tmp_path / "r", resume=True).counters.update_debt == 32e6 - 3


def test_a_stop_request_ends_an_evaluation_at_its_next_step(tmp_path, tiny_config, monkeypatch):
    trainer = Trainer(tiny_config(96), tmp_path / "r")
    calls, actor = [], trainer.actor

    def policy(td):
        calls.append(1)
        if len(calls) == 3:
            trainer._stop.append(signal.SIGTERM)
        return actor(td)

    monkeypatch.setattr(trainer, "actor", policy)
    assert trainer.evaluate() is None and len(calls) == 3
    assert not (tmp_path / "r" / "best_policy.pt").exists()  # an evaluation cut short keeps nothing


# ---------------------------------------------------------------------- upper bounds
@pytest.mark.parametrize(("option", "value", "line"), [
    ("--buffer.capacity", "1000000000000000", ("buffer.capacity must be an integer in [1, 1000000000], got "
                                               "1000000000000000")),
    ("--network.lstm_hidden", "100000000", "network.lstm_hidden must be an integer in [1, 4096], got 100000000"),
    ("--network.mlp_hidden", "100000", "network.mlp_hidden must be an integer in [1, 4096], got 100000"),
    ("--log.eval_episodes", "100000", "log.eval_episodes must be an integer in [1, 4096], got 100000"),
    ("--env.num_envs", "100000", "env.num_envs must be an integer in [1, 4096], got 100000"),
])
def test_settings_that_size_a_run_have_an_upper_bound(option, value, line, tmp_path, capsys, load_script, tiny_args):
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r",
                                              option, value])
    lines, err = _errors(capsys)
    assert code == 2 and lines == [f"train_torchrl: {line}"] and "Traceback" not in err
    assert not (tmp_path / "r").exists()


def test_a_run_that_needs_more_memory_than_the_machine_has_is_refused_before_any_work(tmp_path, capsys, load_script,
                                                                                     tiny_args, monkeypatch):
    monkeypatch.setattr(trainer_module, "available_memory", lambda: 2**30)
    code = load_script("train_torchrl").main([*tiny_args(96), "--log.run_root", str(tmp_path), "--run-name", "r",
                                              "--buffer.capacity", "1000000"])
    lines, err = _errors(capsys)
    assert code == 2 and len(lines) == 1 and "Traceback" not in err
    assert lines[0].startswith("train_torchrl: the run would need about 1.2") and "(replay buffer 1.2" in lines[0]
    assert "more than the 1 GiB free here: lower --buffer.capacity" in lines[0]
    assert not (tmp_path / "r").exists()

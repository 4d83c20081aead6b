"""Recurrent SAC with CAPS on the solar-UAV attitude environment (the paper's Section 3).

A run folder holds ``config.json``, ``progress.csv``, TensorBoard events (``tb/``), ``checkpoint.pt``
(everything needed to resume: networks, targets, optimisers, replay buffer, counters, random
state) and ``best_policy.pt`` (the best deterministic policy by evaluation return).

A distilling run (``distill.teacher``, one of the aircraft's LQIs) starts the network where that
LQI is instead of from random steps: for ``distill.dagger_frames`` steps the teacher flies a share
of the steps falling from all to none (DAgger) while the actor's mean learns the teacher's action on
every step flown; the network as distilled is kept (``distilled_policy.pt``); the critics alone
then learn its values (``distill.critic_warmup_updates``); and SAC goes on with
``distill.offline_share`` of each batch drawn from the steps the teacher flew (as Ball et al. 2023
keep offline data in every batch) and the teacher's action, labelled on every step, kept in the
actor loss (``distill.bc_weight``, TD3+BC's term), so that fine-tuning does not first unlearn it.

A new run is not started over a folder that holds a run (``checkpoint.pt`` or ``best_policy.pt``):
that one is resumed or left alone. A folder whose run stopped before its first checkpoint, with
neither file, has nothing to resume, and a new run starts afresh in it, replacing its logs.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import math
import os
import re
import shutil
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from aircraft import load_aircraft
from jsbsim_env.control.checked_io import DamagedFileError, checked_load, non_finite_entries
from jsbsim_env.control.gain_files import gain_file
from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import PRIVILEGED_SIZE, TaskConfig, goal_range
from jsbsim_env.task.torchrl_env import make_env
from jsbsim_env.task.versions import task_version
from training.checkpoint import (
    CheckpointError,
    atomic_save,
    config_fingerprint,
    load_checkpoint,
    not_a_file_message,
    save_checkpoint,
)
from training.config import OptimSettings, TrainConfig, check_device
from training.networks import make_actor, make_critic
from training.output_folders import write_text_atomic
from training.progress_log import read_progress
from training.relabel import relabel_goals
from training.runtime import available_memory, check_threads
from training.sac import RecurrentSAC

STORED_KEYS = ("observation", "action", ("next", "observation"), ("next", "reward"), ("next", "done"),
               ("next", "terminated"), ("next", "achieved"))
EVAL_MAX_STEPS = 500  # interactions per evaluation episode during training
DISTILLED_POLICY = "distilled_policy.pt"  # a distilling run's network as distilled, before SAC
# Every evaluated policy, by its env steps (``log.keep_evaluated``), for a choice among them on other
# flights than the training's evaluation (``scripts/heldout.py --checkpoints``).
EVALUATED_DIR = "evaluated"


def evaluated_policy_name(frames: int) -> str:
    """The file name of the policy evaluated at ``frames`` env steps, in ``EVALUATED_DIR``."""
    return f"policy_{frames:08d}.pt"


def stored_keys(task: TaskConfig, privileged: bool = False) -> tuple:
    """What the replay buffer keeps of each transition."""
    return (STORED_KEYS + ((("next", "speed_free"),) if task.external_throttle > 0.0 else ())
            + (("privileged", ("next", "privileged")) if privileged else ()))


CSV_FIELDS = ("frames", "updates", "wall_s", "env_steps_per_s", "episodes", "episode_return", "episode_return_norm",
              "episode_length", "loss_actor", "loss_qvalue", "caps_temporal", "caps_spatial", "alpha", "entropy",
              "eval_return_norm", "eval_length", "eval_early_ends", "loss_imitation")


# What a run folder holds. A folder with either of RUN_FILES holds a run: a new run is not started
# over it. Without them the run stopped before its first checkpoint, and a new run replaces the
# files of LOG_FILES it left.
RUN_FILES = ("checkpoint.pt", "best_policy.pt")
LOG_FILES = ("config.json", "progress.csv", "progress.csv.tmp", "sessions.jsonl", "tb", EVALUATED_DIR)
# ``atomic_save``'s temporary files (``tempfile.mkstemp(prefix=f".{name}.")``: 8 characters of
# [a-z0-9_]), which a process killed while writing leaves behind.
_TEMPORARY = re.compile(r"\.(checkpoint\.pt|best_policy\.pt|policy_[0-9]{8}\.pt)\.[a-z0-9_]{8}")


def _short(value) -> str:
    """A progress-bar figure: three decimals, or blank where there is none yet."""
    return f"{value:.3f}" if isinstance(value, float) and math.isfinite(value) else ""


# A residual's exploration at its start: the pre-tanh standard deviation of its correction (0.3 of
# its authority: about 2 deg on a 30 deg surface with a quarter of the travel).
RESIDUAL_START_STD = 0.3


# Settings a resumed run may change: its length, its learning rate (after a divergence, say), and
# (top-level groups and settings) its logging, device and threads.
RESUME_MAY_CHANGE = ("collector.total_frames", "optim.lr")
RESUME_MAY_CHANGE_GROUPS = ("log", "device", "threads")


def resume_settings(config: TrainConfig) -> dict:
    """The settings that must be the same to resume (``group.name``: value): everything but
    ``RESUME_MAY_CHANGE`` and ``RESUME_MAY_CHANGE_GROUPS``. The aircraft by its model
    (``env.aircraft_model``), not by the path it was given as; the paper's as runs from before the
    setting recorded it (none), so that they resume."""
    flat = {}
    for group, value in config.to_dict().items():
        if group in RESUME_MAY_CHANGE_GROUPS:
            continue
        if isinstance(value, dict):
            flat.update({f"{group}.{k}": v for k, v in value.items()})
        else:
            flat[group] = value
    for name in RESUME_MAY_CHANGE:
        flat.pop(name, None)
    flown = load_aircraft(flat.pop("env.aircraft"))
    if not flown.papers:
        flat["env.aircraft_model"] = flown.fingerprint
    return flat


def resume_fingerprint(config: TrainConfig) -> str:
    """A hash of ``resume_settings``."""
    return config_fingerprint(resume_settings(config))


def changed_settings(saved: dict, current: dict) -> list[str]:
    """``group.name (X in the checkpoint, Y now)`` for each setting of ``resume_settings`` that differs."""
    names = sorted(set(saved) | set(current))
    missing = "(none)"
    return [f"{n} ({saved.get(n, missing)!r} in the checkpoint, {current.get(n, missing)!r} now)"
            for n in names if saved.get(n, missing) != current.get(n, missing)]


# What a run holds in memory, for ``memory_needed``: each simulated aircraft (JSBSim and its windows;
# about 1.1 MB measured, with room), and each network weight (itself, its gradient, Adam's two
# moments, a target copy, the checkpoint's copy).
BYTES_PER_AIRCRAFT = 4 * 2**20
BYTES_PER_WEIGHT = 4 * 6


def memory_needed(config: TrainConfig, observation_size: int, window: int) -> dict[str, int]:
    """Bytes a run needs, roughly, by what needs them: the replay buffer filled to capacity (each
    transition's two observation windows, action, reward, flags, goals, privileged entries), the
    aircraft of training and of evaluation, the actor and the two critics (an LSTM's four gates
    on its input and its state, then the two fully connected layers)."""
    c = config
    privileged = 2 * PRIVILEGED_SIZE if c.network.asymmetric_critic else 0
    transition = 4 * (2 * window * observation_size + 4 + 1 + 4 + 1 + privileged) + 3
    h, m = c.network.lstm_hidden, c.network.mlp_hidden
    weights = 3 * (4 * h * (observation_size + h + 2) + (h + 4) * m + m * m + 8 * m)
    return {"replay buffer": c.buffer.capacity * transition,
            "aircraft": (c.env.num_envs + c.log.eval_episodes) * BYTES_PER_AIRCRAFT,
            "networks": weights * BYTES_PER_WEIGHT}


def check_memory(config: TrainConfig, observation_size: int, window: int) -> None:
    """``ValueError`` (one line) where the run would need more memory than the machine has free."""
    free = available_memory()
    needed = memory_needed(config, observation_size, window)
    if free is None or sum(needed.values()) <= free:
        return
    parts = ", ".join(f"{name} {size / 2**30:.3g} GiB" for name, size in needed.items())
    raise ValueError(f"the run would need about {sum(needed.values()) / 2**30:.3g} GiB of memory ({parts}), more than "
                     f"the {free / 2**30:.3g} GiB free here: lower --buffer.capacity, --env.num_envs, "
                     "--log.eval_episodes or the networks' --network.lstm_hidden and --network.mlp_hidden")


@dataclass
class Counters:
    frames: int = 0
    updates: int = 0
    episodes: int = 0
    wall_s: float = 0.0
    best_eval: float = -math.inf
    # Updates owed to the steps collected (``optim.updates_per_step``) and not yet made: a stop
    # request between two updates of a round leaves them to the resumed run.
    update_debt: float = 0.0
    # A distilling run (``distill.teacher``): whether its critics have been warmed after the distillation.
    critics_warmed: bool = False


class Trainer:
    """Builds the environment, networks, loss, buffer and collector of a run, and trains.

    Args:
        config: the run's settings.
        run_dir: the run folder (created).
        resume: continue from ``run_dir/checkpoint.pt``.
    """

    def __init__(self, config: TrainConfig, run_dir: Path | str, resume: bool = False):
        self.config = c = config
        c.validate()  # settings out of range, or changed since the configuration was made
        # The aircraft as it reads from any folder (a built one by its absolute path), for resuming.
        c.env.aircraft = load_aircraft(c.env.aircraft).spec
        check_device(c.device)
        self.version = version = task_version(c.env.task)
        check_memory(c, version.task.observation_size, version.flight_stack.window_steps)  # before any work
        for needed in filter(None, (version.flight_stack.residual_on, c.distill.teacher)):
            gain_file(needed, c.env.aircraft)  # a residual's base or a teacher: GainsMissing, before any work
        self.run_dir = Path(run_dir)
        self.notes: list[str] = []  # what the run did to its folder that its user should hear of
        if resume and not self.run_dir.is_dir():
            raise CheckpointError(f"no run folder to resume at {self.run_dir}")
        try:
            self.run_dir.mkdir(parents=True, exist_ok=True)
            self._lock = _lock_run_dir(self.run_dir)
        except OSError as err:
            raise RunFolderError(f"cannot write to the run folder {self.run_dir} ({_reason(err)})") from None
        self._folder_id = _identity(self.run_dir)
        self._checkpoint_frames: int | None = None  # steps of the checkpoint in the folder
        if resume and not self.checkpoint_path.is_file():
            raise CheckpointError(not_a_file_message(self.checkpoint_path) or self._no_checkpoint_message())
        if not resume:
            self._start_afresh()
        self.remove_stale_temporaries()
        if c.threads > 0:
            torch.set_num_threads(c.threads)
        check_threads(torch.get_num_threads())
        torch.manual_seed(c.seed)
        self.device = torch.device(c.device)
        # Training episodes fly the version's disturbances; the run's own evaluation flies the
        # paper's (``CoreConfig()``) whatever the version trains in.
        eval_core = CoreConfig() if c.env.disturbances else CoreConfig.ideal()
        core = version.task.core if c.env.disturbances else eval_core
        self.aircraft = load_aircraft(c.env.aircraft)
        eval_core, core = (dataclasses.replace(x, aircraft=c.env.aircraft) for x in (eval_core, core))
        self.task_config = dataclasses.replace(version.task, core=core)
        self.eval_task_config = dataclasses.replace(self.task_config, core=eval_core)
        self.window = version.flight_stack.window_steps
        privileged = c.network.asymmetric_critic
        self.teacher = c.distill.teacher
        self.env = make_env(c.env.num_envs, self.task_config, seed=c.seed, window=self.window, privileged=privileged,
                            teacher=self.teacher)
        net = c.network
        obs_size = self.task_config.observation_size
        self.actor = make_actor(net.lstm_hidden, net.mlp_hidden, self.env.action_spec, net.encoder,
                                self.window, obs_size).to(self.device)
        if version.flight_stack.residual_on:  # the correction starts at zero: training starts from the base controller
            self.actor.module[0].module.start_at_zero(RESIDUAL_START_STD)
        elif self.teacher:  # imitation moves the mean only: the exploration stays this narrow until SAC
            self.actor.module[0].module.set_std(c.distill.start_std)
        critics = [make_critic(net.lstm_hidden, net.mlp_hidden, PRIVILEGED_SIZE if privileged else 0, net.encoder,
                               self.window, obs_size).module.to(self.device) for _ in range(2)]
        self.stored_keys = stored_keys(self.task_config, privileged) + (("teacher_action",) if self.teacher else ())
        self.goal_range = goal_range(self.aircraft)  # relabelled goals stay within the task's
        self.sac = RecurrentSAC(
            self.actor.module[0].module, critics, gamma=c.optim.gamma, tau=c.optim.tau, alpha=c.optim.alpha,
            auto_alpha=c.optim.auto_alpha, target_entropy=c.optim.target_entropy, lr=c.optim.lr,
            caps_kappa_temporal=c.caps.kappa_temporal, caps_kappa_spatial=c.caps.kappa_spatial,
            caps_sigma_spatial=c.caps.sigma_spatial, caps_batch_size=c.caps.batch_size,
            caps_action_weights=c.caps.action_weights,
            imitation_weight=c.distill.bc_weight if self.teacher else 0.0)
        self.buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(c.buffer.capacity), batch_size=c.buffer.batch_size)
        # The steps the teacher flew, kept apart for SAC's batches (``distill.offline_share``).
        self.offline_buffer = (TensorDictReplayBuffer(storage=LazyTensorStorage(min(c.buffer.capacity,
                                                                                    c.distill.dagger_frames)))
                               if self.teacher and c.distill.offline_share > 0.0 else None)
        # The collector's policy: while distilling, the teacher flies a share of the steps.
        self.policy = TeacherMix(self.actor) if self.teacher else self.actor
        self.counters = Counters()
        self.fingerprint = resume_fingerprint(c)
        if resume:
            self._load()
            self._record_config()
        else:
            with self._writing():
                (self.run_dir / "config.json").write_text(c.to_json())
        self._episode_returns: list[float] = []
        self._episode_lengths: list[int] = []
        self._losses: dict[str, list[float]] = {}
        self._stop: list[int] = []  # signals received while training (``_stop_on_signals``)

    # ------------------------------------------------------------------ the run folder
    def _no_checkpoint_message(self) -> str:
        """What to do with a folder whose run stopped before its first checkpoint."""
        d, every = self.run_dir, self.config.log.checkpoint_every_frames
        start = (f"start it afresh under its name (--run-name {d.name} --log.run_root {d.parent}; its logs are "
                 "replaced)")
        if (d / "best_policy.pt").exists():
            start = (f"start it afresh under another --run-name (or move its best_policy.pt away and {start})")
        return (f"{d} has no checkpoint: the run stopped before its first one (every {every:,} env steps), so there is "
                f"nothing to resume; {start}, or delete the folder")

    def _start_afresh(self) -> None:
        """A new run in ``run_dir``: refused over a run (``RUN_FILES``); the logs of a run that
        stopped before its first checkpoint are removed (``notes`` says which)."""
        held = [name for name in RUN_FILES if (self.run_dir / name).exists()]
        for name in held:
            problem = not_a_file_message(self.run_dir / name)
            if problem:
                raise RunExistsError(problem)
        if "checkpoint.pt" in held:
            raise RunExistsError(f"{self.run_dir} already holds a run ({', '.join(held)}): go on with it with "
                                 f"--resume {self.run_dir}, or start afresh under another --run-name")
        if held:
            raise RunExistsError(f"{self.run_dir} holds the best_policy.pt of a run that stopped before its first "
                                 "checkpoint: start afresh under another --run-name, or move best_policy.pt away to "
                                 "start afresh there")
        stale = [name for name in LOG_FILES if (self.run_dir / name).exists()]
        if not stale:
            return
        if not _is_run_config(self.run_dir / "config.json"):  # not a stopped run of this package: leave it alone
            raise RunExistsError(f"{self.run_dir} holds {', '.join(stale)} but no run of this package (its config.json "
                                 "is missing or not a training configuration): give another --run-name or "
                                 "--log.run_root")
        with self._writing():
            for name in stale:
                path = self.run_dir / name
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path)
                else:
                    path.unlink()
        self.notes.append(f"{self.run_dir} held a run that stopped before its first checkpoint; starting it afresh "
                          f"(its {', '.join(stale)} replaced)")

    def remove_stale_temporaries(self) -> list[str]:
        """Remove what writers killed in this folder left (``atomic_save``'s temporaries of
        ``checkpoint.pt``, ``best_policy.pt`` and the evaluated policies, the progress log's);
        returns their names. Only safe under the run's lock, which no other trainer holds: no live
        writer owns them."""
        removed = []
        for folder in (self.run_dir, self.run_dir / EVALUATED_DIR):
            try:
                names = [p.name for p in folder.iterdir()]
            except OSError:
                continue
            for name in names:
                if _TEMPORARY.fullmatch(name) or name == "progress.csv.tmp":
                    with contextlib.suppress(OSError):
                        (folder / name).unlink()
                        removed.append(name)
        return removed

    def _folder_error(self, err: OSError | None = None) -> RunFolderError:
        """The one-line error of a run folder that can no longer be written, with the state of
        its checkpoint and what to do."""
        frames = f"{self.counters.frames:,}" if hasattr(self, "counters") else "0"
        if _identity(self.run_dir) != self._folder_id:
            return RunFolderError(f"the run folder {self.run_dir} was removed or replaced during training, at "
                                  f"{frames} env steps: its checkpoint went with it, and the run cannot go on")
        if self._checkpoint_frames is not None:
            state = (f"its last checkpoint is at {self._checkpoint_frames:,} env steps: once the folder can be "
                     f"written, go on with --resume {self.run_dir}")
        else:
            state = "it has no checkpoint yet: once the folder can be written, start it afresh"
        reason = f" ({_reason(err)})" if err is not None else ""
        return RunFolderError(f"cannot write to the run folder {self.run_dir} at {frames} env steps{reason}; {state}")

    @contextlib.contextmanager
    def _writing(self):
        """Writes to the run folder: an ``OSError`` (read-only, removed, full) becomes a
        ``RunFolderError``; a folder removed or replaced since the run started is one too, before
        the write (``atomic_save`` would make a new folder with the checkpoint alone in it)."""
        if _identity(self.run_dir) != self._folder_id:
            raise self._folder_error()
        try:
            yield
        except OSError as err:
            raise self._folder_error(err) from err

    # ------------------------------------------------------------------ checkpoints
    @property
    def checkpoint_path(self) -> Path:
        return self.run_dir / "checkpoint.pt"

    def save(self) -> None:
        """Write everything a resumed run needs, atomically (``RunFolderError`` where it cannot);
        ``TrainingDiverged``, writing nothing, where a weight or an optimiser's moment is not finite."""
        self.check_finite()
        with self._writing():
            self._save()
        self._checkpoint_frames = self.counters.frames

    def _save(self) -> None:
        save_checkpoint(self.checkpoint_path, {
            "config": self.config.to_dict(),
            "sac": self.sac.state_dict(),
            "optimizer": self.sac.optimizer.state_dict(),
            "buffer": buffer_contents(self.buffer),
            **({"offline_buffer": buffer_contents(self.offline_buffer)} if self.offline_buffer is not None else {}),
            "counters": self.counters.__dict__,
            "torch_rng": torch.get_rng_state(),
            "env_episodes": self.env.base_env._episodes.copy(),
        }, self.fingerprint)

    def _record_config(self) -> None:
        """A resumed run's ``config.json`` says what it goes on with (a new length or learning rate),
        so that the next ``--resume`` goes on with it too; rewritten atomically, only where it changed."""
        path = self.run_dir / "config.json"
        text = self.config.to_json()
        with contextlib.suppress(OSError, UnicodeDecodeError):
            if path.read_text() == text:
                return
        with self._writing():
            write_text_atomic(path, text)

    def _load(self) -> None:
        data = load_checkpoint(self.checkpoint_path, required=("config", "sac", "optimizer", "buffer", "counters"))
        # Compare the run's settings as this version reads them; a run of another version of the
        # package (settings or a task version this one does not have) is refused, naming them.
        try:
            saved = resume_settings(TrainConfig.from_dict(data["config"]))
        except (TypeError, ValueError) as err:
            raise CheckpointError(f"checkpoint {self.checkpoint_path} holds unreadable settings: {err}") from err
        changed = changed_settings(saved, resume_settings(self.config))
        if changed:
            may = ", ".join(RESUME_MAY_CHANGE + RESUME_MAY_CHANGE_GROUPS[:1]) + ", device and threads"
            raise CheckpointError(f"checkpoint {self.checkpoint_path} was written by a run with other settings: "
                                  f"{'; '.join(changed)}; resume with its settings (only {may} may change), or "
                                  "start a new run under another --run-name")
        self.sac.load_state_dict(data["sac"])
        self.sac.optimizer.load_state_dict(data["optimizer"])
        for group in self.sac.optimizer.param_groups:  # a resumed run may lower its learning rate
            group["lr"] = self.config.optim.lr
        restore_buffer(self.buffer, data["buffer"])
        if self.offline_buffer is not None:
            if "offline_buffer" not in data:
                raise CheckpointError(f"checkpoint {self.checkpoint_path} has no offline_buffer: it is damaged or "
                                      "from another version of the package")
            restore_buffer(self.offline_buffer, data["offline_buffer"])
        self.counters = Counters(**data["counters"])
        torch.set_rng_state(data["torch_rng"])
        # Resumed environments start new episodes where the run's episode counters stood.
        self.env.base_env._episodes[:] = data["env_episodes"]
        self._checkpoint_frames = self.counters.frames
        # A best policy saved after this checkpoint (the run was killed between the two) keeps its
        # place until an evaluation beats its own score.
        self.counters.best_eval = max(self.counters.best_eval, self._best_policy_score())
        self._trim_progress_log()

    def _best_policy_score(self) -> float:
        """The evaluation return recorded in the run's ``best_policy.pt`` (-inf without one)."""
        path = self.run_dir / "best_policy.pt"
        if not path.exists():
            return -math.inf
        try:
            data = checked_load(path)
        except (DamagedFileError, OSError) as err:
            raise CheckpointError(f"{path} is damaged or unreadable ({str(err).replace(chr(10), ' ')}); move it away "
                                  "to resume (the run's next best evaluation writes a new one)") from None
        evaluation = data.get("evaluation") if isinstance(data, dict) else None
        score = evaluation.get("return_norm") if isinstance(evaluation, dict) else None
        return float(score) if isinstance(score, (int, float)) and math.isfinite(score) else -math.inf

    def _trim_progress_log(self) -> None:
        """Drop log rows written after the checkpoint by a run that was then killed, and rows that
        cannot be read: a torn last row, the zeros power loss leaves (``notes`` says how many)."""
        path = self.run_dir / "progress.csv"
        if not path.exists():
            return
        try:
            readable, torn = read_progress(path, CSV_FIELDS)
        except OSError as err:
            raise CheckpointError(f"cannot read the progress log {path} ({_reason(err)})") from None
        rows = [row for row in readable if int(row["frames"]) <= self.counters.frames]
        if torn:
            self.notes.append(f"{path}: dropped {torn} unreadable row{'s' if torn > 1 else ''} (a write cut short, "
                              "as a kill or power loss leaves)")
        tmp = path.with_suffix(".csv.tmp")
        try:
            with tmp.open("w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=CSV_FIELDS, extrasaction="ignore")
                w.writeheader()
                w.writerows(rows)
            tmp.replace(path)
        except OSError as err:
            raise CheckpointError(f"cannot rewrite the progress log {path} ({_reason(err)})") from None

    def save_policy(self, path: Path, evaluation: dict) -> None:
        """The deterministic policy and the control stack it flies with (the task version's), for
        ``jsbsim_env.control.policy``."""
        with self._writing():
            self._save_policy(path, evaluation)

    def check_finite(self) -> None:
        """``TrainingDiverged`` naming the first weights or optimiser state that are NaN or infinite."""
        bad = non_finite_entries({"weights": self.sac.state_dict(), "optimizer": self.sac.optimizer.state_dict()})
        if bad:
            raise self._diverged(bad[0] + (f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""))

    def _diverged(self, what: str) -> TrainingDiverged:
        return TrainingDiverged(what, self.counters.frames, self.counters.updates, self._checkpoint_frames,
                                self.run_dir, self.config.optim.lr)

    def _save_policy(self, path: Path, evaluation: dict) -> None:
        atomic_save({
            "actor": self.actor.state_dict(),
            "network": self.config.network.__dict__,
            "task": self.version.env_id,
            "stack": self.version.flight_stack.to_dict(),
            "frames": self.counters.frames,
            "seed": self.config.seed,
            "evaluation": evaluation,
            "aircraft": self.aircraft.name,  # what it was trained on: refused on another (PolicyRuntime)
            "aircraft_model": self.aircraft.fingerprint,
        }, path)

    # ------------------------------------------------------------------ training
    def _update(self, batch: TensorDictBase, actor: bool = True) -> None:
        c = self.config
        task = self.task_config
        flown = batch.to(self.device)
        batch = relabel_goals(flown, c.buffer.relabel_fraction,
                              sideslip_weight=task.sideslip_weight, penalty_tail=task.penalty_tail,
                              roll_weight=task.roll_weight, pitch_weight=task.pitch_weight,
                              goal_range=self.goal_range)
        if self.teacher:  # the teacher's label holds for the goal flown, not for a relabelled one
            batch["imitation_mask"] = (batch["observation"] == flown["observation"]).flatten(1).all(1).float()
        self._record_losses(self.sac.update(batch, actor=actor))

    def _imitation_update(self, batch: TensorDictBase) -> None:
        """One distillation step towards the teacher's actions (goals as flown: a relabelled goal
        has no teacher's label)."""
        losses = self.sac.imitation_update(batch.to(self.device))
        self._record_losses(losses)

    def _critic_update(self, batch: TensorDictBase) -> None:
        """One step of the critics alone (the warm-up after the distillation)."""
        self._update(batch, actor=False)

    def _record_losses(self, losses: dict[str, float]) -> None:
        self.counters.updates += 1
        bad = [key for key, value in losses.items() if not math.isfinite(value)]
        if bad:  # the weights are no longer to be trusted: nothing of them is written
            raise self._diverged(", ".join(bad))
        for key, value in losses.items():
            self._losses.setdefault(key, []).append(value)

    def _sample(self) -> TensorDictBase:
        """A SAC batch: ``distill.offline_share`` of it from the teacher's steps where a distilling
        run keeps them, the rest from the replay buffer."""
        size = self.config.buffer.batch_size
        offline = self.offline_buffer
        k = round(size * self.config.distill.offline_share) if offline is not None and len(offline) else 0
        if k == 0:
            return self.buffer.sample()
        # The buffer's own batch size, cut: a sample of another size has TorchRL warn every time.
        return torch.cat([offline.sample(k), self.buffer.sample()[:size - k]])

    def _learn(self, before: int, stop: list[int]) -> None:
        """The gradient steps owed to the steps from ``before`` to now: imitation during a
        distillation, then (once) the distilled policy kept and the critics warmed, then SAC's."""
        c, frames = self.config, self.counters.frames
        d = c.distill
        if self.teacher:
            imitation = min(frames, d.dagger_frames) - before
            if imitation > 0:
                self.counters.update_debt += imitation * d.updates_per_step
                while self.counters.update_debt >= 1.0 and not stop:
                    self._imitation_update(self.buffer.sample())
                    self.counters.update_debt -= 1.0
            if frames >= d.dagger_frames and not self.counters.critics_warmed and not stop:
                self._finish_distillation(stop)
            learning_starts = d.dagger_frames
        else:
            learning_starts = c.collector.init_random_frames
        learn_frames = frames - max(before, learning_starts)  # SAC after the random (or distilling) steps
        if learn_frames > 0 and (self.counters.critics_warmed or not self.teacher):
            self.counters.update_debt += learn_frames * c.optim.updates_per_step
            while self.counters.update_debt >= 1.0 and not stop:  # a stop request ends the round
                self._update(self._sample())
                self.counters.update_debt -= 1.0
        self.check_finite()  # before the collector flies the weights

    def _finish_distillation(self, stop: list[int]) -> None:
        """The end of a distillation: the network as distilled is evaluated and kept
        (``distilled_policy.pt``, and as the best policy where it is the best so far), the teacher
        flies no more, and the critics learn the distilled policy's values before SAC moves it. A
        stop request leaves it to the resumed run."""
        c = self.config
        self.policy.beta = 0.0
        result = evaluate_policy(self.actor, self.eval_task_config, episodes=c.log.eval_episodes,
                                 max_steps=EVAL_MAX_STEPS, window=self.window, stop=stop)
        if result is None:
            return
        self.save_policy(self.run_dir / DISTILLED_POLICY, {**result, "frames": self.counters.frames})
        self._keep_if_best(result)  # a candidate for the run's best policy like any other
        self.counters.update_debt = 0.0  # what imitation left owing is not SAC's
        # Adam's moments of the actor are imitation's, whose gradients end small: SAC's first steps
        # would be several learning rates long. The actor starts SAC with fresh moments.
        for param in self.sac.actor_net.parameters():
            self.sac.optimizer.state.pop(param, None)
        for _ in range(c.distill.critic_warmup_updates):
            if stop:
                return
            self._critic_update(self._sample())
        self.counters.critics_warmed = True

    def _record_episodes(self, data: TensorDictBase) -> None:
        done = data["next", "done"].squeeze(-1)
        if done.any():
            self._episode_returns += data["next", "episode_reward"][done].flatten().tolist()
            self._episode_lengths += data["next", "step_count"][done].flatten().tolist()
            self.counters.episodes += int(done.sum())

    def train(self) -> dict:
        """Train to ``collector.total_frames``; returns the last log row."""
        c = self.config
        remaining = c.collector.total_frames - self.counters.frames
        if remaining <= 0:
            return {}
        # At least one aircraft step each: ``TrainConfig.validate`` keeps frames_per_batch >= num_envs.
        frames_per_batch = c.collector.frames_per_batch - c.collector.frames_per_batch % c.env.num_envs
        # The collector takes random steps in whole batches; rounding up here keeps it from warning.
        random_frames = 0 if self.teacher else frames_per_batch * math.ceil(
            max(0, c.collector.init_random_frames - self.counters.frames) / frames_per_batch)
        collector = Collector(
            # Whole batches, as the collector collects anyway (and warns about otherwise).
            self.env, self.policy, frames_per_batch=frames_per_batch,
            total_frames=frames_per_batch * math.ceil(remaining / frames_per_batch),
            init_random_frames=random_frames,
            exploration_type=ExplorationType.RANDOM,
            # The LSTMs read a window of observations and keep no state between steps.
            auto_register_policy_transforms=False,
        )
        try:
            with self._writing():
                writer, csv_file, csv_writer = self._open_logs()
        except BaseException:
            collector.shutdown()
            raise
        bar = self._progress_bar()
        session_start, start_frames = time.perf_counter(), self.counters.frames
        wall_before = self.counters.wall_s  # time spent by earlier sessions of a resumed run
        next_log = _next_multiple(self.counters.frames, c.log.log_every_frames)
        next_eval = _next_multiple(self.counters.frames, c.log.eval_every_frames)
        next_ckpt = _next_multiple(self.counters.frames, c.log.checkpoint_every_frames)
        row: dict = {}
        if self.teacher:
            self.policy.beta = dagger_share(self.counters.frames, c.distill.dagger_frames)
        last_eval: float | str = ""
        stop = self._stop = []  # signals received (``_stop_on_signals``)
        with _stop_on_signals(stop):
            try:
                for data in collector:
                    data = data.reshape(-1)
                    self._record_episodes(data)
                    self.buffer.extend(data.select(*self.stored_keys).cpu())
                    if self.offline_buffer is not None and "teacher_acted" in data.keys():  # noqa: SIM118
                        flown = data[data["teacher_acted"].reshape(-1)]
                        if flown.numel():
                            self.offline_buffer.extend(flown.select(*self.stored_keys).cpu())
                    n = data.numel()
                    before = self.counters.frames
                    self.counters.frames += n
                    self._learn(before, stop)
                    if self.teacher:  # the teacher's share of the next batch's steps
                        self.policy.beta = dagger_share(self.counters.frames, c.distill.dagger_frames)
                    if stop:
                        self._interrupted(stop)
                    collector.update_policy_weights_()
                    self.counters.wall_s = wall_before + time.perf_counter() - session_start
                    if bar is not None:
                        bar.update(n)
                    evaluation = None
                    # Every ``eval_every_frames``, and at the end: a run that trained has a best policy.
                    if self.counters.frames >= next_eval or self.counters.frames >= c.collector.total_frames:
                        evaluation = self.evaluate()
                        if evaluation is None:  # stopped before its end: nothing of it is kept
                            self._interrupted(stop)
                        next_eval = _next_multiple(self.counters.frames, c.log.eval_every_frames)
                    if self.counters.frames >= next_log or evaluation is not None:
                        row = self._log_row(start_frames, session_start, evaluation)
                        with self._writing():
                            csv_writer.writerow(row)
                            csv_file.flush()
                            for key, value in row.items():
                                if key not in ("frames", "updates") and value != "" and value is not None:
                                    writer.add_scalar(key, value, self.counters.frames)
                            writer.flush()
                        if bar is not None:  # the return of the latest evaluation and the best one so far
                            last_eval = evaluation["return_norm"] if evaluation is not None else last_eval
                            bar.set_postfix(sps=f"{row['env_steps_per_s']:.0f}", ret=_short(row["episode_return_norm"]),
                                            eval=_short(last_eval), best=_short(self.counters.best_eval))
                        next_log = _next_multiple(self.counters.frames, c.log.log_every_frames)
                    if self.counters.frames >= next_ckpt or self.counters.frames >= c.collector.total_frames:
                        self.save()
                        next_ckpt = _next_multiple(self.counters.frames, c.log.checkpoint_every_frames)
                    if stop:
                        self._interrupted(stop)
            except BaseException:
                self._close(collector, writer, csv_file, bar, quiet=True)  # the error in flight is the one to tell
                raise
            self._close(collector, writer, csv_file, bar, quiet=False)
        return row

    def _interrupted(self, stop: list[int]) -> None:
        """A stop request: the checkpoint written, then ``TrainingInterrupted``."""
        self.save()
        raise TrainingInterrupted(signal.Signals(stop[0]).name, self.counters.frames, self.checkpoint_path)

    def _close(self, collector, writer, csv_file, bar, quiet: bool) -> None:
        """End a session: the collector, the logs (their last buffered rows written), the progress
        bar, and temporaries that killed writers left. A log that cannot be written raises
        ``RunFolderError`` unless ``quiet``."""
        collector.shutdown()
        if bar is not None:
            bar.close()
        failed = None
        for close in (writer.close, csv_file.close):
            try:
                close()
            except OSError as err:
                failed = failed or err
        self.remove_stale_temporaries()
        if failed is not None and not quiet:
            raise self._folder_error(failed) from failed

    def evaluate(self) -> dict | None:
        """Deterministic evaluation on the fixed seeded episode set; keeps the best policy. None
        where a stop request (``train``'s signals) ended it early."""
        c = self.config
        result = evaluate_policy(self.actor, self.eval_task_config, episodes=c.log.eval_episodes,
                                 max_steps=EVAL_MAX_STEPS, window=self.window, stop=self._stop)
        if result is None:
            return None
        self._keep_if_best(result)
        return result

    def _keep_if_best(self, result: dict) -> None:
        """The policy evaluated as ``result`` is kept in ``EVALUATED_DIR`` (``log.keep_evaluated``) and
        becomes ``best_policy.pt`` where it beats the best so far."""
        evaluation = {**result, "frames": self.counters.frames}
        if self.config.log.keep_evaluated:  # atomic_save makes the folder
            self.save_policy(self.run_dir / EVALUATED_DIR / evaluated_policy_name(self.counters.frames), evaluation)
        if result["return_norm"] > self.counters.best_eval:
            self.save_policy(self.run_dir / "best_policy.pt", evaluation)
            self.counters.best_eval = result["return_norm"]

    # ------------------------------------------------------------------ logging
    def _open_logs(self):
        from torch.utils.tensorboard import SummaryWriter

        writer = SummaryWriter(str(self.run_dir / "tb"), purge_step=self.counters.frames or None)
        path = self.run_dir / "progress.csv"
        new = not path.exists()
        csv_file = path.open("a", newline="")
        csv_writer = csv.DictWriter(csv_file, fieldnames=CSV_FIELDS)
        if new:
            csv_writer.writeheader()
        return writer, csv_file, csv_writer

    def _progress_bar(self):
        if not self.config.log.progress:
            return None
        from tqdm import tqdm

        return tqdm(total=self.config.collector.total_frames, initial=self.counters.frames, unit="step",
                    dynamic_ncols=True, desc="train")

    def _log_row(self, start_frames: int, session_start: float, evaluation: dict | None) -> dict:
        session_s = max(time.perf_counter() - session_start, 1e-9)
        recent = self._episode_returns[-20:]
        lengths = self._episode_lengths[-20:]
        max_steps = self.task_config.core.max_steps
        row = {
            "frames": self.counters.frames, "updates": self.counters.updates, "wall_s": round(self.counters.wall_s, 2),
            "env_steps_per_s": (self.counters.frames - start_frames) / session_s,
            "episodes": self.counters.episodes,
            "episode_return": float(np.mean(recent)) if recent else "",
            "episode_return_norm": float(np.mean(recent)) / max_steps if recent else "",
            "episode_length": float(np.mean(lengths)) if lengths else "",
            **{k: float(np.mean(v)) for k, v in self._losses.items()},
            "eval_return_norm": evaluation["return_norm"] if evaluation else "",
            "eval_length": evaluation["length"] if evaluation else "",
            "eval_early_ends": evaluation["early_ends"] if evaluation else "",
        }
        self._losses.clear()
        return {k: row.get(k, "") for k in CSV_FIELDS}


class RunLockedError(RuntimeError):
    """Another process is training in this run folder."""


class RunExistsError(RuntimeError):
    """A new run asked for in a folder that holds a run (resume it, or use another folder)."""


class RunFolderError(RuntimeError):
    """The run folder cannot be written (read-only, full, removed): one line naming it and the
    state of its checkpoint."""


def _reason(err: OSError) -> str:
    """An OS error in words, with the file it concerns."""
    text = err.strerror or str(err)
    return f"{text}: {err.filename}" if err.filename else text


def _identity(path: Path) -> tuple[int, int] | None:
    """(device, inode) of a folder, None where there is none: a folder removed, or removed and made
    again, has another."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _is_run_config(path: Path) -> bool:
    """Whether ``path`` is the config.json a training run of this package wrote: every setting, as
    this version reads them (a run writes them all)."""
    try:
        data = json.loads(path.read_text())
        return data == TrainConfig.from_dict(data).to_dict()
    except (OSError, ValueError, TypeError, AttributeError):
        return False


def _lock_run_dir(run_dir: Path):
    """Hold an exclusive lock on ``run_dir/.lock`` for the trainer's lifetime, so that a second
    trainer (a resume while the run is still going) cannot rewrite its logs and checkpoint. The
    operating system drops the lock when the process ends, however it ends."""
    try:
        import fcntl
    except ImportError:  # not on POSIX: no lock
        return None
    handle = (run_dir / ".lock").open("a")
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        raise RunLockedError(f"another process is training in {run_dir}; wait for it or stop it first") from None
    return handle


# ---------------------------------------------------------------------- evaluation during training
EVAL_SEED = 20240428  # the evaluation episodes are the same for every run and every evaluation


@torch.no_grad()
def dagger_share(frames: int, dagger_frames: int) -> float:
    """The share of steps the teacher flies at ``frames`` steps into a distillation of
    ``dagger_frames``: all at the start, none at its end (DAgger's mixture, falling linearly)."""
    return max(0.0, 1.0 - frames / dagger_frames)


class TeacherMix(TensorDictModuleBase):
    """The collector's policy in a distilling run: the actor's action, or on a share ``beta`` of the
    steps (drawn for each aircraft and step) the teacher's (``teacher_action``); ``teacher_acted``
    says which."""

    def __init__(self, actor):
        super().__init__()
        self.actor = actor
        self.in_keys = [*actor.in_keys, "teacher_action"]
        self.out_keys = [*actor.out_keys, "teacher_acted"]
        self.beta = 1.0

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict = self.actor(tensordict)
        acted = torch.rand(tensordict.batch_size, device=tensordict.device) < self.beta
        tensordict["action"] = torch.where(acted[..., None], tensordict["teacher_action"], tensordict["action"])
        tensordict["teacher_acted"] = acted
        return tensordict


def evaluate_policy(policy, task_config: TaskConfig, episodes: int = 8, max_steps: int = 500, window: int = 8,
                    seed: int = EVAL_SEED, stop: list | None = None) -> dict | None:
    """The evaluation a run makes every ``log.eval_every_frames`` (its best policy is kept by it):
    fly ``episodes`` episodes side by side with the deterministic policy, each once.

    Returns the mean normalised return (episode reward / max_steps, the paper's Fig. 8; always with Eq. 22's
    reward and the policy on the throttle, whatever reward weights, penalty tail and external throttle the run
    trains with; ``Trainer`` passes the paper's disturbances, whatever turbulence and delay it trains in), the mean
    episode length and the number of episodes that ended early (terminated, not truncated). None
    where ``stop`` (a list a signal handler appends to) fills before the episodes end.
    """
    plain = dataclasses.replace(task_config, sideslip_weight=1.0, roll_weight=1.0, pitch_weight=1.0, penalty_tail=0.0,
                                external_throttle=0.0)
    env = make_env(episodes, plain, seed=seed, window=window)
    td = env.reset()
    active = torch.ones(episodes, dtype=torch.bool)
    total = torch.zeros(episodes)
    length = torch.zeros(episodes)
    early = torch.zeros(episodes, dtype=torch.bool)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        for _ in range(max_steps):
            if stop:
                env.close()
                return None
            td = env.step(policy(td))
            reward = td["next", "reward"].reshape(episodes)
            total += reward * active
            length += active.float()
            early |= td["next", "terminated"].reshape(episodes) & active
            active &= ~td["next", "done"].reshape(episodes)
            if not active.any():
                break
            td = step_mdp(td)
    env.close()
    return {"return_norm": float(total.mean()) / max_steps, "length": float(length.mean()),
            "early_ends": int(early.sum()), "episodes": episodes}


class TrainingDiverged(RuntimeError):
    """An update made a loss, a weight or an optimiser's moment NaN or infinite. Training stops
    before anything of it is written: the last checkpoint stays the last good one."""

    def __init__(self, what: str, frames: int, updates: int, checkpoint_frames: int | None, run_dir: Path,
                 lr: float):
        self.what, self.frames, self.checkpoint_frames = what, frames, checkpoint_frames
        lower = f"{min(lr / 10, OptimSettings.lr):.3g}"  # the default where the rate was above it
        if checkpoint_frames is not None:
            then = (f"its last good checkpoint ({checkpoint_frames:,} env steps) is kept: go on from it with a lower "
                    f"learning rate, e.g. --resume {run_dir} --optim.lr {lower}")
        else:
            then = f"it has no checkpoint yet: start it again with a lower learning rate, e.g. --optim.lr {lower}"
        super().__init__(f"training diverged at {frames:,} env steps (update {updates:,}): {what} became NaN or "
                         f"infinite; {then}")


class TrainingInterrupted(Exception):
    """SIGINT or SIGTERM stopped training; the checkpoint was written first."""

    def __init__(self, signal_name: str, frames: int, checkpoint: Path):
        self.signal_name, self.frames, self.checkpoint = signal_name, frames, checkpoint
        super().__init__(f"{signal_name} at {frames:,} env steps; checkpoint written to {checkpoint}")


@contextlib.contextmanager
def _stop_on_signals(flag: list):
    """While inside, SIGINT and SIGTERM only append their number to ``flag`` (the loop checks it
    between two updates, between two steps of an evaluation and between batches, so the checkpoint
    is never written from the middle of an update). Outside the main thread signals cannot be
    caught, and nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, lambda signum, frame: flag.append(signum))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def buffer_contents(buffer: TensorDictReplayBuffer) -> dict:
    """The filled part of the replay buffer, in storage order, and its write cursor (the full
    storage is preallocated to capacity and would make every checkpoint gigabytes)."""
    n = len(buffer)
    return {"data": buffer[:n].clone() if n else None, "writer": buffer._writer.state_dict()}


def restore_buffer(buffer: TensorDictReplayBuffer, contents: dict) -> None:
    """Refill an empty buffer with ``buffer_contents``: same layout, same next write position."""
    if contents["data"] is not None:
        buffer.extend(contents["data"])
    buffer._writer.load_state_dict(contents["writer"])


def _next_multiple(value: int, step: int) -> int:
    return (value // step + 1) * step

"""Recurrent SAC with CAPS on the solar-UAV attitude environment (the paper's Section 3).

A run folder holds ``config.json``, ``progress.csv``, TensorBoard events (``tb/``), ``checkpoint.pt``
(everything needed to resume: networks, targets, optimisers, replay buffer, counters, random
state) and ``best_policy.pt`` (the best deterministic policy by evaluation return).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import math
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import TaskConfig
from jsbsim_env.task.torchrl_env import make_env
from jsbsim_env.task.versions import task_version
from training.checkpoint import CheckpointError, atomic_save, config_fingerprint, load_checkpoint, save_checkpoint
from training.config import TrainConfig
from training.networks import make_actor, make_critic
from training.relabel import relabel_goals
from training.runtime import check_threads
from training.sac import RecurrentSAC

STORED_KEYS = ("observation", "action", ("next", "observation"), ("next", "reward"), ("next", "done"),
               ("next", "terminated"), ("next", "achieved"))
EVAL_MAX_STEPS = 500  # interactions per evaluation episode during training


def stored_keys(task: TaskConfig) -> tuple:
    """What the replay buffer keeps of each transition."""
    return STORED_KEYS + ((("next", "speed_free"),) if task.external_throttle > 0.0 else ())


CSV_FIELDS = ("frames", "updates", "wall_s", "env_steps_per_s", "episodes", "episode_return", "episode_return_norm",
              "episode_length", "loss_actor", "loss_qvalue", "caps_temporal", "caps_spatial", "alpha", "entropy",
              "eval_return_norm", "eval_length", "eval_early_ends")


def _short(value) -> str:
    """A progress-bar figure: three decimals, or blank where there is none yet."""
    return f"{value:.3f}" if isinstance(value, float) and math.isfinite(value) else ""


def resume_fingerprint(config: TrainConfig) -> str:
    """Settings that must be the same to resume: everything but logging, device, threads and length."""
    data = config.to_dict()
    data["collector"] = {k: v for k, v in data["collector"].items() if k != "total_frames"}
    return config_fingerprint(data, ignore=("log", "device", "threads"))


@dataclass
class Counters:
    frames: int = 0
    updates: int = 0
    episodes: int = 0
    wall_s: float = 0.0
    best_eval: float = -math.inf


class Trainer:
    """Builds the environment, networks, loss, buffer and collector of a run, and trains.

    Args:
        config: the run's settings.
        run_dir: the run folder (created).
        resume: continue from ``run_dir/checkpoint.pt``.
    """

    def __init__(self, config: TrainConfig, run_dir: Path | str, resume: bool = False):
        self.config = c = config
        if c.collector.total_frames <= c.collector.init_random_frames:
            raise ValueError(f"collector.total_frames ({c.collector.total_frames}) must exceed "
                             f"collector.init_random_frames ({c.collector.init_random_frames}): the run would "
                             "only take random steps and learn nothing")
        self.version = version = task_version(c.env.task)
        self.run_dir = Path(run_dir)
        if resume and not self.run_dir.is_dir():
            raise CheckpointError(f"no run folder to resume at {self.run_dir}")
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self._lock = _lock_run_dir(self.run_dir)
        if c.threads > 0:
            torch.set_num_threads(c.threads)
        check_threads(torch.get_num_threads())
        torch.manual_seed(c.seed)
        self.device = torch.device(c.device)
        # Training episodes fly the version's disturbances; the run's own evaluation flies the
        # paper's (``CoreConfig()``) whatever the version trains in.
        eval_core = CoreConfig() if c.env.disturbances else CoreConfig.ideal()
        core = version.task.core if c.env.disturbances else eval_core
        self.task_config = dataclasses.replace(version.task, core=core)
        self.eval_task_config = dataclasses.replace(self.task_config, core=eval_core)
        self.window = version.flight_stack.window_steps
        self.env = make_env(c.env.num_envs, self.task_config, seed=c.seed, window=self.window)
        self.actor = make_actor(c.network.lstm_hidden, c.network.mlp_hidden, self.env.action_spec).to(self.device)
        critics = [make_critic(c.network.lstm_hidden, c.network.mlp_hidden).module.to(self.device) for _ in range(2)]
        self.stored_keys = stored_keys(self.task_config)
        self.sac = RecurrentSAC(
            self.actor.module[0].module, critics, gamma=c.optim.gamma, tau=c.optim.tau, alpha=c.optim.alpha,
            auto_alpha=c.optim.auto_alpha, target_entropy=c.optim.target_entropy, lr=c.optim.lr,
            caps_kappa_temporal=c.caps.kappa_temporal, caps_kappa_spatial=c.caps.kappa_spatial,
            caps_sigma_spatial=c.caps.sigma_spatial, caps_batch_size=c.caps.batch_size,
            caps_action_weights=c.caps.action_weights)
        self.buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(c.buffer.capacity), batch_size=c.buffer.batch_size)
        self.counters = Counters()
        self.fingerprint = resume_fingerprint(c)
        if resume:
            self._load()
        else:
            (self.run_dir / "config.json").write_text(c.to_json())
        self._episode_returns: list[float] = []
        self._episode_lengths: list[int] = []
        self._losses: dict[str, list[float]] = {}

    # ------------------------------------------------------------------ checkpoints
    @property
    def checkpoint_path(self) -> Path:
        return self.run_dir / "checkpoint.pt"

    def save(self) -> None:
        """Write everything a resumed run needs, atomically."""
        save_checkpoint(self.checkpoint_path, {
            "config": self.config.to_dict(),
            "sac": self.sac.state_dict(),
            "optimizer": self.sac.optimizer.state_dict(),
            "buffer": buffer_contents(self.buffer),
            "counters": self.counters.__dict__,
            "torch_rng": torch.get_rng_state(),
            "env_episodes": self.env.base_env._episodes.copy(),
        }, self.fingerprint)

    def _load(self) -> None:
        data = load_checkpoint(self.checkpoint_path, required=("config", "sac", "optimizer", "buffer", "counters"))
        # Compare the run's settings as this version reads them; a run of another version of the
        # package (settings or a task version this one does not have) is refused, naming them.
        try:
            saved = resume_fingerprint(TrainConfig.from_dict(data["config"]))
        except (TypeError, ValueError) as err:
            raise CheckpointError(f"checkpoint {self.checkpoint_path} holds unreadable settings: {err}") from err
        if saved != self.fingerprint:
            raise CheckpointError(f"checkpoint {self.checkpoint_path} was written by a run with other settings "
                                  f"(fingerprint {saved}, this run {self.fingerprint})")
        self.sac.load_state_dict(data["sac"])
        self.sac.optimizer.load_state_dict(data["optimizer"])
        restore_buffer(self.buffer, data["buffer"])
        self.counters = Counters(**data["counters"])
        torch.set_rng_state(data["torch_rng"])
        # Resumed environments start new episodes where the run's episode counters stood.
        self.env.base_env._episodes[:] = data["env_episodes"]
        self._trim_progress_log()

    def _trim_progress_log(self) -> None:
        """Drop log rows written after the checkpoint by a run that was then killed."""
        path = self.run_dir / "progress.csv"
        if not path.exists():
            return
        rows = [r for r in csv.DictReader(path.open()) if int(r["frames"]) <= self.counters.frames]
        tmp = path.with_suffix(".csv.tmp")
        with tmp.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=CSV_FIELDS)
            w.writeheader()
            w.writerows(rows)
        tmp.replace(path)

    def save_policy(self, path: Path, evaluation: dict) -> None:
        """The deterministic policy and the control stack it flies with (the task version's), for
        ``jsbsim_env.control.policy``."""
        atomic_save({
            "actor": self.actor.state_dict(),
            "network": self.config.network.__dict__,
            "task": self.version.env_id,
            "stack": self.version.flight_stack.to_dict(),
            "frames": self.counters.frames,
            "seed": self.config.seed,
            "evaluation": evaluation,
        }, path)

    # ------------------------------------------------------------------ training
    def _update(self, batch: TensorDictBase) -> None:
        c = self.config
        task = self.task_config
        batch = relabel_goals(batch.to(self.device), c.buffer.relabel_fraction,
                              sideslip_weight=task.sideslip_weight, penalty_tail=task.penalty_tail,
                              roll_weight=task.roll_weight, pitch_weight=task.pitch_weight)
        for key, value in self.sac.update(batch).items():
            self._losses.setdefault(key, []).append(value)
        self.counters.updates += 1

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
        frames_per_batch = c.collector.frames_per_batch - c.collector.frames_per_batch % c.env.num_envs
        if frames_per_batch <= 0:
            raise ValueError(f"collector.frames_per_batch ({c.collector.frames_per_batch}) must be at least "
                             f"env.num_envs ({c.env.num_envs})")
        # The collector takes random steps in whole batches; rounding up here keeps it from warning.
        random_frames = frames_per_batch * math.ceil(max(0, c.collector.init_random_frames - self.counters.frames)
                                                     / frames_per_batch)
        collector = Collector(
            # Whole batches, as the collector collects anyway (and warns about otherwise).
            self.env, self.actor, frames_per_batch=frames_per_batch,
            total_frames=frames_per_batch * math.ceil(remaining / frames_per_batch),
            init_random_frames=random_frames,
            exploration_type=ExplorationType.RANDOM,
            # The LSTMs read a window of observations and keep no state between steps.
            auto_register_policy_transforms=False,
        )
        writer, csv_file, csv_writer = self._open_logs()
        bar = self._progress_bar()
        session_start, start_frames = time.perf_counter(), self.counters.frames
        wall_before = self.counters.wall_s  # time spent by earlier sessions of a resumed run
        next_log = _next_multiple(self.counters.frames, c.log.log_every_frames)
        next_eval = _next_multiple(self.counters.frames, c.log.eval_every_frames)
        next_ckpt = _next_multiple(self.counters.frames, c.log.checkpoint_every_frames)
        row: dict = {}
        last_eval: float | str = ""
        update_debt = 0.0
        stop: list[int] = []  # signals received (``_stop_on_signals``)
        with _stop_on_signals(stop):
            try:
                for data in collector:
                    data = data.reshape(-1)
                    self._record_episodes(data)
                    self.buffer.extend(data.select(*self.stored_keys).cpu())
                    n = data.numel()
                    before = self.counters.frames
                    self.counters.frames += n
                    # Updates per step collected after the random warm-up.
                    learn_frames = self.counters.frames - max(before, c.collector.init_random_frames)
                    if learn_frames > 0:
                        update_debt += learn_frames * c.optim.updates_per_step
                        while update_debt >= 1.0:
                            self._update(self.buffer.sample())
                            update_debt -= 1.0
                    collector.update_policy_weights_()
                    self.counters.wall_s = wall_before + time.perf_counter() - session_start
                    if bar is not None:
                        bar.update(n)
                    evaluation = None
                    if self.counters.frames >= next_eval:
                        evaluation = self.evaluate()
                        next_eval = _next_multiple(self.counters.frames, c.log.eval_every_frames)
                    if self.counters.frames >= next_log or evaluation is not None:
                        row = self._log_row(start_frames, session_start, evaluation)
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
                        self.save()
                        raise TrainingInterrupted(signal.Signals(stop[0]).name, self.counters.frames,
                                                  self.checkpoint_path)
            finally:
                collector.shutdown()
                writer.close()
                csv_file.close()
                if bar is not None:
                    bar.close()
        return row

    def evaluate(self) -> dict:
        """Deterministic evaluation on the fixed seeded episode set; keeps the best policy."""
        c = self.config
        result = evaluate_policy(self.actor, self.eval_task_config, episodes=c.log.eval_episodes,
                                 max_steps=EVAL_MAX_STEPS, window=self.window)
        if result["return_norm"] > self.counters.best_eval:
            self.counters.best_eval = result["return_norm"]
            self.save_policy(self.run_dir / "best_policy.pt", {**result, "frames": self.counters.frames})
        return result

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
def evaluate_policy(policy, task_config: TaskConfig, episodes: int = 8, max_steps: int = 500, window: int = 8,
                    seed: int = EVAL_SEED) -> dict:
    """The evaluation a run makes every ``log.eval_every_frames`` (its best policy is kept by it):
    fly ``episodes`` episodes side by side with the deterministic policy, each once.

    Returns the mean normalised return (episode reward / max_steps, the paper's Fig. 8; always with Eq. 22's
    reward and the policy on the throttle, whatever reward weights, penalty tail and external throttle the run
    trains with; ``Trainer`` passes the paper's disturbances, whatever turbulence and delay it trains in), the mean
    episode length and the number of episodes that ended early (terminated, not truncated).
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


class TrainingInterrupted(Exception):
    """SIGINT or SIGTERM stopped training; the checkpoint was written first."""

    def __init__(self, signal_name: str, frames: int, checkpoint: Path):
        self.signal_name, self.frames, self.checkpoint = signal_name, frames, checkpoint
        super().__init__(f"{signal_name} at {frames:,} env steps; checkpoint written to {checkpoint}")


@contextlib.contextmanager
def _stop_on_signals(flag: list):
    """While inside, SIGINT and SIGTERM only append their number to ``flag`` (the loop checks it
    between batches, so the checkpoint is never written from the middle of an update). Outside the
    main thread signals cannot be caught, and nothing changes."""
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

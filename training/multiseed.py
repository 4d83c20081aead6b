"""Several seeds of one configuration, each its own run (folder, checkpoints, resume), as Ray tasks
or in a process pool, with a summary over the seeds at the end (the paper's Fig. 8 with its spread).

Each seed trains in ``RUN_ROOT/<name>_seed<N>`` on one torch thread. Running the same command
again resumes every seed from its checkpoint, so a killed batch loses at most one checkpoint
interval per seed; a seed that stopped before its first checkpoint starts afresh (``Trainer``:
its logs are replaced, and a best policy without a checkpoint is refused rather than replaced).
A resumed seed must have the same settings (the checkpoint's fingerprint), else it is refused.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from training.config import TrainConfig, check_run_name
from training.ray_session import ray_session

TRAINING_STOP_GRACE_S = 120.0  # a stopped seed's last batch and checkpoint, before it is killed


def train_seed(config: dict, run_dir: str, command: list[str]) -> dict:
    """Train (or resume) one seed's run; returns its last log row with ``run_dir``."""
    from training.provenance import append_session
    from training.runtime import tune_allocator
    from training.trainer import Trainer

    tune_allocator()
    path = Path(run_dir)
    resume = (path / "checkpoint.pt").is_file()
    trainer = Trainer(TrainConfig.from_dict(config), path, resume=resume)
    for note in trainer.notes:
        print(f"train_torchrl: {note}", file=sys.stderr)
    append_session(path, command, trainer.counters.frames, trainer.aircraft.fingerprint)
    return {"run_dir": run_dir, "resumed": resume, **trainer.train()}


def seed_runs(config: TrainConfig, seeds: list[int], name: str) -> list[tuple[dict, str]]:
    """(settings, run folder) of each seed; ``ValueError`` for a seed or a name that is not allowed."""
    check_run_name(name)
    out = []
    for seed in seeds:
        c = TrainConfig.from_dict({**config.to_dict(), "seed": seed, "threads": 1})  # checked, as every setting
        out.append((c.to_dict(), str(Path(c.log.run_root) / f"{name}_seed{seed}")))
    return out


def train_seeds(config: TrainConfig, seeds: list[int], name: str, command: list[str], backend: str = "local",
                workers: int = 1, address: str | None = None) -> list[dict]:
    """Train every seed (``backend`` "local": ``workers`` processes; "ray": Ray tasks, a local Ray
    instance unless ``address`` names a cluster); returns their last log rows, in seed order."""
    if len(set(seeds)) != len(seeds) or not seeds:
        raise ValueError(f"seeds must be distinct and at least one, got {seeds}")
    runs = seed_runs(config, seeds, name)
    if backend == "ray":
        with ray_session(address) as ray:
            task = ray.remote(num_cpus=1, max_retries=0)(train_seed)
            return ray.get([task.remote(c, d, command) for c, d in runs])
    if backend != "local":
        raise ValueError(f"backend must be 'local' or 'ray', got {backend!r}")
    if workers <= 1:
        return [train_seed(c, d, command) for c, d in runs]
    from training.workers import process_pool

    # A training stopped by SIGINT or SIGTERM writes its checkpoint at the end of its batch first.
    with process_pool(workers, grace_s=TRAINING_STOP_GRACE_S, jobs=len(runs)) as pool:
        return list(pool.map(train_seed, *zip(*[(c, d, command) for c, d in runs])))


def seeds_summary(run_dirs: list[Path], figure: Path | None = None) -> dict:
    """Each run's summary (``curves.run_summary``) and the final evaluation return over the seeds
    (mean, min, max); the Fig. 8 curves with their spread to ``figure``."""
    from training.curves import plot_curves, run_summary

    runs = [run_summary(Path(d)) for d in run_dirs]
    finals = [r["final_eval_return"] for r in runs if r.get("final_eval_return") is not None]
    out = {"runs": runs}
    if finals:
        out["final_eval_return"] = {"mean": float(np.mean(finals)), "min": float(min(finals)),
                                    "max": float(max(finals)), "seeds": len(finals)}
    if figure is not None:
        plot_curves([Path(d) for d in run_dirs], figure)
        out["figure"] = str(figure)
    return out


__all__ = ["seed_runs", "seeds_summary", "train_seed", "train_seeds"]

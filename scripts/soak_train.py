"""Soak: one long training run with its resident memory sampled over time (Linux: /proc).

    python scripts/soak_train.py --out runs/soak                  # 1,000,000 env steps
    python scripts/soak_train.py --out runs/soak --frames 200000 --capacity 50000

Starts ``scripts/train_torchrl.py`` (or resumes it: the soak's run folder is ``OUT/run``, and a
killed soak goes on from its last checkpoint; one killed before its first checkpoint is moved
aside and starts again), samples the trainer's resident set size every
``--sample-s`` seconds into ``OUT/memory.csv`` (wall time, env steps, RSS) and ``OUT/memory.png``,
and prints a summary:
RSS when the replay buffer fills, at the end, its maximum, and the growth per 100,000 steps after
the buffer is full (a least-squares slope), which a leak-free run keeps near zero. The learning
settings are the default run's, but with fewer updates per step (``--updates-per-step``) so that
a million steps take under an hour on one core: memory is what is measured here, not learning.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from training.progress_log import read_progress
from training.runtime import (
    OutputFolderError,
    ScriptParser,
    check_output_folder,
    number_type,
    positive_float,
    run_command,
    seed_int,
)


def rss_mib(pid: int) -> float | None:
    """Resident set size of a process, MiB (None once it has exited)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def frames_done(run_dir: Path) -> int:
    """Env steps of the last readable progress row (0 before the first). The trainer may be
    writing a row as it is read, and a killed one leaves a torn row or zeros: those are skipped."""
    try:
        rows, _ = read_progress(run_dir / "progress.csv")
    except OSError:
        return 0
    return int(rows[-1]["frames"]) if rows else 0


def training_command(args, run_dir: Path) -> tuple[list[str], bool]:
    """The options of ``train_torchrl.py`` for this soak, and whether they start it afresh: a run
    with a checkpoint is resumed; a run folder without one (the soak was killed before its first
    checkpoint, every 100,000 steps) is moved aside, with its memory samples, to
    ``OUT/run.stopped-<time>``, and the soak starts again."""
    common = ["--collector.total_frames", str(args.frames), "--log.progress", "false"]
    if (run_dir / "checkpoint.pt").exists():
        return ["--resume", str(run_dir), *common], False
    memory = args.out / "memory.csv"
    if not run_dir.exists() and _trained_samples(memory):  # a soak whose run folder was removed: its results stay
        raise OutputFolderError(f"{args.out} holds the memory samples of an earlier soak ({memory.name}) and no run "
                                "to resume: give another --out")
    if run_dir.exists():
        _check_not_training(run_dir)
        aside = run_dir.with_name(f"{run_dir.name}.stopped-{time.strftime('%Y%m%d-%H%M%S')}")
        run_dir.rename(aside)
        if memory.exists():
            memory.rename(aside / memory.name)
        print(f"soak: {run_dir} stopped before its first checkpoint; moved to {aside}, and the soak starts again",
              file=sys.stderr)
    return ["--seed", str(args.seed), "--log.run_root", str(args.out), "--run-name", run_dir.name,
            "--buffer.capacity", str(args.capacity), "--optim.updates_per_step", str(args.updates_per_step),
            "--log.checkpoint_every_frames", "100000", *common], True


def _trained_samples(memory_csv: Path) -> bool:
    """Whether a memory log holds samples taken while a run trained (steps above 0), not only those
    of a start that failed before its first step."""
    try:
        rows = list(csv.DictReader(memory_csv.open()))
    except OSError:
        return False
    return any(row.get("frames", "").isdigit() and int(row["frames"]) > 0 for row in rows)


def _check_not_training(run_dir: Path) -> None:
    """``OutputFolderError`` when a trainer holds the run folder's lock (a soak whose trainer
    outlived it): its folder is not to be moved."""
    try:
        import fcntl
    except ImportError:
        return
    lock = run_dir / ".lock"
    if not lock.exists():
        return
    with lock.open("a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise OutputFolderError(f"a trainer is still running in {run_dir}: stop it first") from None
        fcntl.flock(handle, fcntl.LOCK_UN)


def summarise(samples: np.ndarray, capacity: int) -> dict:
    """Figures of (wall s, frames, RSS MiB) rows."""
    if samples.size == 0:
        return {"samples": 0}
    frames, rss = samples[:, 1], samples[:, 2]
    full = frames >= capacity
    out = {"samples": len(samples), "frames": int(frames.max()), "rss_start_mib": float(rss[0]),
           "rss_max_mib": float(rss.max()), "rss_end_mib": float(rss[-1]), "buffer_capacity": capacity}
    if full.sum() >= 3 and np.ptp(frames[full]) > 0:
        slope = np.polyfit(frames[full], rss[full], 1)[0]
        out.update(rss_at_buffer_full_mib=float(rss[full][0]), growth_after_full_mib_per_100k_steps=float(slope * 1e5),
                   steps_after_full=int(np.ptp(frames[full])))
    return out


def plot_memory(rows: np.ndarray, capacity: int, path: Path) -> None:
    """Resident memory against env steps, with the step at which the buffer is full."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(rows[:, 1] / 1e3, rows[:, 2], ".-", ms=3)
    ax.axvline(capacity / 1e3, color="grey", ls="--", lw=0.8, label="replay buffer full")
    ax.set_xlabel("env steps, thousands")
    ax.set_ylabel("resident memory, MiB")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="soak folder (the run is OUT/run)")
    p.add_argument("--frames", type=number_type(int, 1, 1_000_000_000), default=1_000_000, help="env steps in all")
    p.add_argument("--capacity", type=number_type(int, 1, 1_000_000_000), default=200_000, help="replay capacity, transitions")
    p.add_argument("--updates-per-step", type=positive_float, default=0.02, help="gradient steps per env step")
    p.add_argument("--sample-s", type=positive_float, default=20.0, help="seconds between memory samples")
    p.add_argument("--seed", type=seed_int, default=0, help="training seed")
    args = p.parse_args(argv)
    if not Path("/proc/self/status").exists():
        p.error("the soak reads memory from /proc, which this system lacks")
    try:
        check_output_folder(args.out)
    except OutputFolderError as err:
        print(f"soak: --out: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    run_dir = args.out / "run"
    try:
        cmd, fresh = training_command(args, run_dir)
    except (OSError, OutputFolderError) as err:
        print(f"soak: {err}", file=sys.stderr)
        return 2
    script = Path(__file__).resolve().parent / "train_torchrl.py"
    memory_csv = args.out / "memory.csv"
    new_file = fresh or not memory_csv.exists()  # a new run's samples start a new file
    with memory_csv.open("w" if new_file else "a", newline="") as fh, open(args.out / "train.log", "a") as log:
        writer = csv.writer(fh)
        if new_file:
            writer.writerow(["wall_s", "frames", "rss_mib"])
        proc = subprocess.Popen([sys.executable, str(script), *cmd], stdout=log, stderr=log)
        start = time.perf_counter()
        while proc.poll() is None:
            rss = rss_mib(proc.pid)
            if rss is not None:
                writer.writerow([round(time.perf_counter() - start, 1), frames_done(run_dir), round(rss, 1)])
                fh.flush()
            time.sleep(args.sample_s)
    if proc.returncode != 0:
        print(f"soak: training exited with code {proc.returncode}; see {args.out / 'train.log'}", file=sys.stderr)
        return proc.returncode
    rows = np.loadtxt(memory_csv, delimiter=",", skiprows=1, ndmin=2)
    config = json.loads((run_dir / "config.json").read_text())
    capacity = int(config["buffer"]["capacity"])
    summary = summarise(rows, capacity)
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    plot_memory(rows, capacity, args.out / "memory.png")
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

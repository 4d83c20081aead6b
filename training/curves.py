"""Training curves (the paper's Fig. 8) and per-run summaries from a run folder's ``progress.csv``.

``run_summary`` gives a run's training wall-clock, its final evaluation return (the mean of the
last ``final_evals`` evaluations, since one evaluation is noisy), the environment steps at which
the evaluation return first reached 0.9 of that final value, and those at which it first made 0.9
of its gain over the first evaluation (the untrained policy already scores about 0.13, so a run
that never learned reaches 0.9 of its final value at once).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from training.progress_log import read_progress


def load_curve(run_dir: Path, key: str, x: str = "frames") -> tuple[np.ndarray, np.ndarray]:
    rows = [r for r in read_progress(run_dir / "progress.csv")[0] if r.get(key, "") != ""]
    return np.array([float(r[x]) for r in rows]), np.array([float(r[key]) for r in rows])


def run_summary(run_dir: Path, final_evals: int = 3) -> dict:
    """Wall-clock time, final evaluation return and the steps to 0.9 of it, from ``progress.csv``."""
    if final_evals < 1:
        raise ValueError(f"final_evals must be at least 1, not {final_evals}")
    rows = read_progress(run_dir / "progress.csv")[0]
    if not rows:
        raise ValueError(f"{run_dir}/progress.csv has no rows yet")
    frames, evals = load_curve(run_dir, "eval_return_norm")
    summary = {"run": str(run_dir), "frames": int(rows[-1]["frames"]), "updates": int(rows[-1]["updates"]),
               "wall_h": float(rows[-1]["wall_s"]) / 3600.0}
    if evals.size:
        final = float(evals[-final_evals:].mean())
        reached = np.nonzero(evals >= 0.9 * final)[0]
        gained = np.nonzero(evals >= evals[0] + 0.9 * (final - evals[0]))[0]
        summary.update(final_eval_return=final, best_eval_return=float(evals.max()),
                       best_eval_frames=int(frames[np.argmax(evals)]),
                       frames_to_90pct_of_final=int(frames[reached[0]]) if reached.size else None,
                       frames_to_90pct_of_gain=int(frames[gained[0]]) if final > evals[0] else None)
    return summary


def plot_curves(runs: list[Path], out: Path) -> None:
    """The paper's Fig. 8 from the runs' ``progress.csv``: episode length, training and evaluation return
    against environment steps, and the evaluation return against wall-clock; mean and min-max."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(18, 4))
    panels = (("episode_length", "episode length", "frames"),
              ("episode_return_norm", "normalised return (training)", "frames"),
              ("eval_return_norm", "normalised return (deterministic evaluation)", "frames"),
              ("eval_return_norm", "normalised return (deterministic evaluation)", "wall_s"))
    for ax, (key, label, x_key) in zip(axes, panels):
        curves = [load_curve(r, key, x_key) for r in runs]
        curves = [c for c in curves if c[0].size]
        if not curves:
            continue
        scale = 1 / 60 if x_key == "wall_s" else 1.0  # wall-clock in minutes
        grid = np.linspace(0, min(c[0][-1] for c in curves), 100)
        values = np.array([np.interp(grid, x, y) for x, y in curves])
        ax.plot(grid * scale, values.mean(axis=0), label=f"mean of {len(curves)} runs")
        ax.fill_between(grid * scale, values.min(axis=0), values.max(axis=0), alpha=0.3, label="min-max")
        if x_key == "wall_s":
            ax.set_xlabel("training wall-clock, min")
        else:
            ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda x, _: f"{x / 1000:.0f}k"))
            ax.set_xlabel("environment steps")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


__all__ = ["load_curve", "plot_curves", "run_summary"]

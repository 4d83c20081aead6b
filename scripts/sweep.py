"""Robustness sweep: controllers over a grid of conditions, on identical seeded episodes.

    python scripts/sweep.py --axis delay_ms=0,100,200,300 --axis noise_scale=0,2,8 --episodes 10
    python scripts/sweep.py --axis turbulence_sigma_mps=0,1,2,3 --backend ray
    python scripts/sweep.py --axis backlash_deg=0,0.5,1 --controllers pid --backend local --workers 2

Writes to ``--out``: ``sweep.csv`` (one row per controller x condition x episode: return, early
end and why, RMSE per axis, error over the last 2 s, surface activity), ``sweep.json`` (the rows,
the command and a summary: mean return and early ends per controller and condition, and where
each controller first ended an episode early along each axis), ``command.txt`` and one PNG per
axis (each controller's mean return and pitch RMSE against the axis, with their spread over
episodes and the other axes). Axes, units and the range of each: ``training/evaluation/sweep.py``.

Every argument is checked before the first flight: an axis value outside its range, an axis given
twice, a value given twice, or an ``--out`` that cannot be written is one line on stderr and exit
code 2. An ``--out`` that holds an earlier sweep's results is refused unless ``--overwrite``, which
replaces the files the earlier sweep recorded (``training.output_folders``: a folder of another
command, or holding files no earlier sweep recorded, is refused). The results are written to a
temporary folder and moved into place at the end: an error or a Ctrl-C leaves the earlier ones.
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

# None of these loads torch, ray or onnxruntime: those load when flying, after the arguments are parsed.
from jsbsim_env.control.factory import CONTROLLER_NAMES, check_flyable
from jsbsim_env.control.gain_files import GainsMissing, GainTableError
from jsbsim_env.task.metrics import json_ready
from training.evaluation.seeds import check_not_test_seed
from training.evaluation.sweep import (
    AXES,
    AXIS_RANGES,
    AXIS_UNITS,
    SWEEP_EPISODE_SEED,
    breaking_points,
    grid,
    jobs_for,
    parse_axes,
    run_local,
    run_ray,
)
from training.output_folders import OutputFolder, writing
from training.runtime import (
    OutputFolderError,
    ScriptParser,
    add_aircraft_options,
    episodes_int,
    run_command,
    workers_int,
)
from training.workers import pool_size

# The files a sweep writes to --out (an earlier sweep's are refused, or replaced with --overwrite).
RESULTS = ("sweep.csv", "sweep.json", "command.txt", *(f"{axis}.png" for axis in AXES))


def build_parser() -> argparse.ArgumentParser:
    p = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    p.add_argument("--axis", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="an axis and its values (repeatable, each axis once): " + ", ".join(
                       f"{k} {AXIS_RANGES[k].text(v)}" for k, v in AXIS_UNITS.items()))
    p.add_argument("--controllers", default="policy,pid", help=f"comma-separated, any of: {', '.join(CONTROLLER_NAMES)}")
    add_aircraft_options(p, "the altitude and EAS axes take its envelope")
    p.add_argument("--policy", default=None, help="policy file (.pt); the shipped policy when omitted")
    p.add_argument("--episodes", type=episodes_int, default=10, help="seeded episodes per controller and condition")
    p.add_argument("--out", type=Path, default=Path("runs/sweep"), help="folder for the table, JSON and plots")
    p.add_argument("--overwrite", action="store_true", help="replace the results of an earlier sweep in --out")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local: a process pool; ray: Ray tasks (pip install '.[ray]')")
    p.add_argument("--workers", type=workers_int, default=1, help="processes of the local backend")
    p.add_argument("--address", default=None, help="ray backend: a cluster's address ('auto': this machine's); "
                                                   "a local Ray instance when omitted")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    return p


def parse_args(argv=None) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def summarise(rows: list[dict], axes: dict[str, list[float]]) -> dict:
    """Mean return, early ends and pitch RMSE per controller and condition; breaking points."""
    keys = [f"axis_{a}" for a in axes]
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["controller"], *(r[k] for k in keys)), []).append(r)
    table = [{"controller": g[0], **dict(zip(axes, g[1:])), "episodes": len(rs),
              "mean_return": float(np.mean([r["return_norm"] for r in rs])),
              "early_ends": sum(r["ended_early"] for r in rs),
              "mean_rmse_pitch_deg": float(np.mean([r["rmse_pitch_deg"] for r in rs])),
              "mean_rmse_beta_deg": float(np.mean([r["rmse_beta_deg"] for r in rs]))} for g, rs in groups.items()]
    return {"conditions": table, "first_early_end": {a: breaking_points(rows, a) for a in axes}}


def plot_axis(rows: list[dict], axis: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    for c in sorted({r["controller"] for r in rows}):
        mine = [r for r in rows if r["controller"] == c]
        values = sorted({r[f"axis_{axis}"] for r in mine})
        for j, (key, label) in enumerate((("return_norm", "normalised return"), ("rmse_pitch_deg", "pitch RMSE, deg"))):
            per = [np.array([r[key] for r in mine if r[f"axis_{axis}"] == v]) for v in values]
            mean = np.array([p.mean() for p in per])
            ax[j].plot(values, mean, "o-", label=c)
            ax[j].fill_between(values, [np.percentile(p, 10) for p in per], [np.percentile(p, 90) for p in per],
                               alpha=0.2)
            ax[j].set_ylabel(label)
            ax[j].set_xlabel(f"{axis} ({AXIS_UNITS[axis]})")
    ax[0].legend()
    fig.suptitle(f"sweep over {axis}: mean and 10-90 % of episodes")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        axes = parse_axes(args.axis, args.aircraft)
        if not axes:
            raise ValueError("give at least one --axis NAME=V1,V2,...")
        controllers = [c.strip() for c in args.controllers.split(",") if c.strip()]
        bad = [c for c in controllers if c not in CONTROLLER_NAMES]
        if bad or not controllers:
            raise ValueError(f"--controllers takes any of {', '.join(CONTROLLER_NAMES)}, got {args.controllers!r}")
        check_not_test_seed(range(SWEEP_EPISODE_SEED, SWEEP_EPISODE_SEED + args.episodes), "sweep")
    except ValueError as err:
        print(f"sweep: {err}", file=sys.stderr)
        return 2
    command = shlex.join(["python", "scripts/sweep.py", *(sys.argv[1:] if argv is None else argv)])
    out = OutputFolder(args.out, "sweep", RESULTS, args.overwrite, command)
    try:
        out.claim()
    except OutputFolderError as err:
        print(f"sweep: --out: {err}", file=sys.stderr)
        return 2
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    policies = {"policy": args.policy or shipped_policy_path()} if "policy" in controllers else {}
    try:  # gain tables and the policy file read and checked once here, not in every worker
        check_flyable(controllers, args.aircraft, policies, args.transfer)
    except (PolicyFileError, GainsMissing, GainTableError) as err:
        print(f"sweep: {err}", file=sys.stderr)
        return 2
    from tqdm import tqdm

    jobs = jobs_for(controllers, grid(axes), args.episodes, aircraft=args.aircraft, transfer=args.transfer)
    bar = tqdm(total=len(jobs), desc=f"sweep ({args.backend})", unit="job", file=sys.stderr)
    started = time.perf_counter()
    workers = pool_size(args.workers, len(jobs))
    try:
        info = {"cpus": float(workers)}
        if args.backend == "ray":
            rows = run_ray(jobs, args.policy, args.address, bar.update, info)
        else:
            rows = run_local(jobs, args.policy, workers, bar.update)
    except RuntimeError as err:
        print(f"sweep: {err}", file=sys.stderr)
        return 2
    finally:
        bar.close()
    wall_s = time.perf_counter() - started
    flights = len(rows)
    summary = {"command": command, "backend": args.backend, "cores": info["cpus"], "wall_s": wall_s,
               "flights": flights, "flights_per_core_second": flights / (wall_s * info["cpus"]),
               **summarise(rows, axes)}
    try:
        with writing(out) as staging:
            (staging / "command.txt").write_text(command + "\n")
            with (staging / "sweep.csv").open("w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
                writer.writeheader()
                writer.writerows(rows)
            (staging / "sweep.json").write_text(json.dumps(json_ready({**summary, "rows": rows}), indent=1))
            for axis in axes:
                plot_axis(rows, axis, staging / f"{axis}.png")
    except OutputFolderError as err:  # the folder changed during the flights
        print(f"sweep: --out: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(json_ready(summary), indent=1))
    else:
        print(f"{flights} flights in {wall_s:.0f} s; written to {args.out}/")
        for axis, points in summary["first_early_end"].items():
            print(f"  first early end along {axis}: " + ", ".join(
                f"{c} {'never' if v is None else f'at {v:g} {AXIS_UNITS[axis]}'}" for c, v in points.items()))
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

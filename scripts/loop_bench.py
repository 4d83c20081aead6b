"""The loop bench: the attitude controller in its own process over a serial line (MAVLink v2 on a
pseudo-terminal, or a real port), against the aircraft model in real time or in lockstep.

    python scripts/loop_bench.py                          # shipped policy, real time, 60 s
    python scripts/loop_bench.py --mode lockstep --controller pid --json
    python scripts/loop_bench.py --faults drop=0.05,corrupt=0.01,disconnect_at=20

Flies the 10 km route's turbulent leg (``jsbsim_env.bench.plant.bench_route``), then flies the
same route in this process with the same controller and seed, and prints the loop's figures
(latency, missed deadlines, dropped frames, CRC errors, failsafe hand-overs, tracking RMSE beside
the in-process run's). Writes ``summary.json``, ``frames.npz`` and ``loop_bench.png`` to ``--out``.
With ``--device`` the plant opens that port and waits for a controller started elsewhere with
``python -m jsbsim_env.bench.node --device PORT``.

Every option is checked before the controller process starts (one line on stderr, exit code 2): a
number out of its range, a fault that is not known, out of range or given twice, a fault after the
flight's end, and in real time a line too slow (``--baud``) or too late (``delay_ms``) for any answer
to arrive within the failsafe's hold time (``jsbsim_env.bench.plant``: 50.8 ms of ``delay_ms`` at the
defaults). An ``--out`` that holds an earlier bench's results is refused unless ``--overwrite`` (a
folder of another command, or holding files no earlier bench recorded, always:
``training.output_folders``); the results are moved into it only when all are written. A
controller process that dies during the flight is survived: the failsafe PID flies on, and the
summary records when (``controller_lost_at_s``).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from aircraft import load_aircraft
from training.output_folders import OutputFolder, writing
from training.runtime import (
    CONTROLLER_NAMES,
    OutputFolderError,
    ScriptParser,
    add_aircraft_options,
    non_negative_int,
    number_type,
    run_command,
    seed_int,
)

# The files a bench writes to --out (an earlier bench's are refused, or replaced with --overwrite).
RESULTS = ("summary.json", "frames.npz", "loop_bench.png")
MAX_DURATION_S = 3600.0  # jsbsim_env.bench.plant.MAX_DURATION_S (not imported here: it loads pymavlink)
MIN_DURATION_S = 2.0  # jsbsim_env.bench.plant.MIN_DURATION_S: the shortest flight whose RMSE means something


def build_parser() -> argparse.ArgumentParser:
    p = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    p.add_argument("--mode", choices=("realtime", "lockstep"), default="realtime",
                   help="realtime: 25 Hz frame clock with deadlines; lockstep: wait for every answer (deterministic)")
    p.add_argument("--controller", choices=CONTROLLER_NAMES, default="policy",
                   help="the controller process flies this (factory.CONTROLLER_NAMES)")
    p.add_argument("--policy", default=None, help="policy file (.pt); the shipped policy when omitted")
    add_aircraft_options(p, "the route flies at the middle of its envelope")
    p.add_argument("--duration", type=number_type(float, MIN_DURATION_S, MAX_DURATION_S, unit="s"), default=60.0,
                   help="flight time, s")
    p.add_argument("--baud", type=number_type(int, 1, 4_000_000), default=115_200,
                   help="line rate, bit/s (10 bits a byte; in real time, fast enough for a frame's round trip)")
    p.add_argument("--faults", default="",
                   help="comma-separated: drop=P, corrupt=P (per frame and direction), delay_ms=MS, "
                        "disconnect_at=S, disconnect_s=S, stall_at=S, stall_s=S (flight time, s)")
    p.add_argument("--device", default=None, help="a real serial port; the controller runs elsewhere (module docstring)")
    p.add_argument("--seed", type=seed_int, default=0, help="seed of the flight (turbulence, noise) and of the faults")
    p.add_argument("--timeout-frames", type=non_negative_int, default=3,
                   help="frames the last command is held before the PID flies (0: the PID flies at the first miss)")
    p.add_argument("--recover-frames", type=number_type(int, 1, 1000), default=5,
                   help="answers on time in a row before the controller flies again")
    p.add_argument("--no-compare", action="store_true", help="skip the in-process flight of the same route")
    p.add_argument("--out", default="runs/loop_bench", help="folder for summary.json, frames.npz, loop_bench.png")
    p.add_argument("--overwrite", action="store_true", help="replace the results of an earlier bench in --out")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout (messages go to stderr)")
    return p


def parse_args(argv=None) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def bench_config(args: argparse.Namespace):
    """The bench flight the arguments ask for (``jsbsim_env.bench.plant.BenchConfig``); ``ValueError``
    (one line) for one that cannot be flown."""
    from jsbsim_env.bench.link import Faults
    from jsbsim_env.bench.plant import BenchConfig

    load_aircraft(args.aircraft)  # an AircraftError (a ValueError) names what the value is instead
    return BenchConfig(mode=args.mode, controller=args.controller, policy=args.policy, aircraft=args.aircraft,
                       transfer=args.transfer, duration_s=args.duration,
                       baud=args.baud, faults=Faults.parse(args.faults), device=args.device, seed=args.seed,
                       timeout_frames=args.timeout_frames, recover_frames=args.recover_frames)


def in_process(args) -> dict:
    """The same route, controller and seed flown in this process (``missions.fly_route``)."""
    from jsbsim_env.bench.plant import bench_route
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.missions import fly_route

    result = fly_route(make_controller(args.controller, args.policy, aircraft=args.aircraft, transfer=args.transfer),
                       bench_route(args.duration, args.seed, args.aircraft))
    return {"tracking_rmse": {k[len("rmse_"):]: v for k, v in result.metrics().items() if k.startswith("rmse_")},
            "ended_early": result.ended_early}


def main(argv=None) -> int:
    args = parse_args(argv)
    from jsbsim_env.bench.plant import plot_bench, run_bench
    from jsbsim_env.task.metrics import json_ready

    try:
        cfg = bench_config(args)
    except ValueError as exc:
        print(f"loop_bench: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    command = shlex.join(["python", "scripts/loop_bench.py", *(sys.argv[1:] if argv is None else argv)])
    folder = OutputFolder(out, "loop_bench", RESULTS, args.overwrite, command)
    try:
        folder.claim()
    except OutputFolderError as exc:
        print(f"loop_bench: --out: {exc}", file=sys.stderr)
        return 2
    from jsbsim_env.control.factory import check_flyable
    from jsbsim_env.control.gain_files import GainsMissing, GainTableError
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    # The controller's gain table or policy file, and the failsafe PID's table, read and checked
    # here, before the controller process starts.
    policies = {"policy": args.policy or shipped_policy_path()} if args.controller == "policy" else {}
    try:
        check_flyable({args.controller, "pid"}, args.aircraft, policies, args.transfer)
    except (PolicyFileError, GainsMissing, GainTableError) as exc:
        print(f"loop_bench: {exc}", file=sys.stderr)
        return 2
    from tqdm import tqdm

    bar = tqdm(total=100, desc=f"{args.mode} flight", unit="%", file=sys.stderr, leave=False)

    def progress(fraction: float) -> None:
        bar.n = round(100 * fraction)
        bar.refresh()

    started = time.perf_counter()
    try:
        result = run_bench(cfg, progress)
    except RuntimeError as exc:
        print(f"loop_bench: {exc}", file=sys.stderr)
        return 1
    finally:
        bar.close()
    summary = dict(result.summary)
    summary["bench_wall_s"] = time.perf_counter() - started
    if not args.no_compare:
        ref = in_process(args)
        ratio = {k: (summary["tracking_rmse"][k] / v if v else None) for k, v in ref["tracking_rmse"].items()}
        summary["in_process"] = {**ref, "rmse_ratio": ratio}
    summary = json_ready(summary)
    try:
        with writing(folder) as staging:
            (staging / "summary.json").write_text(json.dumps(summary, indent=1))
            np.savez_compressed(staging / "frames.npz", **result.frames)
            plot_bench(result, staging / "loop_bench.png")
    except OutputFolderError as exc:  # the folder changed during the flight
        print(f"loop_bench: --out: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        s = summary
        lat = s["latency_ms"]
        latency = "/".join("-" if lat[k] is None else f"{lat[k]:.1f}" for k in ("p50", "p99", "max"))
        print(f"{s['frames']} frames, {s['mode']}, {s['controller']}: missed deadlines {s['missed_deadlines']}, "
              f"latency p50/p99/max {latency} ms, dropped {s['dropped_frames']}, "
              f"CRC errors {s['crc_errors']}, failsafe take-overs {s['failsafe_takeovers']}, "
              f"ended early: {s['ended_early'] or 'no'}")
        rm = s["tracking_rmse"]
        line = "tracking RMSE roll/pitch/EAS/sideslip " + " / ".join(f"{rm[k]:.3f}" for k in rm)
        if "in_process" in s:
            line += "  (in process: " + " / ".join(f"{v:.3f}" for v in s["in_process"]["tracking_rmse"].values()) + ")"
        print(line)
        for e in s["failsafe_events"]:
            print(f"  {e['time_s']:8.2f} s  {e['event']}")
        if s["controller_lost_at_s"] is not None:
            print(f"the controller process died (exit code {s['controller_exit_code']}), noticed at "
                  f"{s['controller_lost_at_s']:.2f} s: the failsafe PID flew the rest of the flight")
        print(f"written to {out}/")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

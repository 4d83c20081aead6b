"""Fly the shipped controller (or ``--policy PATH``, or the PID baseline) on the fixed evaluation
suite and print the metrics; or, with ``--compare``, policy files beside the shipped policy and
the PID on the same suite.

    python scripts/evaluate.py --json                   # metrics as JSON
    python scripts/evaluate.py --plots results/eval     # and the Fig. 9 time histories
    python scripts/evaluate.py --controller pid --json  # the gain-scheduled PID on the same suite
    python scripts/evaluate.py --compare runs/a/best_policy.pt runs/b/best_policy.pt   # one table

The suite (``training.evaluation.suite``): the doublets at three altitudes, then ``--episodes``
seeded training-style episodes; every controller flies the same ones. A ``--plots`` folder that
holds an earlier evaluation's plots is refused unless ``--overwrite``, which replaces them (a folder
of another command, or holding plots no earlier evaluation recorded, always:
``training.output_folders``); the plots are moved into it when the suite has been flown.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

# Only the standard library and training.runtime (no torch) load before the arguments are parsed,
# so that a mistyped option is refused at once; the simulation and the networks load in main().
from training.output_folders import OutputFolder, writing
from training.runtime import (
    CONTROLLER_NAMES,
    OutputFolderError,
    ScriptParser,
    add_aircraft_options,
    episodes_int,
    run_command,
)

SHIPPED, PID = "shipped", "PID"  # column names of --compare
# The classical controllers' keys in the JSON output, and what it says about each.
_LABELS = {"pid": PID, "lqi": "LQI", "pid_tuned": "PID_tuned", "lqi_tuned": "LQI_tuned", "pid_robust": "PID_robust",
           "lqi_robust": "LQI_robust", "lqi_stressed": "LQI_stressed"}
_ABOUT = {"pid": "gain-scheduled PID", "lqi": "gain-scheduled LQI",
          "pid_tuned": "gain-scheduled PID, tuned on nonlinear flights",
          "lqi_tuned": "gain-scheduled LQI, tuned on nonlinear flights",
          "pid_robust": "gain-scheduled PID, tuned on nonlinear flights in the training episodes' conditions",
          "lqi_robust": "gain-scheduled LQI, tuned on nonlinear flights in the training episodes' conditions",
          "lqi_stressed": "gain-scheduled LQI, tuned on nonlinear flights with a long delay and a slow servo among them"}
DEFAULT_EPISODES = 50
# The files --plots receives (training.evaluation.suite.doublet_runs): an earlier evaluation's are
# refused, or replaced with --overwrite.
PLOT_RESULTS = ("doublets_*m.png", "doublets_*m.npz")


def why_null(path: str) -> str:
    """Why a metric of the suite has no value."""
    if "settling" in path:
        return "never settled: the error was still outside 10 % of the step when the next step came"
    if "steady_state" in path:
        return "no samples: the episode ended before this step's last 2 s"
    return "not a finite number"


class _HelpWithSuite(argparse.Action):
    """``-h``/``--help``, with the suite's episode seeds read from the suite itself (loaded only
    when the help is asked for, like the rest of the simulation)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from training.evaluation.suite import DOUBLET_ALTITUDES_M, EVAL_EPISODE_SEED

        parser.epilog = (f"Seeds: the doublets fly at {', '.join(f'{a:.0f}' for a in DOUBLET_ALTITUDES_M)} m on the "
                         "paper's aircraft, at the same fractions of another's envelope with --aircraft "
                         f"(seeded by their altitude); episode k of --episodes has seed {EVAL_EPISODE_SEED} + k "
                         f"(the default {DEFAULT_EPISODES} episodes: seeds {EVAL_EPISODE_SEED} to "
                         f"{EVAL_EPISODE_SEED + DEFAULT_EPISODES - 1}), the same for every controller and run.")
        parser.print_help()
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0], add_help=False)
    parser.add_argument("-h", "--help", action=_HelpWithSuite, help="show this help message and exit")
    parser.add_argument("--controller", choices=CONTROLLER_NAMES, default="policy",
                        help="the trained policy, or the gain-scheduled PID or LQI baseline")
    parser.add_argument("--policy", type=Path, help="policy file (.pt); the shipped controller when omitted")
    parser.add_argument("--compare", type=Path, nargs="+", metavar="POLICY",
                        help="fly these policy files, the shipped policy and the PID on the same suite and print "
                             "one table, a column each (with --json: one object keyed by controller name)")
    add_aircraft_options(parser, "the doublets fly at the same fractions of its envelope, about its reference EAS")
    parser.add_argument("--episodes", type=episodes_int, default=DEFAULT_EPISODES,
                        help="seeded training-style episodes (at least 1; the seeds are below)")
    parser.add_argument("--plots", type=Path, help="folder for the doublet plots (none when omitted)")
    parser.add_argument("--overwrite", action="store_true", help="replace the plots of an earlier evaluation in --plots")
    parser.add_argument("--backend", choices=("onnx", "torch"), default="onnx",
                        help="runtime of the policy: onnxruntime or PyTorch")
    parser.add_argument("--json", action="store_true",
                        help="print every metric as JSON (no progress bar); without it, a table of the headline figures")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.controller != "policy" and (args.policy or args.backend != "onnx"):
        parser.error("--policy and --backend are for --controller policy")
    if args.compare and (args.policy or args.controller != "policy"):
        parser.error("--compare flies the shipped policy and the PID itself: give the other policies to --compare, "
                     "without --policy or --controller")
    if args.compare and args.plots:
        parser.error("--plots is for one controller: without --compare")
    if args.compare:
        names = [str(p) for p in args.compare]
        if len(set(names)) < len(names) or {SHIPPED, PID} & set(names):
            parser.error(f"--compare takes distinct policy files (other than {SHIPPED!r} and {PID!r}), got {names}")
    plots = None
    if args.plots is not None:
        command = shlex.join(["python", "scripts/evaluate.py", *(sys.argv[1:] if argv is None else argv)])
        plots = OutputFolder(args.plots, "evaluate", PLOT_RESULTS, args.overwrite, command)
        try:
            plots.claim()
        except OutputFolderError as err:
            print(f"evaluate: --plots: {err}", file=sys.stderr)
            return 2
    elif args.overwrite:
        parser.error("--overwrite is for --plots")

    import torch

    from aircraft import AircraftError
    from jsbsim_env.control.factory import check_flyable
    from jsbsim_env.control.gain_files import GainsMissing, GainTableError
    from jsbsim_env.control.policy import PolicyFileError

    torch.set_num_threads(1)
    try:  # every controller is built (its file read and checked) before the first flight
        check_flyable(["pid"] if args.compare else [args.controller], args.aircraft)
        controllers = _controllers(args)
    except (PolicyFileError, AircraftError, GainsMissing, GainTableError) as err:
        print(f"evaluate: {err}", file=sys.stderr)
        return 2
    if args.compare:
        results = {name: _evaluate(controller, about, args.episodes, None, progress=not args.json, label=name,
                                   aircraft=args.aircraft)
                   for name, (controller, about) in controllers.items()}
        print(json.dumps(results, indent=2, allow_nan=False, default=str) if args.json else comparison_table(results))
        return 0
    ((controller, about),) = controllers.values()
    if plots is None:
        results = _evaluate(controller, about, args.episodes, None, progress=not args.json, aircraft=args.aircraft)
    else:
        try:
            with writing(plots) as staging:
                results = _evaluate(controller, about, args.episodes, staging, progress=not args.json,
                                    aircraft=args.aircraft)
        except OutputFolderError as err:  # the folder changed during the flights
            print(f"evaluate: --plots: {err}", file=sys.stderr)
            return 2
    print(json.dumps(results, indent=2, allow_nan=False, default=str) if args.json
          else results_table(next(iter(controllers)), results))
    return 0


def _controllers(args) -> dict[str, tuple[object, dict]]:
    """The controllers to fly, by name, each with what the output says about it."""
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.control.policy import PolicyRuntime

    def policy(path: Path | None) -> tuple[object, dict]:
        runtime = PolicyRuntime(path, backend=args.backend, aircraft=args.aircraft, transfer=args.transfer)
        meta = runtime.meta
        return runtime, {"name": "policy", "file": str(path) if path else SHIPPED,
                         **{k: v for k, v in meta.items() if k not in ("network", "stack")},
                         "stack": meta["stack"].to_dict()}

    if args.compare:
        pid = (PIDAttitudeController(aircraft=args.aircraft), {"name": "gain-scheduled PID"})
        return {**{str(path): policy(path) for path in args.compare}, SHIPPED: policy(None), PID: pid}
    if args.controller != "policy":
        from jsbsim_env.control.factory import make_controller

        return {_LABELS[args.controller]: (make_controller(args.controller, aircraft=args.aircraft),
                                           {"name": _ABOUT[args.controller]})}
    return {"policy": policy(args.policy)}


def _evaluate(controller, about: dict, episodes: int, plots: Path | None, progress: bool, label: str = "",
              aircraft: str | None = None) -> dict:
    """The suite's metrics of one controller, ready for JSON (each null explained in ``null_values``)."""
    from jsbsim_env.task.metrics import json_ready
    from training.evaluation.suite import evaluate

    if progress and label:
        print(f"evaluate: flying {label}", file=sys.stderr)
    results = evaluate(controller, episodes=episodes, plot_dir=plots, progress=progress, aircraft=aircraft)
    results["controller"] = about
    nulls: dict[str, str] = {}
    results = json_ready(results, why_null, nulls)
    results["null_values"] = nulls  # each metric printed as null, and why
    return results


# Rows of the --compare table: label and where the value is in the suite's results (the episodes'
# means, or the doublets' metric averaged over the altitudes).
_EPISODE_ROWS = (("return (normalised, mean)", "mean_return_norm", "{:.3f}"),
                 ("RMSE roll, deg", "mean_rmse_roll_deg", "{:.2f}"),
                 ("RMSE pitch, deg", "mean_rmse_pitch_deg", "{:.2f}"),
                 ("RMSE EAS, m/s", "mean_rmse_airspeed_eas_mps", "{:.3f}"),
                 ("RMSE sideslip, deg", "mean_rmse_beta_deg", "{:.2f}"))
_DOUBLET_ROWS = (("doublets RMSE roll, deg", "rmse_roll_deg", "{:.2f}"),
                 ("doublets RMSE pitch, deg", "rmse_pitch_deg", "{:.2f}"),
                 ("doublets RMSE EAS, m/s", "rmse_airspeed_eas_mps", "{:.3f}"),
                 ("doublets RMSE sideslip, deg", "rmse_beta_deg", "{:.2f}"))


# Rows of one controller's doublet table: label, the metric (a list: one value per step of the
# doublet, shown joined by " / ") and its format.
_DOUBLET_DETAIL_ROWS = (*_DOUBLET_ROWS,
                        ("steady-state error roll, deg", "steady_state_error_roll_deg", "{:.3f}"),
                        ("steady-state error pitch, deg", "steady_state_error_pitch_deg", "{:.3f}"),
                        ("steady-state error EAS, m/s", "steady_state_error_airspeed_eas_mps", "{:.3f}"),
                        ("settling time roll, s", "settling_time_90_s_roll_deg", "{:.1f}"),
                        ("settling time pitch, s", "settling_time_90_s_pitch_deg", "{:.1f}"),
                        ("settling time EAS, s", "settling_time_90_s_airspeed_eas_mps", "{:.1f}"))


def _cell(value, fmt: str) -> str:
    """A figure as the tables print it; a missing or non-finite one as a dash."""
    if isinstance(value, list):
        return " / ".join(_cell(v, fmt) for v in value)
    return "—" if value is None or (isinstance(value, float) and not math.isfinite(value)) else fmt.format(value)


def _aligned(rows: list[tuple[str, list[str]]]) -> list[str]:
    """Rows of a label and cells as text columns, a rule under the first row."""
    widths = [max(len(row[0]) for row in rows)] + [max(len(row[1][j]) for row in rows) for j in range(len(rows[0][1]))]
    lines = []
    for k, (label, cells) in enumerate(rows):
        lines.append("  ".join([label.ljust(widths[0]), *(c.rjust(w) for c, w in zip(cells, widths[1:]))]))
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    return lines


def results_table(label: str, results: dict) -> str:
    """One controller's suite results (``_evaluate``'s) as readable tables: the seeded episodes'
    figures, then each doublet's, with every dash explained (``--json`` has every figure)."""
    episodes = results["episodes"]
    rows = [("episodes", [label]),
            ("count", [str(episodes["count"])]),
            ("ended early", [str(episodes["ended_early"])])]
    rows += [(name, [_cell(episodes[key], fmt)]) for name, key, fmt in _EPISODE_ROWS]
    doublets = results["doublets"]
    drows = [("doublets (each step: first / second / third)", list(doublets)),
             ("ended early", ["yes" if d["ended_early"] else "no" for d in doublets.values()])]
    drows += [(name.removeprefix("doublets "), [_cell(d[key], fmt) for d in doublets.values()])
              for name, key, fmt in _DOUBLET_DETAIL_ROWS]
    about = results["controller"]
    what = ("the shipped policy" if about.get("file") == SHIPPED else about["file"]) if "file" in about \
        else about.get("name", label)
    lines = [f"{label}: {what}", "", *_aligned(rows), "", *_aligned(drows)]
    reasons = sorted({why for why in results.get("null_values", {}).values()})
    lines += ["", *(f"—: {why}" for why in reasons)] if reasons else []
    return "\n".join(lines)


def comparison_table(results: dict[str, dict]) -> str:
    """The suite's headline figures of each controller side by side (``_evaluate``'s results by
    name): the episodes' mean return, early ends and RMSE, then the doublets' RMSE averaged over
    their altitudes."""
    def doublet_mean(doublets: dict, key: str):
        values = [d[key] for d in doublets.values()]
        return None if any(v is None for v in values) else sum(values) / len(values)

    first = next(iter(results.values()))
    rows = [("controller", list(results))]
    for label, key, fmt in _EPISODE_ROWS[:1]:
        rows.append((label, [_cell(r["episodes"][key], fmt) for r in results.values()]))
    rows.append((f"early ends (of {first['episodes']['count']} episodes)",
                 [str(r["episodes"]["ended_early"]) for r in results.values()]))
    for label, key, fmt in _EPISODE_ROWS[1:]:
        rows.append((label, [_cell(r["episodes"][key], fmt) for r in results.values()]))
    rows.append((f"doublets ended early (of {len(first['doublets'])})",
                 [str(sum(bool(d["ended_early"]) for d in r["doublets"].values())) for r in results.values()]))
    for label, key, fmt in _DOUBLET_ROWS:
        rows.append((label, [_cell(doublet_mean(r["doublets"], key), fmt) for r in results.values()]))
    return "\n".join(_aligned(rows))


if __name__ == "__main__":
    run_command(main, __file__)

"""Run the paper's experiments (its Section 5) and write a report with plots.

    python scripts/report.py --out results/report             # full (a few minutes)
    python scripts/report.py --out /tmp/report --quick        # seconds, for checks
    python scripts/report.py --out DIR --policy runs/NAME/best_policy.pt
    python scripts/report.py --out DIR --policy P --experiments altitudes,route_10km --controllers RL

Writes DIR/report.md, a PNG per figure and DIR/metrics.json. The trained policy is the shipped
one unless --policy is given; without either the PID parts run alone. A DIR that cannot be written
to is refused before the first flight; one that holds an earlier report is refused unless
--overwrite. The report is written to a temporary folder beside DIR and moved into place when it is
complete, so an error or a Ctrl-C leaves the earlier report as it was; DIR's manifest
(training.output_folders) records the files, and --overwrite replaces only those: a folder of
another command, or one holding figures no earlier report recorded (fig*.png), is refused.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

# The experiments' and controllers' names for the help; torch and onnxruntime load when flying.
from training.evaluation.report import CONTROLLERS, EXPERIMENTS, EXTRA_CONTROLLERS, run_report
from training.output_folders import OutputFolder, writing
from training.runtime import OutputFolderError, ScriptParser, add_aircraft_options, run_command

# The files a report writes to --out (an earlier report's are refused, or replaced with --overwrite).
RESULTS = ("report.md", "metrics.json", "fig*.png")


def build_parser() -> argparse.ArgumentParser:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for report.md, the figures and metrics.json")
    parser.add_argument("--overwrite", action="store_true", help="replace an earlier report in --out")
    parser.add_argument("--policy", type=Path, help="policy file (default: the shipped controller)")
    add_aircraft_options(parser, "the experiments fly at the same fractions of its envelope, about its reference EAS")
    parser.add_argument("--quick", action="store_true", help="short flights, for tests")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--experiments", default=",".join(EXPERIMENTS),
                        help="comma-separated subset of the experiments (default: all of them)")
    parser.add_argument("--controllers", default=",".join(CONTROLLERS),
                        help=f"comma-separated controllers (default: {','.join(CONTROLLERS)}; also any of {', '.join(EXTRA_CONTROLLERS)})")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    experiments, controllers = (tuple(filter(None, v.split(","))) for v in (args.experiments, args.controllers))
    for label, given, known in (("experiment", experiments, EXPERIMENTS), ("controller", controllers, CONTROLLERS + EXTRA_CONTROLLERS)):
        bad = [name for name in given if name not in known]
        if bad or not given:
            parser.error(f"unknown or no {label} {bad}: choose from {', '.join(known)}")
    command = shlex.join(["python", "scripts/report.py", *(sys.argv[1:] if argv is None else argv)])
    out = OutputFolder(args.out, "report", RESULTS, args.overwrite, command)
    try:
        out.claim()
    except OutputFolderError as err:
        print(f"report: --out: {err}", file=sys.stderr)
        return 2
    from aircraft import AircraftError
    from jsbsim_env.control.factory import check_flyable
    from jsbsim_env.control.gain_files import GainsMissing, GainTableError
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    try:  # every gain table and the policy file read and checked before the first flight
        if args.policy is not None and "RL" in controllers and not args.policy.exists():
            raise PolicyFileError(f"policy file {args.policy} does not exist")
        policy = args.policy or shipped_policy_path()
        policies = {"RL": policy} if "RL" in controllers and policy.exists() else {}
        check_flyable([name.lower() for name in controllers if name != "RL"], args.aircraft, policies, args.transfer)
        with writing(out) as staging:
            run_report(staging, args.policy, quick=args.quick, progress=not args.no_progress, experiments=experiments,
                       controllers=controllers, aircraft_spec=args.aircraft, transfer=args.transfer)
    except (PolicyFileError, AircraftError, GainsMissing, GainTableError) as err:
        print(f"report: {err}", file=sys.stderr)
        return 2
    except OutputFolderError as err:  # the folder changed during the flights
        print(f"report: --out: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.out / 'report.md'}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

"""Re-tune the PID or the LQI on the held-out flights (nonlinear simulation, turbulence, delay, the
Table 9 aircraft) with CMA-ES and a stated budget, and write the tuned gain table to a new file.

    python scripts/tune_classical.py --controller pid --budget 100   # writes jsbsim_env/control/pid_tuned_gains.json
    python scripts/tune_classical.py --controller lqi --budget 100   # writes jsbsim_env/control/lqi_tuned_gains.json
    python scripts/tune_classical.py --controller lqi --flights robust   # writes jsbsim_env/control/lqi_robust_gains.json
    python scripts/tune_classical.py --controller lqi --flights stressed   # writes jsbsim_env/control/lqi_stressed_gains.json

The method is in ``training/evaluation/classical_tuning.py``: the parameters (multipliers of the
PID's gain groups, or of the LQI's Bryson weights), the score (``heldout.relative_score`` against
the shipped PID, the score the policy's selection uses), and the robustness cases a candidate must
pass. The shipped tables (``pid_gains.json``, ``lqi_gains.json``) are never replaced; the tuned one
records the budget actually spent (evaluations, flights per evaluation, wall-clock seconds, cores)
and is flown as the controller ``pid_tuned`` or ``lqi_tuned`` (``pid_robust``, ``lqi_robust`` with
``--flights robust``, ``lqi_stressed`` with ``--flights stressed``; ``jsbsim_env.control.factory``).
Needs the ``cma`` package: ``pip install '.[tune]'``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from training.runtime import (
    OutputFolderError,
    ScriptParser,
    claim_output_file,
    number_type,
    run_command,
    seed_int,
    workers_int,
)

DEFAULT_BUDGET = 100
FLIGHT_SETS = ("heldout", "robust", "stressed")  # training.evaluation.heldout.FLIGHT_SETS, to parse without loading it


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", choices=("pid", "lqi"), required=True, help="the controller to tune")
    parser.add_argument("--budget", type=number_type(int, 1, 10_000), default=DEFAULT_BUDGET,
                        help="candidate evaluations (each flies the held-out flights once; the shipped PID and the "
                             "start point are flown once more)")
    parser.add_argument("--out", type=Path, default=None,
                        help="the tuned gain table to write (default: jsbsim_env/control/<controller>_tuned_gains.json, "
                             "which the controller <controller>_tuned flies)")
    parser.add_argument("--seed", type=seed_int, default=0, help="CMA-ES's random seed (flights are the held-out ones)")
    parser.add_argument("--workers", type=workers_int, default=1, help="processes flying candidates at once")
    parser.add_argument("--quick", action="store_true", help="30 s flights, for checks (not a tuning to use)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    parser.add_argument("--flights", choices=FLIGHT_SETS, default="heldout",
                        help="heldout: the held-out flights, nominal conditions (writes <controller>_tuned); robust: "
                             "the same flights in conditions drawn from the training episodes' distribution "
                             "(delay, interval, coefficient spread, turbulence; writes <controller>_robust); "
                             "stressed (the LQI only): the held-out flights and the turbulent one again at the "
                             "benchmark's stressed delay and servo rate (writes lqi_stressed)")
    parser.add_argument("--aircraft", default=None,
                        help="the aircraft tuned: a packaged aircraft's name or a folder built by "
                             "scripts/build_aircraft.py --out, from its designed tables (default: the paper's; "
                             "--out then defaults to its folder's <controller>_tuned_gains.json)")
    args = parser.parse_args(argv)
    if args.budget < 2:
        parser.error(f"--budget must be at least 2 (one CMA-ES generation), got {args.budget}")
    if args.flights == "stressed" and args.controller != "lqi":
        parser.error("--flights stressed tunes the LQI (lqi_stressed, the base of a residual): use --controller lqi")

    from aircraft import AircraftError
    from jsbsim_env.control import gain_files

    try:
        designed = [gain_files.gain_file(kind, args.aircraft) for kind in ("pid", "lqi")]
    except (AircraftError, gain_files.GainsMissing) as err:
        parser.exit(2, f"tune_classical: --aircraft: {err}\n")
    suffix = next(s for s, flights in gain_files.TUNINGS.items() if flights == args.flights)  # the table written
    out = args.out or gain_files.gain_file_path(f"{args.controller}_{suffix}", args.aircraft)
    if out.resolve() in {path.resolve() for path in designed}:
        parser.error(f"--out {out} is a shipped gain table, which tuning never replaces: give another file")
    # A table is read as the controller its name or its record says: never write one as the other's.
    other = [kind for kind, name in gain_files.FILES.items() if name == out.name and not kind.startswith(args.controller)]
    if other:
        parser.error(f"--out {out} is named as the {other[0]} table, and this tuning writes the "
                     f"{args.controller.upper()}'s: give a file named for it")
    if out.is_file():
        from jsbsim_env.control.pid import recorded_controller

        try:
            recorded = recorded_controller(json.loads(out.read_text()))
        except (OSError, ValueError, AttributeError):
            recorded = None
        if recorded is not None and recorded != args.controller:
            parser.error(f"--out {out} holds the {recorded.upper()}'s tuned table, and this tuning writes the "
                         f"{args.controller.upper()}'s: give another file")
    try:  # before the tuning, which takes a while
        claim_output_file(out, args.overwrite)
    except OutputFolderError as err:
        parser.exit(2, f"tune_classical: --out: {err}\n")
    from training.evaluation.classical_tuning import tune, tuning_flights, write_tuned_table

    try:  # the flights' seeds, against the frozen test set, before anything else
        tuning_flights(args.quick, args.aircraft, args.flights)
    except ValueError as err:
        print(err, file=sys.stderr)
        return 2
    try:
        import cma  # noqa: F401 - refused in one line before any work where it is missing
    except ImportError:
        parser.exit(2, "tune_classical: needs the cma package: pip install '.[tune]'\n")
    table = tune(args.controller, args.budget, seed=args.seed, workers=args.workers, quick=args.quick,
                 progress=lambda text: print(text, flush=True), aircraft=args.aircraft, flights=args.flights)
    write_tuned_table(table, out)
    record = table["tuning"]
    budget = record["budget"]
    print(f"score {record['score']:.4f} (start {record['start_score']:.4f}, relative to the shipped PID) after "
          f"{budget['candidate_evaluations']} candidates ({budget['candidates_not_robust']} not robust, unflown); "
          f"{budget['evaluations_flown']} evaluations flown with the reference and the start, "
          f"{budget['flights_per_evaluation']} flights each, {budget['wall_clock_s']:.0f} s on "
          f"{budget['workers']} worker(s)")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

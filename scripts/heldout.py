"""Fly trained runs' best policies (and the PID) on the held-out flights of training.evaluation.heldout: the
report's kinds of flight at other altitudes and route seeds, for choosing among seeds without
choosing on the report's own flights. One row per run.

    python scripts/heldout.py runs/c12_seed0 runs/c12_seed1 runs/c12_seed2 --pid
    python scripts/heldout.py runs/c12_seed0 runs/c12_seed1 runs/c12_seed2 --pick
    python scripts/heldout.py runs/v7_g90 --checkpoints [--aircraft builds/small]

``--pick`` also flies the PID and names the run whose scores are best relative to the PID's
(``training.evaluation.heldout.relative_score``: the geometric mean of each measure over the PID's; a run
that ends a flight early or whose surfaces chatter in calm air is never picked), the seed to ship
with ``scripts/ship_policy.py``.

``--checkpoints`` chooses within each run instead: it flies every policy the run evaluated
(``evaluated/``, kept by ``log.keep_evaluated``) and the PID, and writes the one best relative to the
PID, by the same score, as the run's ``picked_policy.pt`` (a copy of that file, so it flies as it was
trained), with every candidate's scores in ``picked_policy.json``; a ``picked_policy.pt`` that is
none of the run's evaluated policies is not this command's and is left alone. The training's own evaluation,
which chooses ``best_policy.pt``, flies short episodes of goal steps; the held-out flights are the
tuned classical controllers' tuning flights: route legs in turbulence, the Table 9 aircraft and calm
straight legs.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

# torch and the simulation load in the functions, after the arguments are parsed.
from training.runtime import ScriptParser, add_aircraft_options, run_command


def markdown(rows: dict[str, dict]) -> str:
    from training.evaluation.heldout import heldout_flights, surface_activity_ratios

    flights = list(heldout_flights())
    relative = all("relative_to_pid" in scores for scores in rows.values())
    head = ["controller", *(f"{f} {'MAE roll/pitch' if f.startswith('calm') else 'RMSE roll/pitch/β'}, deg"
                            for f in flights), "ended early",
            *(["calm surface activity / PID's, ail/elev/rud", "relative to the PID"] if relative else [])]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, scores in rows.items():
        cells = [" / ".join(f"{v:.3f}" for v in scores[f].values()) for f in flights]
        cells.append("yes" if scores["ended_early"] else "no")
        if relative:
            ratios = surface_activity_ratios(scores, rows["PID"]).values()
            cells.append(" / ".join("—" if math.isnan(r) else f"{r:.1f}" for r in ratios))
            cells.append(f"{scores['relative_to_pid']:.3f}")
        lines.append("| " + " | ".join([name, *cells]) + " |")
    return "\n".join(lines)


PICKED_POLICY = "picked_policy.pt"  # what --checkpoints writes into each run folder, beside its record


def evaluated_policies(run: Path) -> list[Path]:
    """The policies ``run`` kept at its evaluations (``training.trainer.EVALUATED_DIR``), oldest first."""
    from training.trainer import EVALUATED_DIR

    return sorted((run / EVALUATED_DIR).glob("policy_*.pt"))


def write_pick(run: Path, rows: dict[str, dict], files: dict[str, Path], picked: str) -> None:
    """``picked``'s file copied to ``run/PICKED_POLICY`` and the scores of every candidate of the run
    beside it (``picked_policy.json``), each written whole or not at all."""
    from training.output_folders import write_bytes_atomic, write_json_atomic

    record = {"picked": str(files[picked]), "score": "relative_score to the PID on the held-out flights",
              "candidates": {str(files[name]): rows[name] for name in files}, "pid": rows["PID"]}
    write_bytes_atomic(run / PICKED_POLICY, files[picked].read_bytes())
    write_json_atomic(run / "picked_policy.json", record, indent=1)


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", type=Path, nargs="*", help="run folders, each with best_policy.pt")
    parser.add_argument("--pid", action="store_true", help="also fly the PID")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON instead of a table")
    parser.add_argument("--quick", action="store_true", help="30 s flights, for checks")
    parser.add_argument("--pick", action="store_true",
                        help="fly the PID too and name the run best relative to it (relative_score)")
    parser.add_argument("--checkpoints", action="store_true",
                        help="fly every policy each run evaluated (its evaluated/ folder) and the PID, and write the "
                             f"best relative to the PID as the run's {PICKED_POLICY}")
    add_aircraft_options(parser, "the flights at the same fractions of its envelope", transfer=False)
    args = parser.parse_args(argv)
    if not args.runs and not args.pid:
        parser.error("name at least one run folder, or --pid")
    if (args.pick or args.checkpoints) and not args.runs:
        parser.error("--pick and --checkpoints need run folders to choose from")
    if args.pick and args.checkpoints:
        parser.error("--pick chooses among runs, --checkpoints within each: give one of them")
    names = [run.name for run in args.runs]
    if len(set(names)) < len(names) or "PID" in names:
        parser.error(f"run folders need distinct names other than PID, got {names}")
    args.pid |= args.pick or args.checkpoints
    files: dict[str, Path] = {}  # the policies flown, by row name
    for run in args.runs:
        if args.checkpoints:
            kept = evaluated_policies(run)
            if not kept:
                parser.error(f"{run} holds no evaluated policies (evaluated/policy_*.pt): it was trained with "
                             "--log.keep_evaluated false, or by a version of the package that did not keep them")
            files |= {f"{run.name}/{path.stem}": path for path in kept}
            earlier = run / PICKED_POLICY  # replaced only where it is an earlier pick of this run's policies
            if earlier.exists() and (not earlier.is_file()
                                     or earlier.read_bytes() not in {path.read_bytes() for path in kept}):
                parser.error(f"{earlier} is not one of the run's evaluated policies: it was not written by "
                             "--checkpoints, so it is left alone; move it away first")
        elif (run / "best_policy.pt").is_file():
            files[run.name] = run / "best_policy.pt"
        else:
            parser.error(f"{run} has no best_policy.pt")
    import torch

    from aircraft import load_aircraft
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.control.policy import PolicyFileError, load_policy
    from training.evaluation.heldout import CHATTER_LIMIT, heldout_flights, heldout_scores, relative_score

    try:  # --pick selects a seed: its flights are never the benchmark's frozen test set
        flown = load_aircraft(args.aircraft)
        heldout_flights(args.quick, flown)
    except ValueError as err:
        print(f"heldout: {err}", file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    for path in files.values():  # every policy file read and checked before the first flight
        try:
            load_policy(path)
        except PolicyFileError as err:
            print(f"heldout: {err}", file=sys.stderr)
            return 2
    factories = {"PID": lambda: PIDAttitudeController(aircraft=flown)} if args.pid else {}
    for name, path in files.items():
        factories[name] = (lambda p=path: make_controller("policy", p, backend="torch", aircraft=flown))
    rows = {name: heldout_scores(factory, args.quick, flown) for name, factory in factories.items()}
    if args.pid:
        for scores in rows.values():
            scores["relative_to_pid"] = relative_score(scores, rows["PID"])
    print(json.dumps(rows, indent=1) if args.json else markdown(rows))
    if args.pick:
        runs = {run.name: run for run in args.runs}
        best = min(runs, key=lambda name: rows[name]["relative_to_pid"])
        if rows[best]["relative_to_pid"] == float("inf"):
            raise SystemExit(f"every run ended a held-out flight early or moved a surface more than {CHATTER_LIMIT:g} "
                             "times the PID's in calm air: none to pick")
        print(f"picked: {runs[best]} (relative to the PID {rows[best]['relative_to_pid']:.3f})")
    for run in args.runs if args.checkpoints else ():
        mine = {name: path for name, path in files.items() if name.startswith(f"{run.name}/")}
        best = min(mine, key=lambda name: rows[name]["relative_to_pid"])
        if rows[best]["relative_to_pid"] == float("inf"):
            print(f"heldout: every policy {run} evaluated ended a held-out flight early or moved a surface more than "
                  f"{CHATTER_LIMIT:g} times the PID's in calm air: none picked, nothing written", file=sys.stderr)
            return 1
        write_pick(run, rows, mine, best)
        print(f"picked: {mine[best]} (relative to the PID {rows[best]['relative_to_pid']:.3f}), written as "
              f"{run / PICKED_POLICY}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

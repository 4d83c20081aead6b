"""Fly trained runs' best policies (and the PID) on the held-out flights of training.evaluation.heldout: the
report's kinds of flight at other altitudes and route seeds, for choosing among seeds without
choosing on the report's own flights. One row per run.

    python scripts/heldout.py runs/c12_seed0 runs/c12_seed1 runs/c12_seed2 --pid
    python scripts/heldout.py runs/c12_seed0 runs/c12_seed1 runs/c12_seed2 --pick

``--pick`` also flies the PID and names the run whose scores are best relative to the PID's
(``training.evaluation.heldout.relative_score``: the geometric mean of each measure over the PID's; a run
that ends a flight early or whose surfaces chatter in calm air is never picked), the seed to ship
with ``scripts/ship_policy.py``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

# torch and the simulation load in the functions, after the arguments are parsed.
from training.runtime import ScriptParser, run_command


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


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", type=Path, nargs="*", help="run folders, each with best_policy.pt")
    parser.add_argument("--pid", action="store_true", help="also fly the PID")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON instead of a table")
    parser.add_argument("--quick", action="store_true", help="30 s flights, for checks")
    parser.add_argument("--pick", action="store_true",
                        help="fly the PID too and name the run best relative to it (relative_score)")
    args = parser.parse_args(argv)
    if not args.runs and not args.pid:
        parser.error("name at least one run folder, or --pid")
    if args.pick and not args.runs:
        parser.error("--pick needs run folders to pick from")
    names = [run.name for run in args.runs]
    if len(set(names)) < len(names) or "PID" in names:
        parser.error(f"run folders need distinct names other than PID, got {names}")
    args.pid |= args.pick
    for run in args.runs:
        if not (run / "best_policy.pt").is_file():
            parser.error(f"{run} has no best_policy.pt")
    import torch

    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.control.policy import PolicyFileError, load_policy
    from training.evaluation.heldout import CHATTER_LIMIT, heldout_flights, heldout_scores, relative_score

    try:  # --pick selects a seed: its flights are never the benchmark's frozen test set
        heldout_flights(args.quick)
    except ValueError as err:
        print(f"heldout: {err}", file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    for run in args.runs:  # every policy file read and checked before the first flight
        try:
            load_policy(run / "best_policy.pt")
        except PolicyFileError as err:
            print(f"heldout: {err}", file=sys.stderr)
            return 2
    factories = {"PID": PIDAttitudeController} if args.pid else {}
    for run in args.runs:
        factories[run.name] = (lambda p=run / "best_policy.pt": make_controller("policy", p, backend="torch"))
    rows = {name: heldout_scores(factory, args.quick) for name, factory in factories.items()}
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
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

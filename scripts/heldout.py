"""Fly trained runs' best policies (and the PID) on the held-out flights of training.heldout: the
report's kinds of flight at other altitudes and route seeds, for choosing among seeds without
choosing on the report's own flights. One row per run.

    python scripts/heldout.py runs/c12_seed0 runs/c12_seed1 runs/c12_seed2 --pid
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from jsbsim_env.controllers.pid import PIDAttitudeController
from training.controllers import make_controller
from training.heldout import heldout_flights, heldout_scores


def markdown(rows: dict[str, dict]) -> str:
    flights = list(heldout_flights())
    head = ["controller", *(f"{f} {'MAE roll/pitch' if f.startswith('calm') else 'RMSE roll/pitch/β'}, deg"
                            for f in flights), "ended early"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, scores in rows.items():
        cells = [" / ".join(f"{v:.3f}" for v in scores[f].values()) for f in flights]
        lines.append("| " + " | ".join([name, *cells, "yes" if scores["ended_early"] else "no"]) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("runs", type=Path, nargs="*", help="run folders, each with best_policy.pt")
    parser.add_argument("--pid", action="store_true", help="also fly the PID")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON instead of a table")
    parser.add_argument("--quick", action="store_true", help="30 s flights, for checks")
    args = parser.parse_args()
    if not args.runs and not args.pid:
        parser.error("name at least one run folder, or --pid")
    for run in args.runs:
        if not (run / "best_policy.pt").is_file():
            parser.error(f"{run} has no best_policy.pt")
    torch.set_num_threads(1)
    factories = {"PID": PIDAttitudeController} if args.pid else {}
    for run in args.runs:
        factories[run.name] = (lambda p=run / "best_policy.pt": make_controller("policy", p, backend="torch"))
    rows = {name: heldout_scores(factory, args.quick) for name, factory in factories.items()}
    print(json.dumps(rows, indent=1) if args.json else markdown(rows))


if __name__ == "__main__":
    main()

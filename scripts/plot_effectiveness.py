"""The paper's Fig. 10: actuator effectiveness against altitude at EAS 10 m/s, normalised to sea level.

    python scripts/plot_effectiveness.py --out results/effectiveness   # PNG + JSON
    python scripts/plot_effectiveness.py --json                         # figures only
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from jsbsim_env.analysis.effectiveness import effectiveness, plot_effectiveness
from training.runtime import OutputFolderError, check_output_folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", type=Path, help="folder for effectiveness.png and effectiveness.json")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--veas-mps", type=float, default=10.0, help="equivalent airspeed, m/s")
    parser.add_argument("--step-km", type=float, default=2.0, help="altitude step, km")
    args = parser.parse_args()
    if args.out is not None:
        try:
            check_output_folder(args.out)
        except OutputFolderError as err:
            parser.exit(2, f"plot_effectiveness: --out: {err}\n")
    altitudes_m = np.arange(0.0, 20000.0 + 1.0, args.step_km * 1000.0)
    rows = effectiveness(altitudes_m.tolist(), args.veas_mps)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        plot_effectiveness(rows, args.out / "effectiveness.png")
        (args.out / "effectiveness.json").write_text(json.dumps(rows, indent=2))
        print(f"wrote {args.out / 'effectiveness.png'} and effectiveness.json")
    if args.json or not args.out:
        print(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()

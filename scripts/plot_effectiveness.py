"""The paper's Fig. 10: actuator effectiveness against altitude at EAS 10 m/s, normalised to sea level.

    python scripts/plot_effectiveness.py --out results/effectiveness   # PNG + JSON
    python scripts/plot_effectiveness.py --json                         # figures only

An ``--out`` that holds an earlier figure and data is refused unless ``--overwrite`` (a folder of
another command, or holding files no earlier run recorded, always: ``training.output_folders``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from jsbsim_env.analysis.effectiveness import effectiveness, plot_effectiveness
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS
from training.output_folders import OutputFolder, writing
from training.runtime import OutputFolderError, ScriptParser, number_type, run_command

RESULTS = ("effectiveness.png", "effectiveness.json")  # what --out receives


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="folder for effectiveness.png and effectiveness.json")
    parser.add_argument("--overwrite", action="store_true", help="replace an earlier figure and data in --out")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--veas-mps", type=number_type(float, *EAS_RANGE_MPS, unit="m/s", outside="the flight envelope"), default=10.0,
                        help=f"equivalent airspeed, m/s (the envelope: {EAS_RANGE_MPS[0]:g}-{EAS_RANGE_MPS[1]:g})")
    parser.add_argument("--step-km", type=number_type(float, 0.0, ALTITUDE_RANGE_M[1] / 1000.0, low_open=True, unit="km"),
                        default=2.0, help="altitude step, km")
    args = parser.parse_args(argv)
    if args.out is not None:
        folder = OutputFolder(args.out, "plot_effectiveness", RESULTS, args.overwrite)
        try:
            folder.claim()
        except OutputFolderError as err:
            parser.exit(2, f"plot_effectiveness: --out: {err}\n")
    altitudes_m = np.arange(0.0, 20000.0 + 1.0, args.step_km * 1000.0)
    rows = effectiveness(altitudes_m.tolist(), args.veas_mps)
    if args.out:
        try:
            with writing(folder) as staging:
                plot_effectiveness(rows, staging / "effectiveness.png")
                (staging / "effectiveness.json").write_text(json.dumps(rows, indent=2))
        except OutputFolderError as err:  # the folder changed meanwhile
            parser.exit(2, f"plot_effectiveness: --out: {err}\n")
        print(f"wrote {args.out / 'effectiveness.png'} and effectiveness.json")
    if args.json or not args.out:
        print(json.dumps(rows, indent=2))


if __name__ == "__main__":
    run_command(main, __file__)

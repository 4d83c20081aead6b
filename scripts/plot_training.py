"""The paper's Fig. 8: episode length and normalised return against environment steps, mean and spread
over the runs given (one per seed), from their ``progress.csv``; and the evaluation return against
training wall-clock.

    python scripts/plot_training.py runs/sac_seed0 runs/sac_seed1 runs/sac_seed2 --out fig8.png

It also prints each run's summary (``training.curves.run_summary``): training wall-clock, final
evaluation return, and the steps to 0.9 of it and of its gain. An ``--out`` file that exists
already is refused unless ``--overwrite``.
"""

from __future__ import annotations

import json
from pathlib import Path

from training.curves import load_curve, plot_curves, run_summary
from training.runtime import OutputFolderError, ScriptParser, claim_output_file, number_type, run_command

__all__ = ["load_curve", "main", "run_summary"]


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", type=Path, nargs="+", help="run folders (each with progress.csv)")
    parser.add_argument("--out", type=Path, default=Path("fig8_training.png"), help="the figure to write")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument("--final-evals", type=number_type(int, 1, 1000), default=3, help="evaluations averaged into the final return")
    args = parser.parse_args(argv)
    try:
        claim_output_file(args.out, args.overwrite)
    except OutputFolderError as err:
        parser.exit(2, f"plot_training: --out: {err}\n")
    print(json.dumps([run_summary(r, args.final_evals) for r in args.runs], indent=2))
    plot_curves(args.runs, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    run_command(main, __file__)

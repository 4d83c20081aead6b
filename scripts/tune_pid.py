"""Tune the gain-scheduled PID baseline on the aircraft's linear models and store the gain table.

    python scripts/tune_pid.py            # writes jsbsim_env/control/pid_gains.json

The method is in ``jsbsim_env/control/tuning.py``: ITAE of reference steps plus a
sensor-noise penalty, subject to 6 dB of gain margin and 80 ms of extra delay, at each design
altitude at EAS 10 m/s.

Writing the gain table is the command's purpose: it replaces the table at ``--out`` (the package's
by default, kept in git), so a run again regenerates it.
"""

from __future__ import annotations

from pathlib import Path

from jsbsim_env.control.pid import GAINS_PATH, write_gain_table
from training.runtime import OutputFolderError, ScriptParser, check_output_folder, run_command


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=GAINS_PATH,
                        help="gain table to write (replaced: regenerating it is the purpose)")
    args = parser.parse_args(argv)
    if args.out.is_dir():
        parser.exit(2, f"tune_pid: --out: {args.out} is a folder: give the gain table's file name\n")
    try:  # before the tuning, which takes a while
        check_output_folder(args.out.parent)
    except OutputFolderError as err:
        parser.exit(2, f"tune_pid: --out: {err}\n")

    def show(row: dict) -> None:
        print(" ".join(f"{k}={v:.4g}" for k, v in row.items()), flush=True)

    write_gain_table(args.out, progress=show)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

"""Design the gain-scheduled LQI baseline on the aircraft's linear models and store the gain table.

    python scripts/tune_lqi.py            # writes jsbsim_env/control/lqi_gains.json

The method is in ``jsbsim_env/control/lqi.py``: per block, the discrete model with the actuator lags,
the one-step command delay and the error integrators; gains from the discrete Riccati equation with
Bryson's-rule weights and R raised until the PID's robustness cases (every gain doubled, two more
steps of delay) pass, at each design altitude at EAS 10 m/s. Each row records the spectral radii
verified.

Writing the gain table is the command's purpose: it replaces the table at ``--out`` (the package's
by default, kept in git), so a run again regenerates it.
"""

from __future__ import annotations

from pathlib import Path

from jsbsim_env.control.lqi import GAINS_PATH, write_gain_table
from jsbsim_env.control.pid import DESIGN_ALTITUDES_M
from training.runtime import OutputFolderError, ScriptParser, check_output_folder, run_command


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=GAINS_PATH,
                        help="gain table to write (replaced: regenerating it is the purpose)")
    args = parser.parse_args(argv)
    if args.out.is_dir():
        parser.exit(2, f"tune_lqi: --out: {args.out} is a folder: give the gain table's file name\n")
    try:
        check_output_folder(args.out.parent)
    except OutputFolderError as err:
        parser.exit(2, f"tune_lqi: --out: {err}\n")

    def show(row: dict) -> None:
        m = row["margins"]
        print(f"{row['altitude_m']:g} m: " + "; ".join(
            f"{block} radius {v['nominal']:.4f}, gain x2 {v['gain_x2']:.4f}, delay +2 {v['delay_plus2']:.4f}, "
            f"R x{v['r_factor']:g}" for block, v in m.items()), flush=True)

    write_gain_table(args.out, DESIGN_ALTITUDES_M, progress=show)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

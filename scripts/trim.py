"""Trim the solar UAV at one flight condition and print the result (and its linear modes).

    python scripts/trim.py --altitude-m 10000 --veas-mps 10 --json --modes

Exits with status 2 and a message on stderr when no trim exists (outside the envelope, or a
control at its limit).
"""

from __future__ import annotations

import json
import sys

from jsbsim_env.analysis.modes import LinearisationError, linear_modes
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS, Simulation, TrimError
from training.runtime import ScriptParser, number_type, run_command


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--altitude-m", type=number_type(float, *ALTITUDE_RANGE_M, unit="m", outside="the flight envelope"), required=True,
                        help=f"altitude above sea level, m (the envelope: {ALTITUDE_RANGE_M[0]:g}-{ALTITUDE_RANGE_M[1]:g})")
    parser.add_argument("--veas-mps", type=number_type(float, *EAS_RANGE_MPS, unit="m/s", outside="the flight envelope"), required=True,
                        help=f"equivalent airspeed, m/s (the envelope: {EAS_RANGE_MPS[0]:g}-{EAS_RANGE_MPS[1]:g})")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument("--modes", action="store_true", help="add the linear modes from JSBSim's linearisation")
    args = parser.parse_args(argv)

    sim = Simulation()
    try:
        trim = sim.trim(args.altitude_m, args.veas_mps)
        result = trim.as_dict()
        if args.modes:
            result["modes"] = linear_modes(sim, trim)
    except (TrimError, LinearisationError) as err:
        print(f"trim.py: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for key, value in result.items():
        if key != "modes":
            print(f"{key:28s} {value:.6g}")
    for name, mode in result.get("modes", {}).items():
        details = ", ".join(f"{k} {v:.4g}" for k, v in mode.items() if isinstance(v, float))
        re, im = mode["eigenvalue"]
        print(f"{name:12s} {re:+.4f}{im:+.4f}j  {details}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

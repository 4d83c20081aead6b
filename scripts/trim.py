"""Trim an aircraft at one flight condition and print the result (and its linear modes).

    python scripts/trim.py --altitude-m 10000 --veas-mps 10 --json --modes
    python scripts/trim.py --aircraft builds/my_uav --altitude-m 500 --veas-mps 12

Exits with status 2 and a message on stderr when no trim exists (outside the envelope, or a
control at its limit).
"""

from __future__ import annotations

import json
import sys

from aircraft import Aircraft, AircraftError, load_aircraft
from jsbsim_env.analysis.modes import LinearisationError, linear_modes
from jsbsim_env.sim.simulation import Simulation, TrimError
from training.runtime import ScriptParser, add_aircraft_options, check_in_envelope, finite_float, run_command


def condition(args) -> Aircraft:
    """The aircraft ``args`` names, with the condition checked against its envelope (``ValueError``
    naming the option, its value and the envelope)."""
    flown = load_aircraft(args.aircraft)
    check_in_envelope(flown, args.altitude_m, args.veas_mps)
    return flown


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    add_aircraft_options(parser, "the condition must lie in its envelope", transfer=False)
    parser.add_argument("--altitude-m", type=finite_float, required=True,
                        help="altitude above sea level, m, in the aircraft's envelope (the paper's: 0-20,000)")
    parser.add_argument("--veas-mps", type=finite_float, required=True,
                        help="equivalent airspeed, m/s, in the aircraft's envelope (the paper's: 8-12)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument("--modes", action="store_true", help="add the linear modes from JSBSim's linearisation")
    args = parser.parse_args(argv)
    try:
        flown = condition(args)
    except (AircraftError, ValueError) as err:
        print(f"trim: {err}", file=sys.stderr)
        return 2

    sim = Simulation(flown)
    try:
        trim = sim.trim(args.altitude_m, args.veas_mps)
        result = trim.as_dict()
        if args.modes:
            result["modes"] = linear_modes(sim, trim)
    except (TrimError, LinearisationError) as err:
        print(f"trim: {err}", file=sys.stderr)
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

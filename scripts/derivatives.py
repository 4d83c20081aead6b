"""Measure the stability and control derivatives of an aircraft through JSBSim at one trim.

    python scripts/derivatives.py --altitude-m 1000 --veas-mps 10 [--json]
    python scripts/derivatives.py --aircraft builds/my_uav      # at its reference EAS, low in its envelope

Central differences of JSBSim's total aerodynamic forces and moments (jsbsim_env/analysis/derivatives.py),
the aileron's yaw-to-roll ratio in body and stability axes, the largest yaw rate against the roll
after a held 5 deg aileron step, and the linear modes. Exits with status 2 when no trim exists.
"""

from __future__ import annotations

import json
import math
import sys

from aircraft import Aircraft, AircraftError, load_aircraft
from jsbsim_env.analysis import derivatives
from jsbsim_env.analysis.modes import LinearisationError, linear_modes
from jsbsim_env.sim.simulation import Simulation, TrimError
from training.runtime import ScriptParser, add_aircraft_options, check_in_envelope, finite_float, run_command

DEFAULT_PAPER_ALTITUDE_M = 1000.0  # the paper's aircraft's; another's at the same fraction of its envelope


def measure(altitude_m: float, airspeed_eas_mps: float, aircraft: Aircraft | str | None = None) -> dict:
    """Everything the script prints, as one dict (the paper's aircraft when ``aircraft`` is None)."""
    sim = Simulation(aircraft)
    measured = derivatives.measure(sim, altitude_m, airspeed_eas_mps)
    trim = sim.trim(altitude_m, airspeed_eas_mps)
    stability = derivatives.to_stability_axes(measured, math.radians(trim.alpha_deg))
    step = derivatives.aileron_step_adverse_yaw(sim, altitude_m, airspeed_eas_mps)
    modes = linear_modes(sim, sim.trim(altitude_m, airspeed_eas_mps))
    return {"altitude_m": altitude_m, "airspeed_eas_mps": airspeed_eas_mps, "alpha_deg": trim.alpha_deg,
            "derivatives": measured, "stability_axes": stability,
            "aileron_yaw_to_roll_body": measured["Cnda"] / measured["Clda"],
            "aileron_yaw_to_roll_stability": stability["Cnda"] / stability["Clda"],
            "aileron_step": step, "modes": modes}


def condition(args) -> tuple[Aircraft, float, float]:
    """The aircraft ``args`` names, the altitude (m) and EAS (m/s) to measure at (its defaults where
    not given), each checked against its envelope (``ValueError`` naming the option)."""
    flown = load_aircraft(args.aircraft)
    altitude_m = flown.altitude_like_m(DEFAULT_PAPER_ALTITUDE_M) if args.altitude_m is None else args.altitude_m
    eas_mps = flown.reference_eas_mps if args.veas_mps is None else args.veas_mps
    check_in_envelope(flown, altitude_m, eas_mps)
    return flown, altitude_m, eas_mps


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    add_aircraft_options(parser, "the condition must lie in its envelope", transfer=False)
    parser.add_argument("--altitude-m", type=finite_float, default=None,
                        help="altitude above sea level, m, in the aircraft's envelope (default: 1,000 m for the "
                             "paper's aircraft, the same fraction of another's envelope)")
    parser.add_argument("--veas-mps", type=finite_float, default=None,
                        help="equivalent airspeed, m/s, in the aircraft's envelope (default: its reference EAS)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = parser.parse_args(argv)
    try:
        flown, altitude_m, eas_mps = condition(args)
    except (AircraftError, ValueError) as err:
        print(f"derivatives: {err}", file=sys.stderr)
        return 2
    try:
        result = measure(altitude_m, eas_mps, flown)
    except (TrimError, LinearisationError) as err:
        print(f"derivatives: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(f"{flown.name} trimmed at {altitude_m:g} m, EAS {eas_mps:g} m/s: alpha {result['alpha_deg']:.3f} deg")
    for name, value in sorted(result["derivatives"].items()):
        print(f"{name:8s} {value:+.5f}")
    print(f"aileron Cn/Cl: body {result['aileron_yaw_to_roll_body']:+.4f}, "
          f"stability {result['aileron_yaw_to_roll_stability']:+.4f}")
    step = result["aileron_step"]
    print(f"5 deg aileron step: yaw rate against the roll {step['adverse_yaw_rate_degps']:.3f} deg/s "
          f"at {step['time_s']:.2f} s (roll rate {step['roll_rate_degps']:.3f} deg/s)")
    for name, mode in result["modes"].items():
        re, im = mode["eigenvalue"]
        print(f"{name:12s} {re:+.4f}{im:+.4f}j")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

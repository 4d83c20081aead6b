"""Measure the stability and control derivatives of the solar UAV through JSBSim at one trim.

    python scripts/derivatives.py --altitude-m 1000 --veas-mps 10 [--json]

Central differences of JSBSim's total aerodynamic forces and moments (jsbsim_env/analysis/derivatives.py),
the aileron's yaw-to-roll ratio in body and stability axes, the largest yaw rate against the roll
after a held 5 deg aileron step, and the linear modes. Exits with status 2 when no trim exists.
"""

from __future__ import annotations

import json
import math
import sys

from jsbsim_env.analysis import derivatives
from jsbsim_env.analysis.modes import LinearisationError, linear_modes
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS, Simulation, TrimError
from training.runtime import ScriptParser, number_type, run_command


def measure(altitude_m: float, airspeed_eas_mps: float) -> dict:
    """Everything the script prints, as one dict."""
    sim = Simulation()
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


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--altitude-m", type=number_type(float, *ALTITUDE_RANGE_M, unit="m", outside="the flight envelope"), default=1000.0,
                        help=f"altitude above sea level, m (the envelope: {ALTITUDE_RANGE_M[0]:g}-{ALTITUDE_RANGE_M[1]:g})")
    parser.add_argument("--veas-mps", type=number_type(float, *EAS_RANGE_MPS, unit="m/s", outside="the flight envelope"), default=10.0,
                        help=f"equivalent airspeed, m/s (the envelope: {EAS_RANGE_MPS[0]:g}-{EAS_RANGE_MPS[1]:g})")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = parser.parse_args(argv)
    try:
        result = measure(args.altitude_m, args.veas_mps)
    except (TrimError, LinearisationError) as err:
        print(f"derivatives.py: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(f"trim at {args.altitude_m:g} m, EAS {args.veas_mps:g} m/s: alpha {result['alpha_deg']:.3f} deg")
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

"""Trim and linearise the solar UAV across the flight envelope and print the README's tables.

    python scripts/envelope_table.py            # markdown tables
    python scripts/envelope_table.py --json     # every point, with its modes
"""

from __future__ import annotations

import json

from jsbsim_env.analysis.modes import linear_modes
from jsbsim_env.sim.simulation import Simulation
from training.runtime import ScriptParser, run_command

ALTITUDES_M = (500.0, 1000.0, 5000.0, 10000.0, 15000.0, 20000.0)
EAS_MPS = (8.0, 10.0, 12.0)
MODE_TABLE_ALTITUDES_M = (1000.0, 10000.0, 20000.0)


def envelope() -> list[dict]:
    """Trim result and modes at every altitude and EAS of the envelope grid."""
    sim = Simulation()
    points = []
    for h in ALTITUDES_M:
        for v in EAS_MPS:
            trim = sim.trim(h, v)
            point = trim.as_dict()
            point["modes"] = linear_modes(sim, trim)
            points.append(point)
    return points


def _mode_cell(mode: dict) -> str:
    re, im = mode["eigenvalue"]
    if "damping_ratio" in mode:
        return f"{re:.3f}±{im:.3f}j (ω {mode['natural_frequency_radps']:.2f}, ζ {mode['damping_ratio']:.2f})"
    if "time_constant_s" in mode:
        return f"{re:.3f} (τ {mode['time_constant_s']:.2f} s)"
    return f"{re:+.3f} (doubles in {mode['time_to_double_s']:.1f} s)"


def markdown(points: list[dict]) -> str:
    lines = ["| altitude, m | EAS, m/s | TAS, m/s | α, deg | elevator, deg | throttle | rotor, rpm | thrust, N |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for p in points:
        lines.append(f"| {p['altitude_m']:.0f} | {p['airspeed_eas_mps']:.0f} | {p['airspeed_tas_mps']:.1f} | "
                     f"{p['alpha_deg']:.2f} | {p['elevator_deg']:.2f} | {p['throttle']:.3f} | "
                     f"{p['rotor_rpm']:.0f} | {p['thrust_n']:.0f} |")
    names = ("short_period", "phugoid", "roll", "spiral", "dutch_roll")
    lines += ["", "| altitude, m | EAS, m/s | " + " | ".join(n.replace("_", " ") for n in names) + " |",
              "|---:|---:|" + "---|" * len(names)]
    for p in points:
        if p["altitude_m"] in MODE_TABLE_ALTITUDES_M:
            cells = " | ".join(_mode_cell(p["modes"][n]) for n in names)
            lines.append(f"| {p['altitude_m']:.0f} | {p['airspeed_eas_mps']:.0f} | {cells} |")
    unstable = sorted({n for p in points for n, m in p["modes"].items() if not m["stable"]})
    lines += ["", f"Modes unstable somewhere in the grid: {', '.join(unstable) or 'none'}."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print the table as JSON")
    args = parser.parse_args(argv)
    points = envelope()
    print(json.dumps(points, indent=2) if args.json else markdown(points))


if __name__ == "__main__":
    run_command(main, __file__)

"""How often the turbulence clips are active, per channel, across the flight envelope.

    python scripts/turbulence_clip_activity.py            # markdown table: range over the envelope
    python scripts/turbulence_clip_activity.py --json     # every point

At each altitude and EAS of the grid, a stationary series of ``--seconds`` at a 50 ms control
interval (the middle of the training draw) is generated with each clip rule of
``jsbsim_env.sim.turbulence`` ("4sigma", the default, and "paper"), and the share of samples held at
the clip is counted per channel (u, v, w, p, q, r).
"""

from __future__ import annotations

import json
import math

import numpy as np

from jsbsim_env.sim import turbulence as turb
from jsbsim_env.sim.simulation import Simulation
from training.runtime import ScriptParser, number_type, positive_float, run_command

ALTITUDES_M = (500.0, 1000.0, 2000.0, 5000.0, 10000.0, 15000.0, 20000.0)
EAS_MPS = (8.0, 10.0, 12.0)
CHANNELS = ("u", "v", "w", "p", "q", "r")
INTERVAL_S = 0.05
SPAN_M = 35.0


def activity(seconds: float, intensity: str, sigma_mps: float) -> list[dict]:
    """Share of samples at the clip (0..1) per channel, clip rule and envelope point."""
    sim = Simulation()
    n = round(seconds / INTERVAL_S)
    points = []
    for altitude_m in ALTITUDES_M:
        tas_per_eas = math.sqrt(1.225 / sim.density_kg_m3(altitude_m))
        for eas in EAS_MPS:
            point = {"altitude_m": altitude_m, "eas_mps": eas}
            for clip in turb.CLIPS:
                s = turb.dryden_series(n, altitude_m, eas * tas_per_eas, SPAN_M, INTERVAL_S, np.random.default_rng(0),
                                       intensity, sigma_mps, clip)
                at_clip = np.concatenate([np.abs(s.wind_mps) >= s.wind_clip_mps, np.abs(s.rate_radps) >= s.rate_clip_radps],
                                         axis=1)
                point[clip] = dict(zip(CHANNELS, map(float, at_clip.mean(axis=0))))
                point[f"{clip}_limits"] = dict(zip(CHANNELS, [*s.wind_clip_mps, *np.degrees(s.rate_clip_radps)]))
            points.append(point)
    return points


def markdown(points: list[dict]) -> str:
    lines = ["| clip | " + " | ".join(CHANNELS) + " |", "|---|" + "---:|" * len(CHANNELS)]
    for clip in turb.CLIPS:
        cells = []
        for c in CHANNELS:
            share = [100.0 * p[clip][c] for p in points]
            limit = [p[f"{clip}_limits"][c] for p in points]
            unit = "m/s" if c in "uvw" else "°/s"
            cells.append(f"{min(share):.3g}–{max(share):.3g} % (±{min(limit):.2f}–{max(limit):.2f} {unit})")
        lines.append(f"| {clip} | " + " | ".join(cells) + " |")
    lines += ["", "Share of samples at the clip over the envelope grid, and the clip."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print the table as JSON")
    parser.add_argument("--seconds", type=number_type(float, INTERVAL_S, unit="s"), default=5000.0,
                        help="length of each series, s (at least one interval)")
    parser.add_argument("--intensity", default=turb.PAPER, help="'paper' or a MIL-F-8785C severity")
    parser.add_argument("--sigma-mps", type=positive_float, default=0.5, help="intensity of 'paper', m/s")
    args = parser.parse_args(argv)
    points = activity(args.seconds, args.intensity, args.sigma_mps)
    print(json.dumps(points, indent=2) if args.json else markdown(points))


if __name__ == "__main__":
    run_command(main, __file__)

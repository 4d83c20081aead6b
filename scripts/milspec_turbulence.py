"""Measure JSBSim's own MIL-F-8785C (Milspec Dryden) turbulence against altitude and severity.

    python scripts/milspec_turbulence.py            # markdown table of the RMS (m/s)
    python scripts/milspec_turbulence.py --json     # every point

For each severity (``atmosphere/turbulence/milspec/severity``, the probability-of-exceedance curve
of MIL-F-8785C Fig. 7: 1 = 2e-1, 2 = 1e-1, 3 = 1e-2 "light", 4 = 1e-3 "moderate", 5 = 1e-4,
6 = 1e-5 "severe", 7 = 1e-6) and altitude, the trimmed aircraft (EAS 10 m/s) flies with
``atmosphere/turb-type`` 3 (Milspec) for 100 correlation times L/V and the RMS of
``atmosphere/turb-{north,east,down}-fps`` is taken after the first two (one sigma of sampling
error: about 7 % per component). The aircraft is put back in its trimmed state every second
(JSBSim's initial-condition pass keeps the turbulence filters), so that it stays at the altitude
and airspeed being measured however strong the turbulence. The whole table takes about 10 minutes.
W20 (``windspeed_at_20ft_AGL-fps``, which matters below 2000 ft only): 25 ft/s (15 kt) up to
severity 3, 50 ft/s (30 kt) for 4-5 and 75 ft/s (45 kt) for 6-7, as JSBSim documents for light,
moderate and severe. Beside the named severities, this package's MIL-F-8785C sigma_w
(``jsbsim_env.sim.turbulence.milspec_intensities_mps``) for comparison.
"""

from __future__ import annotations

import json
import math

import numpy as np

from jsbsim_env.sim import turbulence as turb
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, FT_TO_M, Simulation
from training.runtime import ScriptParser, number_type, run_command

ALTITUDES_M = (500.0, 1000.0, 2000.0, 5000.0, 10000.0, 15000.0, 20000.0)
SEVERITIES = (1, 2, 3, 4, 5, 6, 7)
NAMED = {3: "light", 4: "moderate", 6: "severe"}
EAS_MPS = 10.0
MILSPEC = 3  # atmosphere/turb-type: ttNone, ttStandard, ttCulp, ttMilspec, ttTustin
REPLACE_EVERY_S = 1.0
CORRELATION_TIMES, SETTLE_CORRELATION_TIMES = 100.0, 2.0
SCALE_LENGTH_M = 1750.0 * FT_TO_M  # above 2000 ft; shorter below, so 22 L/V is enough there too


def w20_fps(severity: int) -> float:
    return 25.0 if severity <= 3 else 50.0 if severity <= 5 else 75.0


def measure(severity: int, altitude_m: float, seed: int = 1) -> dict:
    """RMS (m/s) of JSBSim's Milspec turbulence north, east and down at one severity and altitude."""
    sim = Simulation()
    trim = sim.trim(altitude_m, EAS_MPS)
    f = sim.fdm
    f["simulation/randomseed"] = seed
    f["atmosphere/turb-type"] = MILSPEC
    f["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = w20_fps(severity)
    f["atmosphere/turbulence/milspec/severity"] = severity
    pm = f.get_property_manager()
    read = [pm.get_node(f"atmosphere/turb-{a}-fps", False).get_double_value for a in ("north", "east", "down")]
    steps_per_replace = round(REPLACE_EVERY_S / sim.dt_s)
    correlation_s = SCALE_LENGTH_M / trim.airspeed_tas_mps
    chunks = math.ceil(CORRELATION_TIMES * correlation_s / REPLACE_EVERY_S)
    settle = math.ceil(SETTLE_CORRELATION_TIMES * correlation_s / REPLACE_EVERY_S)
    samples = []
    for chunk in range(chunks):
        f.run_ic()  # back to the trimmed state; the turbulence filters keep theirs
        for _ in range(steps_per_replace):
            f.run()
            if chunk >= settle:
                samples.append([r() for r in read])
    rms = np.sqrt(np.mean(np.square(samples), axis=0)) * FT_TO_M
    point = {"severity": severity, "w20_fps": w20_fps(severity), "altitude_m": altitude_m,
             "tas_mps": trim.airspeed_tas_mps, "rms_north_mps": float(rms[0]), "rms_east_mps": float(rms[1]),
             "rms_down_mps": float(rms[2]), "seconds": len(samples) * sim.dt_s}
    if severity in NAMED:
        point["milspec_sigma_w_mps"] = turb.milspec_intensities_mps(altitude_m, NAMED[severity])[2]
    return point


def markdown(points: list[dict]) -> str:
    alts = sorted({p["altitude_m"] for p in points})
    lines = ["| severity | " + " | ".join(f"{a / 1000:g} km" for a in alts) + " |",
             "|---|" + "---:|" * len(alts)]
    for sev in sorted({p["severity"] for p in points}):
        row = {p["altitude_m"]: p for p in points if p["severity"] == sev}
        name = f" ({NAMED[sev]})" if sev in NAMED else ""
        cells = []
        for a in alts:
            p = row[a]
            horizontal = math.sqrt((p["rms_north_mps"] ** 2 + p["rms_east_mps"] ** 2) / 2)
            cell = f"{horizontal:.2f} / {p['rms_down_mps']:.2f}"
            if "milspec_sigma_w_mps" in p:
                cell += f" ({p['milspec_sigma_w_mps']:.2f})"
            cells.append(cell)
        lines.append(f"| {sev}{name} | " + " | ".join(cells) + " |")
    lines += ["", ("RMS of the horizontal / vertical turbulence velocity, m/s; in brackets the MIL-F-8785C "
                   "sigma_w of jsbsim_env.sim.turbulence for the named severities.")]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print the table as JSON")
    parser.add_argument("--severities", type=number_type(int, min(SEVERITIES), max(SEVERITIES)), nargs="+",
                        default=list(SEVERITIES), help="MIL-F-8785C severity levels")
    parser.add_argument("--altitudes-m", type=number_type(float, *ALTITUDE_RANGE_M, unit="m", outside="the flight envelope"), nargs="+",
                        default=list(ALTITUDES_M),
                        help=f"altitudes, m (the envelope: {ALTITUDE_RANGE_M[0]:g}-{ALTITUDE_RANGE_M[1]:g})")
    args = parser.parse_args(argv)
    # A seed per point: with one seed every point would draw the same noise, and share its error.
    points = [measure(s, a, seed=1 + i) for i, (s, a) in
              enumerate((s, a) for s in args.severities for a in args.altitudes_m)]
    print(json.dumps(points, indent=2) if args.json else markdown(points))


if __name__ == "__main__":
    run_command(main, __file__)

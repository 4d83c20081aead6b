"""Regenerate the solar UAV: aerodynamic data from the geometry, then the JSBSim files.

``python scripts/build_aircraft.py`` runs the whole chain (needs the ``aero`` extra);
``--from-data`` rewrites the XML from the committed ``aero_data.json`` only.
"""

from __future__ import annotations

import argparse
import time

from .. import aircraft_dir
from . import aero_data, analysis, xml_writer
from .geometry import AircraftGeometry


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                     allow_abbrev=False)
    parser.add_argument("--from-data", action="store_true",
                        help="skip the aerodynamic analysis and write the XML from the saved data set")
    args = parser.parse_args(argv)
    geometry = AircraftGeometry()
    if args.from_data:
        data = aero_data.load()
    else:
        start = time.perf_counter()
        data = aero_data.compute_aero_data(geometry)
        aero_data.save(data)
        print(f"aerodynamic data computed in {time.perf_counter() - start:.1f} s -> {aero_data.DATA_PATH}")
    files = xml_writer.aircraft_files(geometry, data)
    xml_writer.write(files, aircraft_dir())
    print(f"wrote {len(files)} files under {aircraft_dir()}")
    st = data["stability"]
    print(f"CG x = {st['cg_x_m']:.3f} m, neutral point x = {st['neutral_point_x_m']:.3f} m, "
          f"static margin {st['static_margin']:.2f} MAC, cruise alpha {st['cruise_alpha_deg']:.2f} deg")
    print(checks_report(data))
    return 0


def checks_report(data: dict) -> str:
    """The lattice's mesh-convergence table and the induced-yaw check, as printed by the build."""
    setup, checks = data["vlm_setup"], data["checks"]
    mesh = f"{setup['spanwise_panels_per_segment']} x {setup['chordwise_panels']}"
    lines = [(f"vortex lattice: {mesh} panels (spanwise per segment x chordwise), flat wing at "
             f"{setup['wing_incidence_deg']:.2f} deg incidence; convergence at the cruise angle of attack:"),
             f"  {'derivative':>10} {'mesh':>10} {'doubled':>10} {'change':>8}"]
    worst = 0.0
    for name, row in checks["mesh_convergence"].items():
        worst = max(worst, row["relative_change"])
        lines.append(f"  {name:>10} {row['mesh']:>10.5g} {row['doubled']:>10.5g} {100 * row['relative_change']:>7.2f}%")
    lines.append(f"  largest change {100 * worst:.2f} % (limit {100 * analysis.CONVERGENCE_TOLERANCE:.0f} %)")
    yaw = checks["aileron_induced_yaw"]
    lines.append(f"aileron induced yaw: dCn_s = -k CL dCl_s/(pi AR), lifting line k = {yaw['lifting_line_factor']:g}, "
                 f"lattice k = {yaw['factor']:.2f} at CL {yaw['CL']:.2f}")
    return "\n".join(lines)

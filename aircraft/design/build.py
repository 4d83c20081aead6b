"""Regenerate the solar UAV: aerodynamic data from the geometry, then the JSBSim files.

``python scripts/build_aircraft.py`` runs the whole chain (needs the ``aero`` extra);
``--from-data`` rewrites the XML from the committed ``aero_data.json`` only.
"""

from __future__ import annotations

import argparse
import time

from .. import aircraft_dir
from . import aero_data, xml_writer
from .geometry import AircraftGeometry


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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
    return 0

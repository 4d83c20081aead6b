"""Build an aircraft from its description file: aerodynamic data from the geometry, then the JSBSim files.

``python scripts/build_aircraft.py`` builds the paper's aircraft (``aircraft/solar_uav.toml``)
into the package (needs the ``aero`` extra); ``python scripts/build_aircraft.py my_uav.toml --out
DIR`` builds another into ``DIR``, a JSBSim root: ``DIR/aircraft/<name>/`` holds its files and
``DIR/aero_data.json`` its aerodynamic data set. ``--from-data`` rewrites the XML from the saved
data set only. The script then surveys the built model (``jsbsim_env.analysis.survey``).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

from .. import jsbsim_root
from . import aero_data, analysis, xml_writer
from .description import PAPER_AIRCRAFT, DescriptionError, load_description
from .geometry import AircraftGeometry


class BuildError(ValueError):
    """A build that cannot run: the message is one line, naming what to change."""


@dataclass(frozen=True)
class Built:
    """What a build wrote: the aircraft, its data set, its JSBSim root and folder."""

    geometry: AircraftGeometry
    data: dict
    data_path: Path
    root: Path  # a JSBSim root: the aircraft's files are in root/aircraft/<name>/
    folder: Path


def build_parser(description: str = __doc__) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter,
                                     allow_abbrev=False)
    parser.add_argument("description", nargs="?", type=Path, default=PAPER_AIRCRAFT,
                        help="the aircraft's description file (TOML; docs/aircraft.md); the paper's aircraft when "
                             "omitted")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder to build into (a JSBSim root: DIR/aircraft/<name>/); the package's own "
                             "aircraft folder when omitted, which only the paper's aircraft may use")
    parser.add_argument("--from-data", action="store_true",
                        help="skip the aerodynamic analysis and write the XML from the saved data set")
    return parser


def build(description: Path, out: Path | None = None, from_data: bool = False, log=print) -> Built:
    """Build the aircraft ``description`` describes into ``out`` (the package when None; only the
    paper's aircraft may); ``BuildError`` where it cannot."""
    try:
        geometry = load_description(description)
    except DescriptionError as err:
        raise BuildError(str(err)) from err
    if out is None:
        if geometry.name != PAPER_AIRCRAFT.stem:
            raise BuildError(f"{description} describes {geometry.name!r}, not the paper's aircraft: give --out DIR "
                             "to build it there")
        data_path, root = aero_data.DATA_PATH, jsbsim_root()
    else:
        data_path, root = out / "aero_data.json", out
    folder = root / "aircraft" / geometry.name  # the package's own aircraft_dir() for the paper's
    if from_data:
        try:
            data = aero_data.load(data_path)
        except ValueError as err:
            raise BuildError(f"{err}; build without --from-data first") from err
    else:
        start = time.perf_counter()
        try:
            data = aero_data.compute_aero_data(geometry, log)
        except ValueError as err:  # a lattice that does not converge, a tail incidence that does not trim
            raise BuildError(f"{description}: {err}") from None
        data_path.parent.mkdir(parents=True, exist_ok=True)
        aero_data.save(data, data_path)
        log(f"aerodynamic data computed in {time.perf_counter() - start:.1f} s -> {data_path}")
    geometry = aero_data.solved_geometry(geometry, data)  # a tail incidence the build solved, as solved
    files = xml_writer.aircraft_files(geometry, data)
    xml_writer.write(files, folder)
    log(f"wrote {len(files)} files under {folder}")
    return Built(geometry, data, data_path, root, folder)


def summary(data: dict) -> str:
    """The stability figures and the analysis's checks, as the build prints them."""
    st = data["stability"]
    return (f"CG x = {st['cg_x_m']:.3f} m, neutral point x = {st['neutral_point_x_m']:.3f} m, "
            f"static margin {st['static_margin']:.2f} MAC, cruise alpha {st['cruise_alpha_deg']:.2f} deg\n"
            + checks_report(data))


def checks_report(data: dict) -> str:
    """The lattice's mesh-convergence table and the induced-yaw check, as printed by the build."""
    setup, checks = data["vlm_setup"], data["checks"]
    mesh = f"{setup['spanwise_panels_per_segment']} x {setup['chordwise_panels']}"
    lines = [(f"vortex lattice: {mesh} panels (spanwise per segment x chordwise), flat wing at "
             f"{setup['wing_incidence_deg']:.2f} deg incidence; convergence at the cruise angle of attack:"),
             f"  {'derivative':>10} {'mesh':>10} {'doubled':>10} {'change':>8}"]
    table = checks["mesh_convergence"]
    for name, row in table.items():
        line = f"  {name:>10} {row['mesh']:>10.5g} {row['doubled']:>10.5g} {100 * row['relative_change']:>7.2f}%"
        if name == "Cma":
            line += f"  (the neutral point moves {100 * analysis.neutral_point_shift_mac(table):.2f} % of the mean chord)"
        lines.append(line)
    failures = analysis.convergence_failures(table)
    limits = (f"each derivative within {100 * analysis.CONVERGENCE_TOLERANCE:g} % of its value on the doubled mesh, "
              f"Cma's neutral point within {100 * analysis.NEUTRAL_POINT_TOLERANCE_MAC:g} % of the mean chord")
    lines.append(f"  converged: {limits}" if not failures else f"  NOT converged ({'; '.join(failures)}); the check: "
                 f"{limits}")
    yaw = checks["aileron_induced_yaw"]
    lines.append(f"aileron induced yaw: dCn_s = -k CL dCl_s/(pi AR), lifting line k = {yaw['lifting_line_factor']:g}, "
                 f"lattice k = {yaw['factor']:.2f} at CL {yaw['CL']:.2f}")
    return "\n".join(lines)

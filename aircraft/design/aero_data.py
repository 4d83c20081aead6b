"""Compute, save and load the aerodynamic and propeller data set of the solar UAV.

``compute_aero_data`` runs the AeroSandbox analyses of :mod:`aircraft.design.analysis` and the
propeller BEMT of :mod:`aircraft.design.propeller` (both need the ``aero`` extra). The result is
saved as ``aero_data.json`` beside this module, so that the XML writer, which needs nothing but
numpy, reproduces the committed aircraft files exactly on any machine.
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from importlib import metadata
from pathlib import Path

import numpy as np

from .geometry import AircraftGeometry

DATA_PATH = Path(__file__).with_name("aero_data.json")
RHO0_KG_M3 = 1.225
G_MPS2 = 9.80665


def _cruise_alpha_deg(polar_cl: np.ndarray, alpha_deg: np.ndarray, cl_required: float) -> float:
    """Angle of attack of the linear range where the lift coefficient equals ``cl_required``."""
    linear = (alpha_deg >= -8) & (alpha_deg <= 10)
    return float(np.interp(cl_required, polar_cl[linear], alpha_deg[linear]))


def _cruise_cl(geometry: AircraftGeometry) -> float:
    """The lift coefficient of level flight at the reference EAS."""
    return geometry.mass_kg * G_MPS2 / (0.5 * RHO0_KG_M3 * geometry.envelope.reference_eas_mps**2
                                        * geometry.reference_area_m2)


def _balance(geometry: AircraftGeometry) -> tuple[float, float, float, dict]:
    """The cruise angle of attack (deg), the neutral point and the CG x (m), and the polar about the
    CG: the neutral point from the built-up polar about a reference point, then the CG at the
    chosen static margin ahead of it."""
    from . import analysis as an

    alpha = np.array(an.ALPHA_DEG, dtype=float)
    j_cruise = geometry.envelope.reynolds.index(geometry.envelope.cruise_reynolds)
    x_ref_m = geometry.wing.root_chord_m / 4.0
    polar_ref = an.longitudinal_polar(geometry, x_ref_m)
    alpha_cruise = _cruise_alpha_deg(polar_ref["CL"][:, j_cruise], alpha, _cruise_cl(geometry))
    da = 1.0
    cl_a = np.interp([alpha_cruise - da, alpha_cruise + da], alpha, polar_ref["CL"][:, j_cruise])
    cm_a = np.interp([alpha_cruise - da, alpha_cruise + da], alpha, polar_ref["Cm"][:, j_cruise])
    x_np_m = x_ref_m - (cm_a[1] - cm_a[0]) / (cl_a[1] - cl_a[0]) * geometry.reference_chord_m
    cg_x_m = x_np_m - geometry.static_margin * geometry.reference_chord_m
    return alpha_cruise, x_np_m, cg_x_m, an.longitudinal_polar(geometry, cg_x_m)


TAIL_INCIDENCE_TOLERANCE_CM = 1e-4  # the solved incidence's pitching moment at cruise with the elevator at 0


def solve_tail_incidence(geometry: AircraftGeometry, log=None) -> AircraftGeometry:
    """``geometry`` with the horizontal tail's incidence at which the polar's pitching moment about
    the CG is zero at the cruise angle of attack of the reference EAS with the elevator at zero
    (secant steps from the description's first guess; the moment is close to linear in the
    incidence); ``ValueError`` where no incidence within +-15 deg does it."""
    from . import analysis as an

    alpha = np.array(an.ALPHA_DEG, dtype=float)
    j_cruise = geometry.envelope.reynolds.index(geometry.envelope.cruise_reynolds)

    def cruise_cm(incidence_deg: float) -> float:
        trial = replace(geometry, horizontal_tail=replace(geometry.horizontal_tail, incidence_deg=incidence_deg))
        alpha_cruise, _, _, polar = _balance(trial)
        return float(np.interp(alpha_cruise, alpha, polar["Cm"][:, j_cruise]))

    x0 = geometry.horizontal_tail.incidence_deg
    x1 = x0 - 1.0
    f0, f1 = cruise_cm(x0), cruise_cm(x1)
    for _ in range(8):
        if abs(f1) < TAIL_INCIDENCE_TOLERANCE_CM or f1 == f0:
            break
        step = x1 - f1 * (x1 - x0) / (f1 - f0)
        if not -15.0 <= step <= 15.0:
            raise ValueError(f"horizontal_tail.incidence_deg = \"trim\": the incidence that trims {geometry.name} at "
                             f"its reference EAS with the elevator at zero lies beyond +-15 deg (the secant points to "
                             f"{step:.1f} deg); give the incidence as a number, or move the tail or the static margin")
        x0, x1, f0 = x1, step, f1
        f1 = cruise_cm(x1)
    if abs(f1) >= TAIL_INCIDENCE_TOLERANCE_CM:
        raise ValueError(f"horizontal_tail.incidence_deg = \"trim\": no incidence found that trims {geometry.name} "
                         f"at its reference EAS with the elevator at zero ({x1:.2f} deg, the last tried, leaves a "
                         f"pitching moment of {f1:.2g}); give the incidence as a number")
    if log is not None:
        log(f"horizontal tail incidence solved: {x1:.3f} deg trims at {geometry.envelope.reference_eas_mps:g} m/s "
            "EAS with the elevator at zero")
    return replace(geometry, horizontal_tail=replace(geometry.horizontal_tail, incidence_deg=float(x1)))


def solved_geometry(geometry: AircraftGeometry, data: dict) -> AircraftGeometry:
    """``geometry`` with the horizontal tail's incidence that ``data`` (a data set built from it)
    was computed with: the solved one where the description asked for it, else its own."""
    if not geometry.solve_tail_incidence:
        return geometry
    incidence_deg = float(data["meta"]["geometry"]["horizontal_tail"]["incidence_deg"])
    return replace(geometry, horizontal_tail=replace(geometry.horizontal_tail, incidence_deg=incidence_deg))


def compute_aero_data(geometry: AircraftGeometry | None = None, log=None) -> dict:
    """All tables the XML writer needs, computed from ``geometry``, with the checks the build prints
    (``log`` hears of a refined lattice and a solved tail incidence); ``analysis.MeshNotConverged``
    where no lattice converges, ``ValueError`` where no tail incidence trims."""
    geometry = geometry or AircraftGeometry()
    from . import analysis as an
    from .propeller import propeller_coefficients

    if geometry.solve_tail_incidence:
        geometry = solve_tail_incidence(geometry, log)
    envelope = geometry.envelope
    cl_cruise = _cruise_cl(geometry)
    # Every table after the balance is computed about the CG.
    alpha_cruise, x_np_m, cg_x_m, polar = _balance(geometry)
    slopes = an.lift_slopes(geometry)
    # The lattice's mesh: refined until its derivatives converge at the cruise angle of attack.
    mesh, incidence_deg, convergence = an.converged_mesh(geometry, cg_x_m, alpha_cruise, cl_cruise, log)
    data = {
        "meta": {
            "generator": "aircraft.design.aero_data.compute_aero_data",
            "aerosandbox": metadata.version("aerosandbox"),
            "neuralfoil": metadata.version("neuralfoil"),
            "geometry": asdict(geometry),
        },
        "stability": {
            "cg_x_m": cg_x_m,
            "neutral_point_x_m": float(x_np_m),
            "static_margin": geometry.static_margin,
            "cruise_cl": cl_cruise,
            "cruise_alpha_deg": alpha_cruise,
            "lift_slopes_per_rad": slopes,
        },
        "grids": {
            "alpha_deg": list(an.ALPHA_DEG),
            "reynolds": list(envelope.reynolds),
            "vlm_alpha_deg": list(an.VLM_ALPHA_DEG),
            "beta_deg": list(an.BETA_DEG),
            "deflection_deg": list(an.DEFLECTION_DEG),
        },
        "polar": polar,
        "sideslip": an.sideslip_increments(geometry, cg_x_m, alpha_cruise),
        "vlm": an.vlm_derivatives(geometry, cg_x_m, incidence_deg, mesh),
        "vlm_setup": {"spanwise_panels_per_segment": mesh.spanwise, "chordwise_panels": mesh.chordwise,
                      "wing_incidence_deg": incidence_deg},
        "profile": {"Cnr": an.profile_yaw_damping(geometry, cl_cruise)},
        "downwash_lag": an.downwash_lag_derivatives(geometry, cg_x_m, slopes),
        "controls": an.control_increments(geometry, cg_x_m, slopes),
        "apparent_mass_per_density": an.apparent_mass_per_density(geometry, cg_x_m),
        # Checks the build prints: the lattice's convergence at the cruise angle of attack, and the
        # lattice's own value of the lifting-line factor of the ailerons' induced yaw.
        "checks": {
            "mesh_convergence": convergence,
            "aileron_induced_yaw": {"lifting_line_factor": an.AILERON_INDUCED_YAW_FACTOR,
                                    **an.aileron_induced_yaw_factor(geometry, cg_x_m, incidence_deg, alpha_cruise,
                                                                    mesh=mesh)},
        },
    }
    prop = propeller_coefficients(geometry.propeller)
    data["propeller"] = {"J": prop.advance_ratio, "CT": prop.thrust_coeff, "CP": prop.power_coeff}
    return _to_plain(data)


def _to_plain(obj):
    """numpy arrays and scalars to lists and floats, rounded for a stable, reviewable file."""
    if isinstance(obj, dict):
        return {k: _to_plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_to_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _to_plain(obj.tolist())
    if isinstance(obj, (float, np.floating)):
        return float(f"{float(obj):.7g}")
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def save(data: dict, path: Path = DATA_PATH) -> None:
    """Write the data set as indented JSON."""
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def load(path: Path = DATA_PATH) -> dict:
    """Read a saved data set."""
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ValueError(f"cannot read the aerodynamic data set {path}: {err}") from err

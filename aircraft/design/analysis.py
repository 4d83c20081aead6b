"""Aerodynamic tables of the solar UAV computed from its geometry with AeroSandbox.

Methods, one per kind of number:

* Static polar against angle of attack and Reynolds number (CL, CD, Cm): AeroSandbox's
  ``AeroBuildup`` (NeuralFoil section polars, lifting-line corrections, fuselage build-up), which
  carries stall and post-stall. ``AeroBuildup`` sees every surface in the free stream, so the
  horizontal tail is analysed on its own at its local angle of attack
  ``α_t = α + i_t − ε(α)`` with the classical wing downwash ``ε = 2·CL_wing/(π·AR)``
  (Nelson, *Flight Stability and Automatic Control*, §2.4) and the tail efficiency ``η_t``.
* Lateral/directional and rate derivatives (CYβ, Clβ, Cnβ, CYp, Clp, Cnp, CLq, Cmq, CYq, Cnq, CYr,
  Clr, Cnr) against angle of attack: AeroSandbox's vortex-lattice method (inviscid, tail downwash
  included), in its linear range; the tables hold their end values beyond it. The rates turn the
  aircraft about its CG, the mesh comes from a convergence study (``converged_mesh``), and Cnr
  gains the wing's profile-drag part, which an inviscid lattice cannot see.
* Downwash lag (CLα̇, Cmα̇): the tail-volume estimate with the polar's downwash model.
* Sideslip increments of lift, drag and pitching moment (even in β): ``AeroBuildup`` in sideslip.
* Control surfaces, which AeroSandbox's 3-D methods do not model: the section increments Δcl, Δcd,
  Δcm of the deflected airfoil come from NeuralFoil (``Airfoil.add_control_surface``), and are
  carried to the aircraft by strip theory with the 3-D lift-slope ratio ``k = CLα_3D / a0``
  (the textbook aileron / elevator / rudder estimates, Nelson §2.4, §5.3 and Etkin & Reid §5.7).
  Adverse yaw of the ailerons comes from the profile-drag asymmetry per side and from the induced
  drag of the antisymmetric load, ``ΔCn_s = −3·CL·ΔCl_s/(π·AR)`` (lifting-line theory, checked
  with the lattice by ``aileron_induced_yaw_factor``), both in stability axes.

Axes: lift, drag and side force in wind axes; rolling, pitching and yawing moments in body axes
about the CG, except the aileron's, which strip theory gives in stability axes and the XML writer
rotates to body axes with the angle of attack.

Reynolds number is the flight-condition variable (the breakpoints are the description's
``envelope.reynolds``): for the paper's aircraft at equivalent airspeeds of 8-12 m/s, Mach stays
below 0.15 while the Reynolds number on the mean chord falls from about 1.9e6 to 0.4e6 between sea
level and 20 km. Each Reynolds breakpoint is evaluated at the altitude where the envelope's
reference EAS (10 m/s) gives it, so the Mach number that goes with it is the one the aircraft meets
there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import AircraftGeometry, TailSurface

RHO0_KG_M3 = 1.225  # sea-level density of the 1976 standard atmosphere
ALPHA_DEG = (-90, -60, -45, -30, -20, -16, -12, -10, -8, -6, -4, -2, 0, 2, 4, 6, 8, 10, 12, 14, 16,
             18, 20, 25, 30, 45, 60, 90)
VLM_ALPHA_DEG = (-10, -6, -2, 0, 2, 4, 6, 8, 10, 12, 14)
BETA_DEG = (0, 4, 8, 12, 16, 20, 30)
DEFLECTION_DEG = (-30, -25, -20, -15, -10, -6, -3, 0, 3, 6, 10, 15, 20, 25, 30)


def flight_condition(reynolds: float, geometry: AircraftGeometry) -> tuple[float, float]:
    """Altitude (m) and true airspeed (m/s) at which the mean chord sees ``reynolds``.

    The altitude is the one where the envelope's reference EAS gives that Reynolds number; outside
    the envelope's altitude range the altitude is held at the end and the airspeed changed instead.
    """
    import aerosandbox as asb

    def reynolds_at(altitude_m: float, eas_mps: float) -> tuple[float, float]:
        atmo = asb.Atmosphere(altitude=altitude_m)
        tas_mps = eas_mps * np.sqrt(RHO0_KG_M3 / atmo.density())
        return float(atmo.density() * tas_mps * geometry.reference_chord_m / atmo.dynamic_viscosity()), tas_mps

    eas_mps = geometry.envelope.reference_eas_mps
    low, high = geometry.envelope.altitude_range_m
    for end in (low, high):
        re_end, tas_end = reynolds_at(end, eas_mps)
        if (end == low and reynolds >= re_end) or (end == high and reynolds <= re_end):
            return end, tas_end * reynolds / re_end
    for _ in range(60):  # bisection: Reynolds number falls monotonically with altitude at fixed EAS
        mid = 0.5 * (low + high)
        low, high = (mid, high) if reynolds_at(mid, eas_mps)[0] > reynolds else (low, mid)
    altitude_m = 0.5 * (low + high)
    return altitude_m, reynolds_at(altitude_m, eas_mps)[1]


def _operating_point(reynolds: float, geometry: AircraftGeometry, alpha_deg=0.0, beta_deg=0.0):
    import aerosandbox as asb

    altitude_m, tas_mps = flight_condition(reynolds, geometry)
    return asb.OperatingPoint(atmosphere=asb.Atmosphere(altitude=altitude_m), velocity=tas_mps,
                              alpha=alpha_deg, beta=beta_deg)


# The vortex lattice sees only a section's mean line, and AeroSandbox's lattice resolves the
# FX 63-137's strong aft camber poorly: its lift at the cruise angle of attack converges as 1/N with
# the chordwise panels (0.52, 0.63, 0.69, 0.72 with 6, 12, 24, 48), and Clr and Cnp with it. For
# the lattice the wing is therefore a flat plate (a symmetric section) at the incidence that makes
# the lattice lift what the viscous polar lifts at the cruise angle of attack: the same spanwise
# load at the same lift, and a lattice that converges at a few chordwise panels.
LATTICE_SECTION = "naca0010"


def _wing(geometry: AircraftGeometry, extra_twist: tuple[tuple[float, float], ...] = (), name: str = "wing",
          mirrored: bool | None = None, lattice_incidence_deg: float | None = None):
    """The main wing, symmetric; or, when ``mirrored`` is given, one half of it (the right one, or the
    left one if ``mirrored``) with ``extra_twist`` ((y in m, degrees), ...) added at those stations
    and linearly in between. With ``lattice_incidence_deg`` the wing as the lattice sees it: flat
    sections (``LATTICE_SECTION``) at that root incidence, washout kept."""
    import aerosandbox as asb

    w = geometry.wing
    if lattice_incidence_deg is None:
        af, incidence_deg = asb.Airfoil(w.airfoil), w.incidence_deg
    else:
        af, incidence_deg = asb.Airfoil(LATTICE_SECTION), lattice_incidence_deg
    half_span = w.span_m / 2.0
    tip_x = (w.root_chord_m - w.tip_chord_m) / 4.0  # unswept quarter-chord line
    tip_z = (half_span - w.kink_y_m) * np.tan(np.radians(w.outer_dihedral_deg))
    a = geometry.aileron
    outer = half_span - w.kink_y_m
    side = -1.0 if mirrored else 1.0

    def station(y_m: float, twist_extra_deg: float = 0.0):
        frac = (y_m - w.kink_y_m) / outer
        chord = w.root_chord_m + frac * (w.tip_chord_m - w.root_chord_m)
        return asb.WingXSec(xyz_le=[frac * tip_x, side * y_m, frac * tip_z], chord=chord, airfoil=af,
                            twist=incidence_deg + frac * w.tip_twist_deg + twist_extra_deg)

    inner = [station(y, t) for y, t in extra_twist] if extra_twist else [station(a.inner_y_m), station(a.outer_y_m)]
    xsecs = [asb.WingXSec(xyz_le=[0, 0, 0], chord=w.root_chord_m, airfoil=af, twist=incidence_deg),
             station(w.kink_y_m), *inner, station(half_span)]
    if mirrored is None:
        return asb.Wing(name=name, symmetric=True, xsecs=xsecs)
    # AeroSandbox takes a surface's normal from the order of its sections: root to tip on the right,
    # tip to root on the left, so that both halves lift upwards.
    return asb.Wing(name=name, symmetric=False, xsecs=xsecs[::-1] if mirrored else xsecs)


def _tail(surface: TailSurface, name: str, symmetric: bool, incidence_offset_deg: float = 0.0):
    import aerosandbox as asb

    af = asb.Airfoil(surface.airfoil)
    twist = surface.incidence_deg + incidence_offset_deg
    return asb.Wing(name=name, symmetric=symmetric, xsecs=[
        asb.WingXSec(xyz_le=list(surface.root_le_m), chord=surface.root_chord_m, airfoil=af, twist=twist),
        asb.WingXSec(xyz_le=list(surface.tip_le_m), chord=surface.tip_chord_m, airfoil=af, twist=twist),
    ])


def airplane(geometry: AircraftGeometry, cg_x_m: float, parts=("wing", "htail", "vtail", "fuselage"),
             lattice_incidence_deg: float | None = None):
    """The AeroSandbox model of the aircraft (or of some of its parts), with the CG at the origin.

    Moments are taken about ``xyz_ref``, but AeroSandbox's vortex lattice turns the body rates
    p, q, r about the geometry origin. With the origin at the wing-root leading edge a pitch rate
    would also move the CG, adding CL_alpha * 2 x_cg / c to CLq (about +4.3 here). Moving the
    geometry so that the CG is the origin makes every rate derivative one about the CG.
    ``lattice_incidence_deg``: the wing as the vortex lattice sees it (see ``LATTICE_SECTION``).
    """
    import aerosandbox as asb

    wings = []
    if "wing" in parts:
        wings.append(_wing(geometry, lattice_incidence_deg=lattice_incidence_deg))
    if "htail" in parts:
        wings.append(_tail(geometry.horizontal_tail, "htail", symmetric=True))
    if "vtail" in parts:
        wings.append(_tail(geometry.vertical_tail, "vtail", symmetric=False))
    fuselages = []
    if "fuselage" in parts:
        fuselages.append(asb.Fuselage(name="pod_and_boom", xsecs=[
            asb.FuselageXSec(xyz_c=[x, 0, 0], radius=r) for x, r in geometry.fuselage_stations_m]))
    to_cg = [-cg_x_m, 0.0, -geometry.cg_z_m]
    return asb.Airplane(name=geometry.name, xyz_ref=[0.0, 0.0, 0.0], wings=[w.translate(to_cg) for w in wings],
                        fuselages=[f.translate(to_cg) for f in fuselages], s_ref=geometry.reference_area_m2,
                        c_ref=geometry.reference_chord_m, b_ref=geometry.reference_span_m)


def _trapezoid_area_m2(s: TailSurface) -> float:
    """Planform area of one trapezoidal panel (the whole fin; half a horizontal tail)."""
    root, tip = np.array(s.root_le_m), np.array(s.tip_le_m)
    span = float(np.hypot(tip[1] - root[1], tip[2] - root[2]))
    return 0.5 * (s.root_chord_m + s.tip_chord_m) * span


def _mac_m(s: TailSurface) -> float:
    """Mean aerodynamic chord of a trapezoidal panel."""
    taper = s.tip_chord_m / s.root_chord_m
    return 2 / 3 * s.root_chord_m * (1 + taper + taper**2) / (1 + taper)


def _mac_quarter_chord(s: TailSurface) -> np.ndarray:
    """Position of the quarter chord of a trapezoidal panel's mean aerodynamic chord."""
    taper = s.tip_chord_m / s.root_chord_m
    frac = (1 + 2 * taper) / (3 * (1 + taper))  # spanwise position of the MAC
    le = np.array(s.root_le_m) + frac * (np.array(s.tip_le_m) - np.array(s.root_le_m))
    return le + np.array([0.25 * _mac_m(s), 0.0, 0.0])


def longitudinal_polar(geometry: AircraftGeometry, cg_x_m: float) -> dict[str, np.ndarray]:
    """CL, CD, Cm (about the CG) on the (α, Re) grid, tail with downwash and efficiency."""
    import aerosandbox as asb

    alpha = np.array(ALPHA_DEG, dtype=float)
    wing_body = airplane(geometry, cg_x_m, parts=("wing", "vtail", "fuselage"))
    tail_only = airplane(geometry, cg_x_m, parts=("htail",))
    out = {k: np.zeros((alpha.size, len(geometry.envelope.reynolds))) for k in ("CL", "CD", "Cm")}
    for j, re in enumerate(geometry.envelope.reynolds):
        wb = asb.AeroBuildup(wing_body, _operating_point(re, geometry, alpha_deg=alpha)).run()
        cl_wing = np.asarray(wb["CL"], dtype=float)
        # Downwash grows with wing lift and vanishes past stall as the wake lifts off; hold it to the
        # linear-range lift so it does not jump post-stall.
        downwash_deg = np.degrees(2.0 * np.clip(cl_wing, -1.0, 1.6) / (np.pi * geometry.aspect_ratio))
        tail_alpha = alpha - downwash_deg
        ht = asb.AeroBuildup(tail_only, _operating_point(re, geometry, alpha_deg=tail_alpha)).run()
        eta = geometry.horizontal_tail.efficiency
        # Tail forces are in the tail's own wind axes: rotate them into the aircraft's.
        eps = np.radians(downwash_deg)
        cl_t, cd_t = np.asarray(ht["CL"], dtype=float), np.asarray(ht["CD"], dtype=float)
        out["CL"][:, j] = cl_wing + eta * (cl_t * np.cos(eps) - cd_t * np.sin(eps))
        out["CD"][:, j] = np.asarray(wb["CD"], dtype=float) + eta * (cd_t * np.cos(eps) + cl_t * np.sin(eps))
        out["Cm"][:, j] = np.asarray(wb["Cm"], dtype=float) + eta * np.asarray(ht["Cm"], dtype=float)
    return out


def sideslip_increments(geometry: AircraftGeometry, cg_x_m: float, alpha_deg: float) -> dict[str, np.ndarray]:
    """ΔCL, ΔCD, ΔCm against |β| (even in β) at the cruise angle of attack, mid-range Reynolds."""
    import aerosandbox as asb

    beta = np.array(BETA_DEG, dtype=float)
    op = _operating_point(1.0e6, geometry, alpha_deg=alpha_deg, beta_deg=beta)
    r = asb.AeroBuildup(airplane(geometry, cg_x_m), op).run()
    return {f"{k}beta": np.asarray(r[k], dtype=float) - float(np.asarray(r[k])[0]) for k in ("CL", "CD", "Cm")}


VLM_DERIVATIVES = ("CYb", "Clb", "Cnb", "CYp", "Clp", "Cnp", "CLq", "Cmq", "CYq", "Cnq", "CYr", "Clr", "Cnr")
# Derivatives that vanish by symmetry; left out of the mesh-convergence criterion.
SYMMETRY_ZERO = ("CYq", "Cnq")
# Roll- and yaw-rate derivatives whose tails' share is tabulated on its own: the rotational gusts
# of a frozen field act on a part of the aircraft only (the roll gust, a spanwise gradient of w,
# on the wing, the horizontal tail's small share counted with the fin's; the yaw gust, a v varying
# along x, on the fin).
TAIL_SHARES = ("CYp", "Clp", "Cnp", "CYr", "Clr", "Cnr")


@dataclass(frozen=True)
class LatticeMesh:
    """Vortex-lattice panels per wing segment (between two sections) and along each chord.

    Spanwise panels are evenly spaced: AeroSandbox's default cosine spacing puts sliver panels
    (a thousandth of the chord wide) at both ends of every segment, and where two segments meet
    those slivers make the influence matrix ill-conditioned: from 20 panels per segment on,
    Cnp jumped from -0.04 to +0.9. Chordwise panels keep AeroSandbox's cosine spacing, which
    resolves the leading and trailing edges of the (flat, see ``LATTICE_SECTION``) sections.
    """

    spanwise: int
    chordwise: int

    def doubled(self) -> LatticeMesh:
        return LatticeMesh(2 * self.spanwise, 2 * self.chordwise)


# The first mesh tried (``converged_mesh``): on the paper's aircraft and the small example every
# derivative here is within the tolerances below of its value on the mesh of twice the resolution.
VLM_MESH = LatticeMesh(spanwise=8, chordwise=6)
# Each mesh tried in turn, each against its double, until one passes (the second's check, against
# 24 x 18 panels, takes about two minutes on one core; 32 x 24 would take eight).
MESH_REFINEMENTS = (VLM_MESH, LatticeMesh(spanwise=12, chordwise=9))
CONVERGENCE_TOLERANCE = 0.03  # each derivative's relative change on the doubled mesh
# Cma is judged by the neutral point it places, |dCma / CLa| as a fraction of the mean chord: it is
# a small difference of the wing's and the tail's large moments, so its relative change says little
# (9 % on the small example moves its neutral point by 0.3 % of the chord).
NEUTRAL_POINT_TOLERANCE_MAC = 0.005


def _vortex_lattice(plane, op_point, mesh: LatticeMesh):
    import aerosandbox as asb

    return asb.VortexLatticeMethod(plane, op_point, spanwise_resolution=mesh.spanwise,
                                   spanwise_spacing_function=np.linspace, chordwise_resolution=mesh.chordwise)


def _tail_efficiency(geometry: AircraftGeometry) -> float:
    """The tails' dynamic-pressure ratio q_tail/q, which the lattice (one free stream) leaves out."""
    eta = geometry.horizontal_tail.efficiency
    if geometry.vertical_tail.efficiency != eta:
        raise ValueError("the lattice applies one tail efficiency; the horizontal and vertical tails' differ")
    return eta


def _lattice_point(geometry: AircraftGeometry, cg_x_m: float, incidence_deg: float, alpha_deg: float,
                   mesh: LatticeMesh, derivatives: bool = True) -> dict[str, float]:
    """Lattice coefficients (and derivatives) of the aircraft at one α, the tails' share scaled by
    their efficiency: wing alone + η (wing with tails − wing alone), the same η the polar and the
    control surfaces use. The tails' share includes the wing's downwash on them."""
    op = _operating_point(geometry.envelope.lattice_reynolds, geometry, alpha_deg=alpha_deg)
    keys = VLM_DERIVATIVES + ("CL", "CLa", "Cma") if derivatives else ("CL",)
    runs = []
    for parts in (("wing",), ("wing", "htail", "vtail")):
        vlm = _vortex_lattice(airplane(geometry, cg_x_m, parts=parts, lattice_incidence_deg=incidence_deg), op, mesh)
        r = vlm.run_with_stability_derivatives() if derivatives else vlm.run()
        runs.append({k: float(np.asarray(r[k]).ravel()[0]) for k in keys})
    eta = _tail_efficiency(geometry)
    wing, whole = runs
    out = {k: wing[k] + eta * (whole[k] - wing[k]) for k in keys}
    out.update({f"{k}_tails": eta * (whole[k] - wing[k]) for k in keys if k in TAIL_SHARES})
    return out


def vlm_derivatives(geometry: AircraftGeometry, cg_x_m: float, incidence_deg: float,
                    mesh: LatticeMesh = VLM_MESH) -> dict[str, np.ndarray]:
    """Stability derivatives against α from the vortex lattice (wing at ``incidence_deg``, see
    ``lattice_wing_incidence_deg``; tails at their efficiency, see ``_lattice_point``): rates
    non-dimensional, angles per rad, moments in body axes about the CG, side force in wind axes
    (AeroSandbox's conventions, which are JSBSim's). ``<name>_tails`` is the tails' share of the
    ``TAIL_SHARES`` derivatives."""
    points = [_lattice_point(geometry, cg_x_m, incidence_deg, a, mesh) for a in VLM_ALPHA_DEG]
    return {k: np.array([p[k] for p in points]) for k in points[0]}


def mesh_convergence(geometry: AircraftGeometry, cg_x_m: float, incidence_deg: float, alpha_deg: float,
                     mesh: LatticeMesh = VLM_MESH) -> dict[str, dict[str, float]]:
    """Each lattice derivative at ``mesh`` and at twice its resolution in both directions, at one α.

    Returns ``{derivative: {"mesh": value, "doubled": value, "relative_change": |Δ| / |doubled|}}``.
    """
    coarse = _lattice_point(geometry, cg_x_m, incidence_deg, alpha_deg, mesh)
    fine = _lattice_point(geometry, cg_x_m, incidence_deg, alpha_deg, mesh.doubled())
    return {k: {"mesh": coarse[k], "doubled": fine[k],
                "relative_change": abs(coarse[k] - fine[k]) / max(abs(fine[k]), 1e-12)}
            for k in VLM_DERIVATIVES + ("CL", "CLa", "Cma") if k not in SYMMETRY_ZERO}


def neutral_point_shift_mac(table: dict[str, dict[str, float]]) -> float:
    """How far the neutral point moves between ``mesh_convergence``'s two meshes, as a fraction of
    the mean chord: |ΔCma / CLa|."""
    return abs(table["Cma"]["mesh"] - table["Cma"]["doubled"]) / abs(table["CLa"]["doubled"])


def convergence_failures(table: dict[str, dict[str, float]]) -> list[str]:
    """What ``mesh_convergence``'s ``table`` shows unconverged, one text each ("Cmq changes 4.10 %
    (limit 3 %)"); empty where every derivative passes (Cma by its neutral-point shift)."""
    out = []
    for name, row in table.items():
        if name == "Cma":
            shift = neutral_point_shift_mac(table)
            if shift > NEUTRAL_POINT_TOLERANCE_MAC:
                out.append(f"Cma moves the neutral point {100 * shift:.2f} % of the mean chord "
                           f"(limit {100 * NEUTRAL_POINT_TOLERANCE_MAC:g} %)")
        elif row["relative_change"] > CONVERGENCE_TOLERANCE:
            out.append(f"{name} changes {100 * row['relative_change']:.2f} % (limit {100 * CONVERGENCE_TOLERANCE:g} %)")
    return out


class MeshNotConverged(ValueError):
    """No lattice mesh the build tries passes its convergence check; the message says which
    derivatives did not converge and what to change."""


def converged_mesh(geometry: AircraftGeometry, cg_x_m: float, alpha_deg: float, lift_coefficient: float,
                   log=None) -> tuple[LatticeMesh, float, dict[str, dict[str, float]]]:
    """The first mesh of ``MESH_REFINEMENTS`` whose derivatives at ``alpha_deg`` pass the check
    against twice its resolution (``convergence_failures``), with the flat wing's incidence on it
    (``lattice_wing_incidence_deg``) and its convergence table; ``MeshNotConverged`` where none
    does. ``log`` hears of each refinement."""
    for mesh in MESH_REFINEMENTS:
        incidence_deg = lattice_wing_incidence_deg(geometry, cg_x_m, alpha_deg, lift_coefficient, mesh)
        table = mesh_convergence(geometry, cg_x_m, incidence_deg, alpha_deg, mesh)
        failures = convergence_failures(table)
        if not failures:
            return mesh, incidence_deg, table
        if log is not None:
            log(f"vortex lattice at {mesh.spanwise} x {mesh.chordwise} panels not converged ({'; '.join(failures)}): "
                "refining")
    raise MeshNotConverged(
        f"the vortex lattice did not converge at {mesh.spanwise} x {mesh.chordwise} panels against "
        f"{2 * mesh.spanwise} x {2 * mesh.chordwise}: {'; '.join(failures)}. Its usual causes: a tail far smaller "
        "than the wing or lying in the plane of the wing's wake (give it some height above the wing, the z of "
        "horizontal_tail.root_le_m), or a wing segment much narrower than the others (wing.kink_y_m near the "
        "root or the tip)")


def lattice_wing_incidence_deg(geometry: AircraftGeometry, cg_x_m: float, alpha_deg: float,
                               lift_coefficient: float, mesh: LatticeMesh | None = None) -> float:
    """Root incidence of the flat lattice wing at which the aircraft's lattice lift coefficient at
    ``alpha_deg`` is ``lift_coefficient``: secant steps from 0° and 1° (the lift is almost linear
    in the incidence; only the panels' tilt is not)."""
    mesh = mesh or VLM_MESH

    def lift(incidence_deg: float) -> float:
        return _lattice_point(geometry, cg_x_m, incidence_deg, alpha_deg, mesh, derivatives=False)["CL"]

    x0, x1 = 0.0, 1.0
    f0, f1 = lift(x0) - lift_coefficient, lift(x1) - lift_coefficient
    for _ in range(4):
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = lift(x1) - lift_coefficient
        if abs(f1) < 1e-4 * lift_coefficient:
            break
    return x1


def section_increments(airfoil_name: str, hinge_x: float, reynolds: float, mach: float) -> dict[str, np.ndarray]:
    """Δcl, Δcd, Δcm of a section against deflection (trailing edge down positive), NeuralFoil."""
    import aerosandbox as asb

    base = asb.Airfoil(airfoil_name)
    rows = []
    for d in DEFLECTION_DEG:
        r = base.add_control_surface(deflection=float(d), hinge_point_x=hinge_x).get_aero_from_neuralfoil(
            alpha=0.0, Re=reynolds, mach=mach, model_size="large")
        rows.append([float(np.asarray(r[k]).ravel()[0]) for k in ("CL", "CD", "CM")])
    rows_arr = np.array(rows)
    rows_arr -= rows_arr[DEFLECTION_DEG.index(0)]
    return {"dcl": rows_arr[:, 0], "dcd": rows_arr[:, 1], "dcm": rows_arr[:, 2]}


def section_lift_slope_per_rad(airfoil_name: str, reynolds: float, mach: float) -> float:
    """Two-dimensional lift slope a0 around zero angle of attack, NeuralFoil."""
    import aerosandbox as asb

    r = asb.Airfoil(airfoil_name).get_aero_from_neuralfoil(alpha=np.array([-2.0, 2.0]), Re=reynolds, mach=mach,
                                                           model_size="large")
    cl = np.asarray(r["CL"], dtype=float)
    return float((cl[1] - cl[0]) / np.radians(4.0))


def _mach(reynolds: float, geometry: AircraftGeometry) -> float:
    import aerosandbox as asb

    altitude_m, tas_mps = flight_condition(reynolds, geometry)
    return float(tas_mps / asb.Atmosphere(altitude=altitude_m).speed_of_sound())


# Lifting-line theory with an elliptic base loading (Fourier term A1 = CL/(π AR)): the ailerons'
# antisymmetric load (A2, with ΔCl = −π AR A2/4) meets the base loading in the induced drag as
# 3 A1 A2, so the induced yawing moment is ΔCn = −3 CL ΔCl/(π AR) in stability axes (Phillips,
# *Mechanics of Flight*, the induced yawing moment of a wing with antisymmetric loading): twice for
# the base lift acting in the aileron's changed downwash, once for the aileron's lift in the base
# downwash. ``aileron_induced_yaw_factor`` checks it with the lattice.
AILERON_INDUCED_YAW_FACTOR = 3.0


def control_increments(geometry: AircraftGeometry, cg_x_m: float, lift_slopes: dict[str, float]) -> dict[str, np.ndarray]:
    """Per-surface coefficient increments on the (deflection, Re) grid, by strip theory.

    Returned keys: ``<coef>_<surface>`` with surface in ``aileron`` (the right aileron, trailing
    edge down positive; the left one is its mirror image), ``elevator`` (one half of the elevator,
    trailing edge down positive) and ``rudder`` (trailing edge left positive). ``Cn_aileron_induced``
    is the adverse-yaw increment per unit aircraft lift coefficient.

    Axes: forces in wind axes. The aileron's rolling and yawing moments are in stability axes (its
    lift acts across the airflow and its drag along it; the writer rotates them to body axes with
    the angle of attack); the tail surfaces' moments are in body axes (their forces act across the
    surface and their arms run along the body axes).
    """
    w, a = geometry.wing, geometry.aileron
    S, b, c = geometry.reference_area_m2, geometry.reference_span_m, geometry.reference_chord_m
    # Aileron strip integrals over the tapered outer panel.
    y = np.linspace(a.inner_y_m, a.outer_y_m, 201)
    chord = _wing_chord_m(geometry, y)
    int_c, int_cy, int_c2 = (np.trapezoid(chord, y), np.trapezoid(chord * y, y), np.trapezoid(chord**2, y))
    dihedral = np.radians(w.outer_dihedral_deg)
    x_quarter_chord_m = w.root_chord_m / 4.0  # straight quarter-chord line

    ht, vt = geometry.horizontal_tail, geometry.vertical_tail
    s_half_m2, s_fin_m2 = _trapezoid_area_m2(ht), _trapezoid_area_m2(vt)
    ht_ac, vt_ac = _mac_quarter_chord(ht), _mac_quarter_chord(vt)
    ht_mac, vt_mac = _mac_m(ht), _mac_m(vt)

    keys = [f"{k}_aileron" for k in ("CL", "CD", "CY", "Cl", "Cm", "Cn", "Cn_aileron_induced")]
    keys += [f"{k}_elevator" for k in ("CL", "CD", "Cm")] + [f"{k}_rudder" for k in ("CY", "CD", "Cl", "Cm", "Cn")]
    out = {k.replace("_aileron_induced_aileron", "_aileron_induced"): np.zeros((len(DEFLECTION_DEG), len(geometry.envelope.reynolds)))
           for k in keys}
    for j, re in enumerate(geometry.envelope.reynolds):
        mach = _mach(re, geometry)
        # Aileron: wing section, Reynolds number scaled to the local chord.
        re_ail = re * float(np.mean(chord)) / c
        sec = section_increments(w.airfoil, 1.0 - a.chord_fraction, re_ail, mach)
        k_wing = lift_slopes["wing_3d"] / section_lift_slope_per_rad(w.airfoil, re_ail, mach)
        normal = k_wing * sec["dcl"] * int_c / S  # normal-force increment of the panel
        cl_roll = -k_wing * sec["dcl"] * np.cos(dihedral) * int_cy / (S * b)  # right wing up: roll left
        dcd = sec["dcd"] * int_c / S
        out["CL_aileron"][:, j] = normal * np.cos(dihedral)
        out["CY_aileron"][:, j] = -normal * np.sin(dihedral)  # right panel's normal leans inboard
        out["Cl_aileron"][:, j] = cl_roll
        out["CD_aileron"][:, j] = dcd
        out["Cm_aileron"][:, j] = (normal * np.cos(dihedral) * (cg_x_m - x_quarter_chord_m) / c
                                   + k_wing * sec["dcm"] * int_c2 / (S * c))
        out["Cn_aileron"][:, j] = dcd * (int_cy / int_c) / b  # drag on the right wing yaws the nose right
        out["Cn_aileron_induced"][:, j] = -AILERON_INDUCED_YAW_FACTOR * cl_roll / (np.pi * geometry.aspect_ratio)
        # Elevator (one half) and rudder: tail sections, strip theory over the whole span.
        for name, surf, area, ac, mac in (("elevator", ht, s_half_m2, ht_ac, ht_mac),
                                          ("rudder", vt, s_fin_m2, vt_ac, vt_mac)):
            re_t = re * mac / c
            sec = section_increments(surf.airfoil, 1.0 - surf.control_chord_fraction, re_t, mach)
            k_t = lift_slopes[f"{name}_3d"] / section_lift_slope_per_rad(surf.airfoil, re_t, mach)
            force = surf.efficiency * k_t * sec["dcl"] * area / S
            drag = surf.efficiency * sec["dcd"] * area / S
            moment_own = surf.efficiency * k_t * sec["dcm"] * area * mac / S
            arm_x = ac[0] - cg_x_m
            arm_z = ac[2] - geometry.cg_z_m
            if name == "elevator":
                out["CL_elevator"][:, j] = force
                out["CD_elevator"][:, j] = drag
                out["Cm_elevator"][:, j] = -force * arm_x / c + moment_own / c + drag * arm_z / c
            else:
                # Trailing edge left pushes the fin to the right (+Y): nose left, right wing down.
                out["CY_rudder"][:, j] = force
                out["CD_rudder"][:, j] = drag
                # The fin section's own moment turns its leading edge away from its lift: nose left.
                out["Cn_rudder"][:, j] = -force * arm_x / b + moment_own / b
                out["Cl_rudder"][:, j] = force * arm_z / b
                out["Cm_rudder"][:, j] = drag * arm_z / c  # drag above the CG pitches the nose up
    return out


def lift_slopes(geometry: AircraftGeometry) -> dict[str, float]:
    """3-D lift slopes (per rad, on each surface's own area) of the wing and the tails, vortex lattice."""
    import aerosandbox as asb

    vt = geometry.vertical_tail
    height_m = vt.tip_le_m[2] - vt.root_le_m[2]
    # The fin is analysed laid flat and mirrored about its root: the tail plane and boom act as an
    # end plate, doubling its effective aspect ratio.
    fin_flat = TailSurface(vt.airfoil, (vt.root_le_m[0], 0.0, 0.0), (vt.tip_le_m[0], height_m, 0.0),
                           vt.root_chord_m, vt.tip_chord_m, 0.0, vt.control_chord_fraction, vt.efficiency)
    slopes = {}
    for key, wing in (("wing_3d", _wing(geometry, lattice_incidence_deg=0.0)),  # a slope: any incidence
                      ("elevator_3d", _tail(geometry.horizontal_tail, "htail", True)),
                      ("rudder_3d", _tail(fin_flat, "fin", True))):
        plane = asb.Airplane(wings=[wing], s_ref=wing.area(), c_ref=wing.mean_aerodynamic_chord(),
                             b_ref=wing.span())
        op = asb.OperatingPoint(velocity=20.0, alpha=2.0)
        r = _vortex_lattice(plane, op, VLM_MESH).run_with_stability_derivatives(
            alpha=True, beta=False, p=False, q=False, r=False)
        slopes[key] = float(np.asarray(r["CLa"]).ravel()[0])
    return slopes


def horizontal_tail_volume(geometry: AircraftGeometry, cg_x_m: float) -> tuple[float, float]:
    """Tail arm l_t (m, CG to the tail's mean quarter chord) and tail volume S_t l_t / (S c)."""
    arm_m = float(_mac_quarter_chord(geometry.horizontal_tail)[0] - cg_x_m)
    area_m2 = 2.0 * _trapezoid_area_m2(geometry.horizontal_tail)
    return arm_m, area_m2 * arm_m / (geometry.reference_area_m2 * geometry.reference_chord_m)


def downwash_lag_derivatives(geometry: AircraftGeometry, cg_x_m: float, slopes: dict[str, float]) -> dict[str, float]:
    """CLα̇ and Cmα̇ (per unit α̇ c/2V) of the tail's downwash lag.

    The tail meets the downwash the wing shed l_t/V earlier, ε(t) = dε/dα · α(t − l_t/V), so its
    angle of attack gains dε/dα · α̇ · l_t/V. With the polar's downwash model, ε = 2 CL_w/(π AR),
    and the lattice's wing lift slope: CLα̇ = 2 a_t η V_H dε/dα and Cmα̇ = −2 a_t η V_H (l_t/c) dε/dα
    (Etkin & Reid §5.5; Nelson §3.5), a_t the tail's lift slope on its own area, V_H its volume.
    α̇ is the wing's rate against the air, gusts included (the XML writer adds the pitch gust).
    The lattice, being steady, has none of this.
    """
    arm_m, volume = horizontal_tail_volume(geometry, cg_x_m)
    downwash_slope = 2.0 * slopes["wing_3d"] / (np.pi * geometry.aspect_ratio)
    cl_adot = 2.0 * slopes["elevator_3d"] * geometry.horizontal_tail.efficiency * volume * downwash_slope
    return {"CLadot": cl_adot, "Cmadot": -cl_adot * arm_m / geometry.reference_chord_m,
            "downwash_slope": downwash_slope}


def _wing_chord_m(geometry: AircraftGeometry, y_m: np.ndarray) -> np.ndarray:
    """Local chord of the wing at span stations |y| (m)."""
    w = geometry.wing
    frac = np.clip((np.abs(y_m) - w.kink_y_m) / (w.span_m / 2.0 - w.kink_y_m), 0.0, 1.0)
    return w.root_chord_m + frac * (w.tip_chord_m - w.root_chord_m)


def yaw_damping_per_section_drag(geometry: AircraftGeometry) -> float:
    """Cnr per unit section drag coefficient: −4/(S b²) ∫ c y² dy over the span (−1/3 for a
    rectangular wing).

    In a yaw rate r the section at y meets the air at V − r y, so its drag changes by
    −2 (r y / V) q c c_d; its arm is y.
    """
    half_span = geometry.wing.span_m / 2.0
    y = np.linspace(-half_span, half_span, 401)
    moment_m4 = float(np.trapezoid(_wing_chord_m(geometry, y) * y**2, y))
    return -4.0 * moment_m4 / (geometry.reference_area_m2 * geometry.reference_span_m**2)


def profile_yaw_damping(geometry: AircraftGeometry, lift_coefficient: float) -> np.ndarray:
    """Cnr from the wing's profile drag, against the Reynolds breakpoints; the inviscid lattice has none.

    ``yaw_damping_per_section_drag`` times NeuralFoil's section drag at the lift coefficient
    ``lift_coefficient``, at the mean chord's Reynolds number.
    """
    import aerosandbox as asb

    mean_chord_m = geometry.reference_area_m2 / geometry.wing.span_m
    section_alpha_deg = np.linspace(-8.0, 8.0, 33)
    out = []
    for re in geometry.envelope.reynolds:
        r = asb.Airfoil(geometry.wing.airfoil).get_aero_from_neuralfoil(
            alpha=section_alpha_deg, Re=re * mean_chord_m / geometry.reference_chord_m,
            mach=_mach(re, geometry), model_size="large")
        cd = float(np.interp(lift_coefficient, np.asarray(r["CL"], float), np.asarray(r["CD"], float)))
        out.append(cd * yaw_damping_per_section_drag(geometry))
    return np.array(out)


def aileron_induced_yaw_factor(geometry: AircraftGeometry, cg_x_m: float, incidence_deg: float, alpha_deg: float,
                               twist_deg: float = 2.0, mesh: LatticeMesh = VLM_MESH) -> dict[str, float]:
    """Independent check of ``AILERON_INDUCED_YAW_FACTOR`` with the vortex lattice.

    The ailerons are modelled as antisymmetric twist (±``twist_deg``) over their span, which gives
    the same spanwise load change as a flap; the factor k in ΔCn_s = −k CL ΔCl_s/(π AR) is read
    from the stability-axis moments with and without it. Returns k and the lift coefficient.
    """
    import aerosandbox as asb

    ramp_m = 0.2  # twist blends in over this width: a sliver segment would make the lattice ill-conditioned
    a = geometry.aileron
    results = []
    for twist in (0.0, twist_deg):
        extra = ((a.inner_y_m, 0.0), (a.inner_y_m + ramp_m, twist), (a.outer_y_m - ramp_m, twist), (a.outer_y_m, 0.0))
        right = _wing(geometry, extra_twist=extra, name="right_wing", mirrored=False,
                      lattice_incidence_deg=incidence_deg)
        left = _wing(geometry, extra_twist=tuple((y, -t) for y, t in extra), name="left_wing", mirrored=True,
                     lattice_incidence_deg=incidence_deg)
        plane = asb.Airplane(xyz_ref=[0.0, 0.0, 0.0], wings=[w.translate([-cg_x_m, 0.0, -geometry.cg_z_m])
                                                             for w in (right, left)],
                             s_ref=geometry.reference_area_m2, c_ref=geometry.reference_chord_m,
                             b_ref=geometry.reference_span_m)
        results.append(_vortex_lattice(plane, _operating_point(geometry.envelope.lattice_reynolds, geometry, alpha_deg=alpha_deg),
                                       mesh).run())
    alpha = np.radians(alpha_deg)
    d_roll = float(results[1]["Cl"] - results[0]["Cl"])
    d_yaw = float(results[1]["Cn"] - results[0]["Cn"])
    d_roll_s = d_roll * np.cos(alpha) + d_yaw * np.sin(alpha)
    d_yaw_s = d_yaw * np.cos(alpha) - d_roll * np.sin(alpha)
    cl = float(results[0]["CL"])
    return {"factor": -d_yaw_s * np.pi * geometry.aspect_ratio / (cl * d_roll_s), "CL": cl}


def apparent_mass_per_density(geometry: AircraftGeometry, cg_x_m: float) -> dict[str, float]:
    """Strip-theory apparent mass of the lifting surfaces per unit air density (m³ and m⁵).

    A thin section of chord c moving normal to itself through still air carries ρ π c²/4 per unit
    span at its mid-chord, and turning about its mid-chord an apparent inertia ρ π c⁴/128. Summed
    over the wing: the apparent mass in heave and the apparent inertia in roll (about the x axis);
    over the wing and the horizontal tail: the apparent inertia in pitch about the CG, where the
    tail's share dominates through its arm. Strip theory ignores the tip relief of a finite
    surface, so these are upper bounds (a few per cent at the wing's aspect ratio 15.6).
    """
    half_span = geometry.wing.span_m / 2.0
    y = np.linspace(-half_span, half_span, 401)
    chord = _wing_chord_m(geometry, y)
    per_span = np.pi * chord**2 / 4.0
    # Unswept quarter-chord line at x = c_root/4, so the mid-chord lies at c_root/4 + c/4.
    mid_chord_x = geometry.wing.root_chord_m / 4.0 + chord / 4.0
    pitch = float(np.trapezoid(per_span * ((mid_chord_x - cg_x_m) ** 2 + chord**2 / 32.0), y))
    ht = geometry.horizontal_tail
    t = np.linspace(0.0, 1.0, 201)
    tail_chord = ht.root_chord_m + t * (ht.tip_chord_m - ht.root_chord_m)
    tail_le_x = ht.root_le_m[0] + t * (ht.tip_le_m[0] - ht.root_le_m[0])
    tail_span_m = 2.0 * (ht.tip_le_m[1] - ht.root_le_m[1])  # both halves
    tail_per_span = np.pi * tail_chord**2 / 4.0
    pitch += tail_span_m * float(np.trapezoid(
        tail_per_span * ((tail_le_x + tail_chord / 2.0 - cg_x_m) ** 2 + tail_chord**2 / 32.0), t))
    return {"heave_m3": float(np.trapezoid(per_span, y)), "roll_m5": float(np.trapezoid(per_span * y**2, y)),
            "pitch_m5": pitch}

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
  included), in its linear range; the tables hold their end values beyond it.
* Sideslip increments of lift, drag and pitching moment (even in β): ``AeroBuildup`` in sideslip.
* Control surfaces, which AeroSandbox's 3-D methods do not model: the section increments Δcl, Δcd,
  Δcm of the deflected airfoil come from NeuralFoil (``Airfoil.add_control_surface``), and are
  carried to the aircraft by strip theory with the 3-D lift-slope ratio ``k = CLα_3D / a0``
  (the textbook aileron / elevator / rudder estimates, Nelson §2.4, §5.3 and Etkin & Reid §5.7).
  Adverse yaw of the ailerons comes from the profile-drag asymmetry per side and from the induced
  drag of the lift increment, ``ΔCn = −ΔCl·CL/(π·AR)``.

Reynolds number is the flight-condition variable: at equivalent airspeeds of 8-12 m/s, Mach stays
below 0.15 while the Reynolds number on the mean chord falls from about 1.9e6 to 0.4e6 between sea
level and 20 km. Each Reynolds breakpoint is evaluated at the altitude where 10 m/s EAS gives it,
so the Mach number that goes with it is the one the aircraft meets there.
"""

from __future__ import annotations

import numpy as np

from .geometry import AircraftGeometry, TailSurface

RHO0_KG_M3 = 1.225  # sea-level density of the 1976 standard atmosphere
REFERENCE_EAS_MPS = 10.0  # the equivalent airspeed each Reynolds breakpoint is evaluated at

REYNOLDS = (3.0e5, 5.0e5, 7.5e5, 1.0e6, 1.5e6, 2.0e6)
ALPHA_DEG = (-90, -60, -45, -30, -20, -16, -12, -10, -8, -6, -4, -2, 0, 2, 4, 6, 8, 10, 12, 14, 16,
             18, 20, 25, 30, 45, 60, 90)
VLM_ALPHA_DEG = (-10, -6, -2, 0, 2, 4, 6, 8, 10, 12, 14)
BETA_DEG = (0, 4, 8, 12, 16, 20, 30)
DEFLECTION_DEG = (-30, -25, -20, -15, -10, -6, -3, 0, 3, 6, 10, 15, 20, 25, 30)


def flight_condition(reynolds: float, geometry: AircraftGeometry) -> tuple[float, float]:
    """Altitude (m) and true airspeed (m/s) at which the mean chord sees ``reynolds``.

    The altitude is the one where 10 m/s EAS gives that Reynolds number; outside 0-20 km the
    altitude is held at the end and the airspeed changed instead.
    """
    import aerosandbox as asb

    def reynolds_at(altitude_m: float, eas_mps: float) -> tuple[float, float]:
        atmo = asb.Atmosphere(altitude=altitude_m)
        tas_mps = eas_mps * np.sqrt(RHO0_KG_M3 / atmo.density())
        return float(atmo.density() * tas_mps * geometry.reference_chord_m / atmo.dynamic_viscosity()), tas_mps

    low, high = 0.0, 20000.0
    for end in (low, high):
        re_end, tas_end = reynolds_at(end, REFERENCE_EAS_MPS)
        if (end == low and reynolds >= re_end) or (end == high and reynolds <= re_end):
            return end, tas_end * reynolds / re_end
    for _ in range(60):  # bisection: Reynolds number falls monotonically with altitude at fixed EAS
        mid = 0.5 * (low + high)
        low, high = (mid, high) if reynolds_at(mid, REFERENCE_EAS_MPS)[0] > reynolds else (low, mid)
    altitude_m = 0.5 * (low + high)
    return altitude_m, reynolds_at(altitude_m, REFERENCE_EAS_MPS)[1]


def _operating_point(reynolds: float, geometry: AircraftGeometry, alpha_deg=0.0, beta_deg=0.0):
    import aerosandbox as asb

    altitude_m, tas_mps = flight_condition(reynolds, geometry)
    return asb.OperatingPoint(atmosphere=asb.Atmosphere(altitude=altitude_m), velocity=tas_mps,
                              alpha=alpha_deg, beta=beta_deg)


def _wing(geometry: AircraftGeometry):
    import aerosandbox as asb

    w = geometry.wing
    af = asb.Airfoil(w.airfoil)
    half_span = w.span_m / 2.0
    tip_x = (w.root_chord_m - w.tip_chord_m) / 4.0  # unswept quarter-chord line
    tip_z = (half_span - w.kink_y_m) * np.tan(np.radians(w.outer_dihedral_deg))
    a = geometry.aileron
    outer = half_span - w.kink_y_m

    def station(y_m: float, twist_extra_deg: float = 0.0):
        frac = (y_m - w.kink_y_m) / outer
        chord = w.root_chord_m + frac * (w.tip_chord_m - w.root_chord_m)
        return asb.WingXSec(xyz_le=[frac * tip_x, y_m, frac * tip_z], chord=chord, airfoil=af,
                            twist=w.incidence_deg + frac * w.tip_twist_deg + twist_extra_deg)

    xsecs = [asb.WingXSec(xyz_le=[0, 0, 0], chord=w.root_chord_m, airfoil=af, twist=w.incidence_deg),
             station(w.kink_y_m), station(a.inner_y_m), station(a.outer_y_m), station(half_span)]
    return asb.Wing(name="wing", symmetric=True, xsecs=xsecs)


def _tail(surface: TailSurface, name: str, symmetric: bool, incidence_offset_deg: float = 0.0):
    import aerosandbox as asb

    af = asb.Airfoil(surface.airfoil)
    twist = surface.incidence_deg + incidence_offset_deg
    return asb.Wing(name=name, symmetric=symmetric, xsecs=[
        asb.WingXSec(xyz_le=list(surface.root_le_m), chord=surface.root_chord_m, airfoil=af, twist=twist),
        asb.WingXSec(xyz_le=list(surface.tip_le_m), chord=surface.tip_chord_m, airfoil=af, twist=twist),
    ])


def airplane(geometry: AircraftGeometry, cg_x_m: float, parts=("wing", "htail", "vtail", "fuselage")):
    """The AeroSandbox model of the aircraft (or of some of its parts), moments about the CG."""
    import aerosandbox as asb

    wings = []
    if "wing" in parts:
        wings.append(_wing(geometry))
    if "htail" in parts:
        wings.append(_tail(geometry.horizontal_tail, "htail", symmetric=True))
    if "vtail" in parts:
        wings.append(_tail(geometry.vertical_tail, "vtail", symmetric=False))
    fuselages = []
    if "fuselage" in parts:
        fuselages.append(asb.Fuselage(name="pod_and_boom", xsecs=[
            asb.FuselageXSec(xyz_c=[x, 0, 0], radius=r) for x, r in geometry.fuselage_stations_m]))
    return asb.Airplane(name="solar_uav", xyz_ref=[cg_x_m, 0.0, geometry.cg_z_m], wings=wings,
                        fuselages=fuselages, s_ref=geometry.reference_area_m2,
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
    out = {k: np.zeros((alpha.size, len(REYNOLDS))) for k in ("CL", "CD", "Cm")}
    for j, re in enumerate(REYNOLDS):
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


def vlm_derivatives(geometry: AircraftGeometry, cg_x_m: float) -> dict[str, np.ndarray]:
    """Stability derivatives (per rad, rates non-dimensional) against α from the vortex lattice."""
    import aerosandbox as asb

    plane = airplane(geometry, cg_x_m, parts=("wing", "htail", "vtail"))
    out: dict[str, list[float]] = {k: [] for k in VLM_DERIVATIVES + ("CLa", "Cma")}
    for a in VLM_ALPHA_DEG:
        vlm = asb.VortexLatticeMethod(plane, _operating_point(1.0e6, geometry, alpha_deg=a),
                                      spanwise_resolution=8, chordwise_resolution=6)
        r = vlm.run_with_stability_derivatives()
        for k, values in out.items():
            values.append(float(np.asarray(r[k]).ravel()[0]))
    return {k: np.array(v) for k, v in out.items()}


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


def control_increments(geometry: AircraftGeometry, cg_x_m: float, lift_slopes: dict[str, float]) -> dict[str, np.ndarray]:
    """Per-surface coefficient increments on the (deflection, Re) grid, by strip theory.

    Returned keys: ``<coef>_<surface>`` with surface in ``aileron`` (the right aileron, trailing
    edge down positive; the left one is its mirror image), ``elevator`` (one half of the elevator,
    trailing edge down positive) and ``rudder`` (trailing edge left positive). ``Cn_aileron_induced``
    is the adverse-yaw increment per unit aircraft lift coefficient.
    """
    w, a = geometry.wing, geometry.aileron
    S, b, c = geometry.reference_area_m2, geometry.reference_span_m, geometry.reference_chord_m
    half_span = w.span_m / 2.0
    # Aileron strip integrals over the tapered outer panel.
    y = np.linspace(a.inner_y_m, a.outer_y_m, 201)
    chord = w.root_chord_m + (y - w.kink_y_m) / (half_span - w.kink_y_m) * (w.tip_chord_m - w.root_chord_m)
    int_c, int_cy, int_c2 = (np.trapezoid(chord, y), np.trapezoid(chord * y, y), np.trapezoid(chord**2, y))
    dihedral = np.radians(w.outer_dihedral_deg)
    x_quarter_chord_m = w.root_chord_m / 4.0  # straight quarter-chord line

    ht, vt = geometry.horizontal_tail, geometry.vertical_tail
    s_half_m2, s_fin_m2 = _trapezoid_area_m2(ht), _trapezoid_area_m2(vt)
    ht_ac, vt_ac = _mac_quarter_chord(ht), _mac_quarter_chord(vt)
    ht_mac, vt_mac = _mac_m(ht), _mac_m(vt)

    keys = [f"{k}_aileron" for k in ("CL", "CD", "CY", "Cl", "Cm", "Cn", "Cn_aileron_induced")]
    keys += [f"{k}_elevator" for k in ("CL", "CD", "Cm")] + [f"{k}_rudder" for k in ("CY", "CD", "Cl", "Cm", "Cn")]
    out = {k.replace("_aileron_induced_aileron", "_aileron_induced"): np.zeros((len(DEFLECTION_DEG), len(REYNOLDS)))
           for k in keys}
    for j, re in enumerate(REYNOLDS):
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
        out["Cn_aileron_induced"][:, j] = -cl_roll / (np.pi * geometry.aspect_ratio)
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
    for key, wing in (("wing_3d", _wing(geometry)),
                      ("elevator_3d", _tail(geometry.horizontal_tail, "htail", True)),
                      ("rudder_3d", _tail(fin_flat, "fin", True))):
        plane = asb.Airplane(wings=[wing], s_ref=wing.area(), c_ref=wing.mean_aerodynamic_chord(),
                             b_ref=wing.span())
        op = asb.OperatingPoint(velocity=20.0, alpha=2.0)
        r = asb.VortexLatticeMethod(plane, op, spanwise_resolution=8, chordwise_resolution=6
                                    ).run_with_stability_derivatives(alpha=True, beta=False, p=False, q=False, r=False)
        slopes[key] = float(np.asarray(r["CLa"]).ravel()[0])
    return slopes

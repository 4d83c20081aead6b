"""The aerodynamic model as physics statements, measured through JSBSim (jsbsim_env.analysis.derivatives).

Hand estimates use textbook formulas with Helmbold's lift slope, not the vortex lattice the model
comes from, so that they are an independent check.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from aircraft.design import aero_data
from aircraft.design.analysis import _mac_quarter_chord, _trapezoid_area_m2, yaw_damping_per_section_drag
from aircraft.design.geometry import AircraftGeometry
from jsbsim_env.analysis import derivatives
from jsbsim_env.analysis.modes import LONGITUDINAL_STATES, linearise
from jsbsim_env.sim.simulation import Simulation

GEOMETRY = AircraftGeometry()
DATA = aero_data.load()
CG_X_M = DATA["stability"]["cg_x_m"]


def helmbold_lift_slope_per_rad(aspect_ratio: float) -> float:
    """Lift slope of a straight wing with 2-D slope 2 pi (Helmbold)."""
    return 2.0 * math.pi * aspect_ratio / (2.0 + math.sqrt(aspect_ratio**2 + 4.0))


@pytest.fixture(scope="module")
def cruise():
    """Derivatives measured through JSBSim at 1 km, EAS 10 m/s, and the trim."""
    sim = Simulation()
    measured = derivatives.measure(sim, 1000.0, 10.0)
    return sim, measured, sim.trim(1000.0, 10.0)


def _tail_volume():
    ht = GEOMETRY.horizontal_tail
    area_m2 = 2.0 * _trapezoid_area_m2(ht)
    span_m = 2.0 * ht.tip_le_m[1]
    arm_m = _mac_quarter_chord(ht)[0] - CG_X_M
    c, s = GEOMETRY.reference_chord_m, GEOMETRY.reference_area_m2
    return helmbold_lift_slope_per_rad(span_m**2 / area_m2), arm_m, area_m2 * arm_m / (s * c)


def test_pitch_rate_derivatives_are_about_the_cg_and_match_the_tail_volume_estimate(cruise):
    _, d, _ = cruise
    a_t, arm_m, volume = _tail_volume()
    eta = GEOMETRY.horizontal_tail.efficiency
    c = GEOMETRY.reference_chord_m
    a_w = helmbold_lift_slope_per_rad(GEOMETRY.aspect_ratio)
    x_ac_m = GEOMETRY.wing.root_chord_m / 4.0  # unswept quarter-chord line
    # Thin-airfoil theory: a pitch rate about x_cg adds the angle of attack of the 3/4-chord point,
    # and a moment about the quarter chord of -pi/4 per unit q c/2V (the equivalent parabolic camber).
    cl_q_wing = a_w * (1.0 + 2.0 * (x_ac_m - CG_X_M) / c)
    cm_q_wing = -math.pi / 4.0 * a_w / (2.0 * math.pi) + cl_q_wing * (CG_X_M - x_ac_m) / c
    cl_q_tail = 2.0 * a_t * eta * volume
    cl_q, cm_q = cl_q_wing + cl_q_tail, cm_q_wing - cl_q_tail * arm_m / c
    # The estimate leaves out the downwash change the pitching wing sends to the tail and the
    # spanwise load shapes; for this unswept high-aspect-ratio layout that is a few per cent.
    # Rates turned about the wing-root leading edge would add CL_alpha * 2 x_cg / c (about 4.3) to
    # CLq, far outside the tolerance.
    assert d["CLq"] == pytest.approx(cl_q, rel=0.08)
    assert d["Cmq"] == pytest.approx(cm_q, rel=0.08)
    # The acceptance figures of the corrected model.
    assert d["CLq"] == pytest.approx(8.55, rel=0.15)
    assert -17.0 < d["Cmq"] < -12.0


def test_alpha_dot_derivatives_are_the_downwash_lag_of_the_tail(cruise):
    _, d, _ = cruise
    a_t, arm_m, volume = _tail_volume()
    eta = GEOMETRY.horizontal_tail.efficiency
    downwash_slope = 2.0 * helmbold_lift_slope_per_rad(GEOMETRY.aspect_ratio) / (math.pi * GEOMETRY.aspect_ratio)
    cl_adot = 2.0 * a_t * eta * volume * downwash_slope
    # Helmbold against the lattice's slopes: within 5 %.
    assert d["CLadot"] == pytest.approx(cl_adot, rel=0.05)
    assert d["Cmadot"] == pytest.approx(-cl_adot * arm_m / GEOMETRY.reference_chord_m, rel=0.05)


def _short_period_matrix(sim: Simulation, with_alpha_dot: bool) -> np.ndarray:
    for term in ("CLadot", "Cmadot"):
        sim[f"aero/scale/{term}"] = 1.0 if with_alpha_dot else 0.0
    trim = sim.trim(10000.0, 10.0)
    return linearise(sim, trim)[0], trim


def test_alpha_dot_terms_damp_the_short_period_as_the_textbook_derivatives_predict():
    """With M_adot and Z_adot, alpha-dot = (row of alpha)/(1 - Z_adot/V) and q-dot gains M_adot alpha-dot
    (Etkin & Reid §4.9): predicted from the matrix without them, compared with JSBSim's linearisation."""
    sim = Simulation()
    a0, trim = _short_period_matrix(sim, with_alpha_dot=False)
    a1, _ = _short_period_matrix(sim, with_alpha_dot=True)
    v = trim.airspeed_tas_mps
    qbar_s = 0.5 * 1.225 * trim.airspeed_eas_mps**2 * GEOMETRY.reference_area_m2
    c = GEOMETRY.reference_chord_m
    iyy = GEOMETRY.inertia_kg_m2[1]
    lag = DATA["downwash_lag"]
    z_adot = -lag["CLadot"] * qbar_s * c / (2.0 * v) / (GEOMETRY.mass_kg * v)  # (1/s) per (rad/s), alpha row
    m_adot = lag["Cmadot"] * qbar_s * c * c / (2.0 * v) / iyy  # 1/s
    i_alpha, i_q = LONGITUDINAL_STATES.index("alpha"), LONGITUDINAL_STATES.index("q")
    predicted = a0.copy()
    predicted[i_alpha] = a0[i_alpha] / (1.0 - z_adot)
    predicted[i_q] = a0[i_q] + m_adot * predicted[i_alpha]
    short = [sorted(np.linalg.eigvals(a), key=lambda e: -abs(e))[:2] for a in (a0, a1, predicted)]
    damping = [-sum(e.real for e in pair) for pair in short]  # 2 zeta omega of the short period
    # M_adot is about a fifth of M_q + M_adot, but the light wing loading makes Z_alpha the larger
    # part of 2 zeta omega here: the lag adds about 4 % to it at 10 km and takes zeta from 0.94 to 1.
    assert damping[1] > damping[0] * 1.03
    assert damping[1] == pytest.approx(damping[2], rel=0.01)


def test_aileron_moments_are_rotated_from_stability_to_body_axes():
    """Strip theory gives the ailerons' rolling and yawing moments in stability axes (lift across,
    drag along the airflow); in body axes Cn_b = Cn_s cos a + Cl_s sin a, Cl_b = Cl_s cos a - Cn_s sin a."""
    sim = Simulation()
    for alpha_deg in (-6.0, 0.0, 8.0):
        sim.place_with_controls(1000.0, 10.5, alpha_deg, 5.0, 0.0, 0.0, 0.15)
        qsb = sim["aero/qbar-psf"] * sim["metrics/Sw-sqft"] * sim["metrics/bw-ft"]
        cl_s, cn_s = sim["aero/function/aileron-Cl-stability"], sim["aero/function/aileron-Cn-stability"]
        a = math.radians(alpha_deg)
        assert abs(cn_s) > 1e-4 and abs(cl_s) > 1e-3
        assert sim["aero/coefficient/Clda"] / qsb == pytest.approx(cl_s * math.cos(a) - cn_s * math.sin(a), rel=1e-9)
        assert sim["aero/coefficient/Cnda"] / qsb == pytest.approx(cn_s * math.cos(a) + cl_s * math.sin(a), rel=1e-9)


def test_aileron_adverse_yaw_has_the_lifting_line_size(cruise):
    sim, d, trim = cruise
    # Body axes: about -0.0625 at the cruise trim (alpha -1 deg), and well above the -0.017 a
    # stability-axis table with a third of the induced yaw gave.
    ratio = d["Cnda"] / d["Clda"]
    assert -0.0625 * 4 / 3 < ratio < -0.0625 * 2 / 3
    assert abs(ratio) >= 0.042
    # In stability axes the induced part is -3 CL/(pi AR) per unit rolling moment; the profile-drag
    # asymmetry adds a little on top.
    stability = derivatives.to_stability_axes(d, math.radians(trim.alpha_deg))
    lift = sim["forces/fwz-aero-lbs"] / (sim["aero/qbar-psf"] * sim["metrics/Sw-sqft"])
    induced = -3.0 * lift / (math.pi * GEOMETRY.aspect_ratio)
    assert stability["Cnda"] / stability["Clda"] == pytest.approx(induced, abs=0.01)
    # The lattice's own factor, stored by the build, is the lifting-line one within 15 %.
    assert DATA["checks"]["aileron_induced_yaw"]["factor"] == pytest.approx(3.0, rel=0.15)
    # Flown: a held 5 deg aileron step yaws the nose against the roll at more than 0.95 deg/s.
    step = derivatives.aileron_step_adverse_yaw(sim, 1000.0, 10.0)
    assert step["adverse_yaw_rate_degps"] >= 0.95


def test_the_lattice_mesh_is_converged():
    """At the chosen mesh each derivative is within 3 % of its value at twice the resolution, and
    Cma's neutral point within 0.5 % of the mean chord (the slow test
    test_aero_data_regenerates_from_the_geometry recomputes the table)."""
    from aircraft.design import analysis

    table = DATA["checks"]["mesh_convergence"]
    assert {"Clr", "Cnp", "CLq", "Cmq", "Cnr", "CYb", "Clb", "Cnb", "Clp", "Cma"} <= set(table)
    assert analysis.convergence_failures(table) == []
    assert analysis.neutral_point_shift_mac(table) == pytest.approx(0.0030, abs=0.0005)


def _table(changes: dict[str, float]) -> dict:
    """A convergence table whose derivatives change by ``changes`` (relative) on the doubled mesh."""
    rows = {"CLa": (5.0, 5.0), "Cma": (-0.5, -0.5), "Cmq": (-13.0, -13.0)}
    out = {}
    for name, (mesh, doubled) in rows.items():
        mesh = doubled * (1.0 + changes.get(name, 0.0))
        out[name] = {"mesh": mesh, "doubled": doubled, "relative_change": abs(mesh - doubled) / abs(doubled)}
    return out


def test_the_lattice_is_refined_until_it_converges_or_the_build_says_what_did_not(monkeypatch):
    from aircraft.design import analysis

    # Cma judged by its neutral point: 5 % of -0.5 over CLa 5 moves it 0.5 % of the chord (the limit).
    assert analysis.convergence_failures(_table({"Cma": 0.04})) == []
    assert analysis.convergence_failures(_table({"Cma": 0.06, "Cmq": 0.05})) == [
        "Cma moves the neutral point 0.60 % of the mean chord (limit 0.5 %)", "Cmq changes 5.00 % (limit 3 %)"]
    seen = []
    monkeypatch.setattr(analysis, "lattice_wing_incidence_deg", lambda *args: 1.0)

    def study(geometry, cg_x_m, incidence_deg, alpha_deg, mesh):
        seen.append(mesh)
        return tables[mesh]

    monkeypatch.setattr(analysis, "mesh_convergence", study)
    first, second = analysis.MESH_REFINEMENTS
    tables = {first: _table({"Cmq": 0.05}), second: _table({"Cmq": 0.01})}
    mesh, _, table = analysis.converged_mesh(GEOMETRY, 0.5, 2.0, 0.8, log=seen.append)
    assert mesh == second and table is tables[second]
    assert seen[0] == first and "Cmq changes 5.00 %" in seen[1] and seen[2] == second  # the log says why
    tables[second] = _table({"Cmq": 0.04})
    with pytest.raises(analysis.MeshNotConverged, match=r"did not converge at 12 x 9 panels against 24 x 18: Cmq "
                                                        r"changes 4.00 % \(limit 3 %\)\. Its usual causes"):
        analysis.converged_mesh(GEOMETRY, 0.5, 2.0, 0.8)


def test_profile_drag_yaw_damping_of_a_rectangular_wing_is_a_third_of_the_section_drag():
    from dataclasses import replace

    wing = GEOMETRY.wing
    # With the root chord at S/b the outer panels' tip chord equals it: a rectangle.
    rectangular = replace(GEOMETRY, wing=replace(wing, root_chord_m=wing.area_m2 / wing.span_m))
    assert rectangular.wing.tip_chord_m == pytest.approx(rectangular.wing.root_chord_m)
    assert yaw_damping_per_section_drag(rectangular) == pytest.approx(-1.0 / 3.0, rel=1e-4)
    # The tapered outer panels carry less chord where the arm is longest.
    assert -1.0 / 3.0 < yaw_damping_per_section_drag(GEOMETRY) < -0.25
    # In the model: about -c_d/3 with a section drag coefficient of 0.005-0.012.
    assert all(-0.004 < v < -0.0015 for v in DATA["profile"]["Cnr"])


def test_apparent_mass_option_adds_the_airs_inertia_to_roll():
    """With aero/apparent-mass-active the roll acceleration an aileron gives falls by Ixx/(Ixx + I_a),
    I_a = rho * integral of pi c^2/4 y^2 dy: about Ixx itself at sea level (mass ratio 3.3), 7 % at 20 km."""
    per_density = DATA["apparent_mass_per_density"]["roll_m5"]
    c = GEOMETRY.reference_area_m2 / GEOMETRY.reference_span_m
    rectangular = math.pi * c**2 / 4.0 * GEOMETRY.reference_span_m**3 / 12.0
    assert 0.75 * rectangular < per_density < rectangular  # tapered tips carry less air
    ixx = GEOMETRY.inertia_kg_m2[0]
    for altitude_m, rho in ((0.0, 1.225), (20000.0, 0.088)):
        increments = []
        for active in (0.0, 1.0):
            pdot = []
            for aileron_deg in (0.0, 10.0):
                sim = Simulation()
                sim["aero/apparent-mass-active"] = active
                sim.place_with_controls(altitude_m, 10.0 * math.sqrt(1.225 / rho), 2.0, aileron_deg, 0.0, 0.0, 0.5)
                pdot.append(sim["accelerations/pdot-rad_sec2"])
            increments.append(pdot[1] - pdot[0])
        rho_model = sim["atmosphere/rho-slugs_ft3"] * 515.378818
        assert increments[1] / increments[0] == pytest.approx(ixx / (ixx + rho_model * per_density), rel=1e-3)
    assert 1.225 * per_density / ixx == pytest.approx(1.0, abs=0.1)


def test_moments_are_taken_about_the_cg_the_mass_model_puts_the_aircraft_at():
    sim = Simulation()
    reference = [sim[f"metrics/aero-rp-{a}-in"] for a in "xyz"]
    cg = [sim[f"inertia/cg-{a}-in"] for a in "xyz"]
    assert reference == pytest.approx(cg, abs=1e-6)
    assert cg[0] * 0.0254 == pytest.approx(CG_X_M, abs=1e-6)


def test_downwash_lag_follows_the_wings_angle_against_the_air():
    """A vertical gust changes the wing's angle of attack against the air like body motion does:
    alpha_air = alpha - w_g/V, so its rate is alpha-dot + q_g (the turbulence writes
    q_g = -(1/V) dw_g/dt). The downwash the tail meets lags that rate, gust included."""
    sim = Simulation()
    sim.set_initial_conditions(1000.0, 10.5, alpha_deg=1.0)
    qsc = sim["aero/qbar-psf"] * sim["metrics/Sw-sqft"] * sim["metrics/cbarw-ft"]
    c_over_2v = sim["aero/ci2vel"]
    for gust_q in (0.0, 0.02, -0.05):
        sim["atmosphere/gust-q-rad_sec"] = gust_q
        sim.fdm.run_ic()
        rate = sim["aero/alphadot-rad_sec"] + gust_q
        expected = DATA["downwash_lag"]["Cmadot"] * rate * c_over_2v
        assert sim["aero/coefficient/Cmadot"] / qsc == pytest.approx(expected, rel=1e-5)  # the XML's 6 digits

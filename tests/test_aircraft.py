"""The solar UAV as a JSBSim model: files, loading, actuators, scales, atmosphere."""

from __future__ import annotations

import math
import shutil
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import aircraft
from aircraft.design import aero_data, xml_writer
from aircraft.design.geometry import AircraftGeometry
from jsbsim_env.analysis.runscripts import RUNS
from jsbsim_env.sim.model_check import COEFFICIENT_TERMS
from jsbsim_env.sim.simulation import FT_TO_M, LBF_TO_N, SLUG_FT2_TO_KG_M2, ModelError, Simulation


@pytest.fixture(scope="module")
def sim() -> Simulation:
    return Simulation()


def test_committed_xml_is_what_the_generator_writes():
    files = xml_writer.aircraft_files(AircraftGeometry(), aero_data.load())
    on_disk = {p.relative_to(aircraft.aircraft_dir()).as_posix()
               for p in aircraft.aircraft_dir().rglob("*.xml")}
    # The trimmed cruise initial conditions come from the trim (tests/test_runscripts.py checks them).
    trimmed = {f"{run.initial_conditions}.xml" for run in RUNS}
    assert on_disk == {rel for rel in files if rel.endswith(".xml")} | trimmed
    assert aircraft.ENVELOPE_FILE in files  # written beside them, compared below
    for rel, text in files.items():
        assert (aircraft.aircraft_dir() / rel).read_text() == text, f"{rel} differs from the generator's output"


def test_every_reset_file_runs():
    names = aircraft.reset_files()
    assert len(names) >= 3
    for name in names:
        s = Simulation()
        assert s.fdm.load_ic(name, True)
        assert s.fdm.run_ic()
        for _ in range(60):
            assert s.fdm.run()
        assert math.isfinite(s["position/h-sl-ft"]) and s["position/h-sl-ft"] > 0


def test_mass_and_inertia_match_table_1(sim):
    sim.set_initial_conditions(1000.0, 10.5)
    assert sim["inertia/mass-slugs"] * 14.5939 == pytest.approx(359.0, rel=1e-6)
    # JSBSim reads KG*M2 with its factor 1/1.35594 (exactly 1/1.3558179): 9e-5 low when read back.
    assert sim.inertia_kg_m2() == pytest.approx((15221.0, 1827.5, 16967.0, 37.0), rel=2e-4)


def test_ixz_is_the_product_of_inertia_of_the_mass_model(sim):
    """The file's <ixz> is the product of inertia (integral of x z dm) and JSBSim reads it as such."""
    mass_balance = ET.parse(aircraft.aircraft_dir() / "MassBalance.xml").getroot()
    assert mass_balance.get("negated_crossproduct_inertia") == "false"
    ixz_file = float(mass_balance.find("ixz").text)
    ixz_model = AircraftGeometry().inertia_kg_m2[3]
    assert ixz_file == ixz_model > 0.0
    assert sim.inertia_kg_m2().ixz_kg_m2 == pytest.approx(ixz_model, rel=2e-4)
    # JSBSim's own read-backs give the tensor element, -Ixz.
    j = np.asarray(sim.fdm.get_mass_balance().get_J()) * SLUG_FT2_TO_KG_M2
    assert j[0, 2] == j[2, 0] == pytest.approx(-ixz_model, rel=2e-4)
    assert sim["inertia/ixz-slugs_ft2"] * SLUG_FT2_TO_KG_M2 == pytest.approx(-ixz_model, rel=2e-4)


def test_a_pure_rolling_moment_yaws_the_way_ixz_says():
    """At zero rates Ixx pdot - Ixz rdot = L and Izz rdot - Ixz pdot = N: with N = 0, rdot = (Ixz/Izz) pdot."""
    s = Simulation()
    for term in COEFFICIENT_TERMS:  # only the ailerons' rolling moment acts
        s[f"aero/scale/{term}"] = 1.0 if term == "Clda" else 0.0
    s.set_initial_conditions(1000.0, 10.5)
    s.set_controls(10.0, 0.0, 0.0, 0.0)
    s.settle_actuators()
    s.set_initial_conditions(1000.0, 10.5)
    to_nm = LBF_TO_N * FT_TO_M
    roll_nm, yaw_nm = s["moments/l-total-lbsft"] * to_nm, s["moments/n-total-lbsft"] * to_nm
    pdot, rdot = s["accelerations/pdot-rad_sec2"], s["accelerations/rdot-rad_sec2"]
    ixx, _, izz, ixz = s.inertia_kg_m2()
    assert abs(roll_nm) > 1000.0 and abs(yaw_nm) < 1e-9 * abs(roll_nm)
    assert ixx * pdot - ixz * rdot == pytest.approx(roll_nm, rel=1e-9)
    assert izz * rdot - ixz * pdot == pytest.approx(yaw_nm, abs=1e-9 * abs(roll_nm))
    # Ixz > 0: the yaw acceleration has the sign of the roll acceleration (read as -Ixz it would not).
    assert rdot * pdot > 0.0 and rdot / pdot == pytest.approx(ixz / izz, rel=1e-6)


def _step_response(sim: Simulation, prop_in: str, value: float, prop_out: str, seconds: float) -> np.ndarray:
    sim.set_initial_conditions(1000.0, 10.5)
    sim.set_controls(0.0, 0.0, 0.0, 0.2)
    sim.settle_actuators()
    sim[prop_in] = value
    out = []
    for _ in range(round(seconds / sim.dt_s)):
        sim.fdm.run()
        out.append(sim[prop_out])
    return np.array(out)


def test_surface_step_follows_first_order_lag(sim):
    # 1 deg step: far below the rate limit (100 deg/s x 0.02 s = 2 deg), so a pure lag.
    y = _step_response(sim, "fcs/elevator-cmd-norm", 1.0 / 30.0, "fcs/elevator-pos-deg", 0.2)
    # JSBSim's lag is the Tustin (bilinear) discretisation of 1/(T s + 1), T = 0.02 s.
    a_dt = sim.dt_s / 0.02
    ca, cb = a_dt / (2 + a_dt), (2 - a_dt) / (2 + a_dt)
    expected, prev_in, prev_out = [], 0.0, 0.0
    for _ in y:
        prev_out = ca * (1.0 + prev_in) + cb * prev_out
        prev_in = 1.0
        expected.append(prev_out)
    assert np.max(np.abs(y - np.array(expected))) < 1e-9
    # Its 63.2 % point lies within one step after the continuous lag's time constant (the bilinear
    # step response trails the continuous one by about half a step).
    t = np.arange(1, y.size + 1) * sim.dt_s
    t_63 = np.interp(1 - math.exp(-1), y, t)
    assert 0.02 <= t_63 <= 0.02 + sim.dt_s


def test_surface_large_step_is_rate_limited(sim):
    y = _step_response(sim, "fcs/elevator-cmd-norm", 20.0 / 30.0, "fcs/elevator-pos-deg", 0.5)
    rates = np.diff(y) / sim.dt_s
    assert np.max(rates) == pytest.approx(100.0, rel=1e-6)
    # 20 deg at 100 deg/s takes 0.2 s, plus the lag's tail.
    t_90 = (np.argmax(y >= 18.0) + 1) * sim.dt_s
    assert 0.17 <= t_90 <= 0.25


def test_surface_rate_limit_is_settable_at_run_time(sim):
    sim["fcs/surface-rate-limit-deg_s"] = 25.0
    try:
        y = _step_response(sim, "fcs/elevator-cmd-norm", 20.0 / 30.0, "fcs/elevator-pos-deg", 0.5)
        assert np.max(np.diff(y) / sim.dt_s) == pytest.approx(25.0, rel=1e-6)
    finally:
        sim["fcs/surface-rate-limit-deg_s"] = 100.0


def test_backlash_holds_small_reversals(sim):
    sim["fcs/backlash-width-deg"] = 0.3
    try:
        y = _step_response(sim, "fcs/elevator-cmd-norm", 2.0 / 30.0, "fcs/elevator-pos-deg", 0.5)
        assert y[-1] == pytest.approx(2.0 - 0.15, abs=1e-3)  # takes up half the play
        held = y[-1]
        sim["fcs/elevator-cmd-norm"] = (2.0 - 0.2) / 30.0  # reversal smaller than the play
        for _ in range(60):
            sim.fdm.run()
        assert sim["fcs/elevator-pos-deg"] == pytest.approx(held, abs=1e-9)
        sim["fcs/elevator-cmd-norm"] = (2.0 - 1.0) / 30.0  # larger reversal: moves by the excess
        for _ in range(120):
            sim.fdm.run()
        assert sim["fcs/elevator-pos-deg"] == pytest.approx(1.0 + 0.15, abs=1e-3)
    finally:
        sim["fcs/backlash-width-deg"] = 0.0


def test_rotor_speed_follows_lag_and_rate_limit(sim):
    sim.set_initial_conditions(20000.0, 37.1)
    sim.set_controls(0.0, 0.0, 0.0, 0.5)
    sim.settle_actuators()
    full_rpm = sim["fcs/rotor-speed-full-rpm"]
    sim["fcs/throttle-cmd-norm[0]"] = 0.7  # +0.2 of the full-throttle speed, about 270 rpm
    ref, rpm = [], []
    for _ in range(int(2.0 / sim.dt_s)):
        sim.fdm.run()
        ref.append(sim["fcs/rotor-speed-ref-rpm"])
        rpm.append(sim["propulsion/engine[0]/propeller-rpm"])
    ref, rpm = np.array(ref), np.array(rpm)
    assert np.max(np.diff(ref)) / sim.dt_s == pytest.approx(480.0, rel=1e-6)
    assert ref[-1] == pytest.approx(0.7 * full_rpm, abs=0.5)
    # The motor's speed loop keeps the rotor within a few per cent of the reference.
    assert np.max(np.abs(rpm[30:] - ref[30:])) < 0.05 * full_rpm


@pytest.mark.parametrize("term", ["CL0", "CDalpha", "CYbeta", "Clp", "Cmde", "Cnr", "Clda", "CYdr"])
def test_scale_property_scales_its_term(term):
    s = Simulation()
    s.set_initial_conditions(5000.0, 15.0, alpha_deg=4.0, beta_deg=3.0, rates_radps=(0.05, 0.03, 0.04))
    s.set_controls(5.0, -4.0, 3.0, 0.3)
    s.settle_actuators()
    s.set_initial_conditions(5000.0, 15.0, alpha_deg=4.0, beta_deg=3.0, rates_radps=(0.05, 0.03, 0.04))
    base = s[f"aero/coefficient/{term}"]
    assert abs(base) > 1e-6
    s[f"aero/scale/{term}"] = 1.2
    s.fdm.run_ic()
    assert s[f"aero/coefficient/{term}"] == pytest.approx(1.2 * base, rel=1e-9)
    s.fdm.reset_to_initial_conditions(0)
    assert s[f"aero/scale/{term}"] == 1.2  # persists across resets


def test_inertia_scale_slows_roll_response():
    """The roll acceleration an aileron deflection adds falls as 1/scale."""
    increments = []
    for scale in (1.0, 1.15):
        pdot = []
        for aileron_deg in (0.0, 10.0):
            s = Simulation()
            s["aero/scale/I"] = scale
            s.set_initial_conditions(1000.0, 10.5)
            s.set_controls(aileron_deg, 0.0, 0.0, 0.41)  # about the trim: the rotors turn as a matched set
            s.settle_actuators()
            s.set_initial_conditions(1000.0, 10.5)
            pdot.append(s["accelerations/pdot-rad_sec2"])
        increments.append(pdot[1] - pdot[0])
    assert abs(increments[0]) > 1e-3
    assert increments[1] == pytest.approx(increments[0] / 1.15, rel=1e-6)


# US Standard Atmosphere 1976: geopotential altitude (m) -> density (kg/m³).
ATMOSPHERE_1976 = {0.0: 1.2250, 5000.0: 0.73612, 11000.0: 0.36392, 20000.0: 0.088035}


@pytest.mark.parametrize("altitude_m, rho_kg_m3", ATMOSPHERE_1976.items())
def test_atmosphere_matches_1976_table(sim, altitude_m, rho_kg_m3):
    sim.set_initial_conditions(altitude_m, 20.0)
    # JSBSim's altitude is geometric; the table's is geopotential (differs by 0.3 % at 20 km).
    r_earth_m = 6356766.0
    geometric_m = r_earth_m * altitude_m / (r_earth_m - altitude_m)
    sim.set_initial_conditions(geometric_m, 20.0)
    assert sim.fdm["atmosphere/rho-slugs_ft3"] * 515.378818 == pytest.approx(rho_kg_m3, rel=2e-3)
    v_tas = sim["velocities/vt-fps"] * FT_TO_M
    assert sim.airspeed_eas_mps() == pytest.approx(math.sqrt(rho_kg_m3 / 1.225) * v_tas, rel=2e-3)


def test_malformed_aircraft_file_gives_clear_error(tmp_path):
    root = tmp_path / "root"
    shutil.copytree(aircraft.aircraft_dir(), root / "aircraft" / "solar_uav")
    aero = root / "aircraft" / "solar_uav" / "Aerodynamics.xml"
    aero.write_text(aero.read_text()[: len(aero.read_text()) // 2])  # truncated mid-element
    with pytest.raises(ModelError, match="solar_uav"):
        Simulation(root)


def _assert_nested_close(a, b, path="data"):
    if isinstance(a, dict):
        assert set(a) == set(b), f"{path}: keys differ"
        for k in a:
            _assert_nested_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)) and a and isinstance(a[0], (dict, list, tuple, str)):
        assert len(a) == len(b), f"{path}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b)):
            _assert_nested_close(x, y, f"{path}[{i}]")
    elif isinstance(a, str):
        assert a == b, path
    else:
        np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=1e-6, atol=1e-9, err_msg=path)


@pytest.mark.slow
def test_aero_data_regenerates_from_the_geometry():
    """The committed aero_data.json is what the analyses compute from the geometry (about 20 s)."""
    pytest.importorskip("aerosandbox")
    _assert_nested_close(aero_data.compute_aero_data(AircraftGeometry()), aero_data.load())


def test_model_fingerprint_follows_the_model_not_the_initial_conditions(tmp_path):
    folder = tmp_path / "solar_uav"
    shutil.copytree(aircraft.aircraft_dir(), folder)
    assert aircraft.model_fingerprint(folder=folder) == aircraft.model_fingerprint()
    reset = folder / "reset00.xml"
    reset.write_text(reset.read_text().replace("<psi unit=\"DEG\"> 0 </psi>", "<psi unit=\"DEG\"> 90 </psi>"))
    assert "90 </psi>" in reset.read_text()
    assert aircraft.model_fingerprint(folder=folder) == aircraft.model_fingerprint()
    top = folder / "solar_uav.xml"  # documentation only: status, header notes, comments
    top.write_text(top.read_text().replace('release="ANALYTICAL"', 'release="PRODUCTION"')
                   .replace("<author>solar-uav-rl</author>", "<author>someone else</author><!-- edited -->"))
    assert "PRODUCTION" in top.read_text() and "someone else" in top.read_text()
    assert aircraft.model_fingerprint(folder=folder) == aircraft.model_fingerprint()
    mass = folder / "MassBalance.xml"
    mass.write_text(mass.read_text().replace("<emptywt unit=\"KG\"> 359 </emptywt>", "<emptywt unit=\"KG\"> 360 </emptywt>"))
    assert "360 </emptywt>" in mass.read_text()
    assert aircraft.model_fingerprint(folder=folder) != aircraft.model_fingerprint()


def test_a_new_simulation_does_not_depend_on_what_the_heap_held():
    """JSBSim 1.3 leaves a propeller's absorbed power uninitialised until its first step, while the
    motors' speed controllers read it in the flight control, which runs first (found with
    valgrind). With freed memory full of NaN, every new simulation used to start with NaN
    accelerations; ``Simulation`` now starts that power at 0."""
    for _ in range(10):
        junk = [np.full(n // 8, np.nan) for n in range(256, 4096, 8) for _ in range(3)]
        del junk
        s = Simulation()
        s.set_initial_conditions(1000.0, 10.5)
        assert math.isfinite(s["accelerations/wdot-ft_sec2"])
        assert all(math.isfinite(s[f"fcs/esc-{i}-power-norm"]) for i in range(s.engine_count))


def test_the_envelope_is_part_of_the_fingerprint_and_an_older_record_still_matches_its_aircraft(tmp_path):
    import json

    from jsbsim_env.control.policy import WrongAircraftError, check_aircraft, load_policy, shipped_policy_path

    folders = {}
    for which in ("as_built", "edited"):
        folders[which] = folder = tmp_path / which / "aircraft" / "solar_uav"
        shutil.copytree(aircraft.aircraft_dir(), folder)
    envelope = folders["edited"] / aircraft.ENVELOPE_FILE
    values = json.loads(envelope.read_text())
    values["altitude_range_m"] = [0.0, 30000.0]
    envelope.write_text(json.dumps(values))
    built, edited = aircraft.load_aircraft(folders["as_built"]), aircraft.load_aircraft(folders["edited"])
    assert built.fingerprint == aircraft.model_fingerprint() != edited.fingerprint
    trained = {"aircraft": "solar_uav", "aircraft_model": built.fingerprint}
    check_aircraft(trained, tmp_path / "policy.pt", built)
    with pytest.raises(WrongAircraftError, match="trained on solar_uav"):
        check_aircraft(trained, tmp_path / "policy.pt", edited)
    # A record from before the envelope joined the fingerprint keeps the XML files' alone: it matches.
    older = {"aircraft": "solar_uav", "aircraft_model": aircraft.model_fingerprint(envelope=False)}
    check_aircraft(older, tmp_path / "policy.pt", built)
    check_aircraft(load_policy(shipped_policy_path())[1], shipped_policy_path(), aircraft.load_aircraft())

"""Another aircraft than the paper's, from its description to the commands: the small example
(``aircraft/small_solar_uav.toml``) built once for the module (about 35 s: analysis, JSBSim files,
the classical controllers' design, the survey), then flown by the environments, the classical
controllers and, refused, by a policy trained on the paper's aircraft."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import aircraft
from aircraft.design import aero_data
from aircraft.design.description import PAPER_AIRCRAFT, load_description

SMALL_AIRCRAFT = PAPER_AIRCRAFT.with_name("small_solar_uav.toml")


@pytest.fixture(scope="module")
def small(small_aircraft):
    """The JSBSim root the small example is built into (conftest's ``small_aircraft``)."""
    return small_aircraft


def test_the_small_example_builds_loads_in_jsbsim_and_trims_across_its_envelope(small):
    from jsbsim_env.sim.simulation import Simulation

    report = (small / "build_report.md").read_text()
    assert report.startswith("# small_solar_uav: build report") and "static margin 0.10 MAC" in report
    # The survey: a trim at the reference EAS at each altitude, and every mode named there.
    assert report.count("| 12.0 | 5.") == 3 and "short_period" in report and "dutch_roll" in report
    # ... and across its EAS range: the static margin and the modes at all nine points, each flagged
    # against the stated limits (its spiral diverges faster than MIL-F-8785C's 20 s at low speed).
    assert "## Trims, static margin and modes across the envelope" in report
    margins = [float(m) for m in re.findall(r"^\| \d+ \| 1[025]\.0 \| (\d+\.\d) % \|", report, re.MULTILINE)]
    assert len(margins) == 9 and all(7.0 < m < 12.0 for m in margins)
    assert "- 150 m, 10 m/s: spiral time to double" in report
    # The run-time trim table's whole grid: 22 altitudes by 10-15 m/s in 1 m/s steps.
    assert "## The trim table" in report and "132 of 132 points trimmed." in report
    folder = small / "aircraft" / "small_solar_uav"
    assert (folder / "small_solar_uav.xml").is_file() and (small / "aero_data.json").is_file()
    assert aircraft.model_fingerprint(folder=folder) != aircraft.model_fingerprint()
    sim = Simulation(small)
    assert sim.aircraft.name == "small_solar_uav" and sim.aircraft.fingerprint == aircraft.model_fingerprint(folder=folder)
    assert sim.inertia_kg_m2().ixx_kg_m2 == pytest.approx(15.0, rel=1e-3)
    geometry = load_description(SMALL_AIRCRAFT)
    low, high = geometry.envelope.altitude_range_m
    for altitude_m in (low, high):
        for eas_mps in (*geometry.envelope.eas_range_mps, geometry.envelope.reference_eas_mps):
            trim = sim.trim(altitude_m, eas_mps)
            assert 0.0 < trim.throttle < 1.0 and -10.0 < trim.alpha_deg < 14.0, (altitude_m, eas_mps)
    cruise = sim.trim(low, geometry.envelope.reference_eas_mps)
    # The trim's angle of attack is the analysis's cruise angle of attack.
    cruise_alpha = aero_data.load(small / "aero_data.json")["stability"]["cruise_alpha_deg"]
    assert cruise.alpha_deg == pytest.approx(cruise_alpha, abs=0.5)
    # The standalone JSBSim runs: trimmed initial conditions and doublets at 1.5 and 3 km.
    assert sorted(p.name for p in (small / "scripts").glob("*.xml")) == ["cruise_1500m_doublets.xml",
                                                                         "cruise_3000m_doublets.xml"]
    assert '<use aircraft="small_solar_uav" initialize="cruise_1500m"/>' in (
        small / "scripts" / "cruise_1500m_doublets.xml").read_text()
    assert (folder / "cruise_1500m.xml").is_file() and "## Standalone JSBSim runs" in report
    # Its own envelope: the paper's 10 km is outside it.
    with pytest.raises(Exception, match="outside the flight envelope 0-3000 m"):
        sim.trim(10_000.0, 12.0)


def test_the_aircraft_is_named_by_its_root_or_its_folder_and_a_description_is_not_a_built_aircraft(small, tmp_path):
    by_root = aircraft.load_aircraft(small)
    assert aircraft.load_aircraft(str(small / "aircraft" / "small_solar_uav")) == by_root
    assert by_root.altitude_range_m == (0.0, 3000.0) and by_root.eas_range_mps == (10.0, 15.0)
    assert by_root.surface_limits_deg == (25.0, 25.0, 25.0) and not by_root.packaged
    with pytest.raises(aircraft.AircraftError, match="is a description, not a built aircraft: build it with"):
        aircraft.load_aircraft(SMALL_AIRCRAFT)
    with pytest.raises(aircraft.AircraftError, match="holds no built aircraft"):
        aircraft.load_aircraft(tmp_path)
    with pytest.raises(aircraft.AircraftError, match="neither a packaged aircraft .*solar_uav.* nor a path"):
        aircraft.load_aircraft("small_uav")


def test_the_environments_fly_the_second_aircraft_in_its_own_envelope(small):
    import gymnasium as gym

    import jsbsim_env  # noqa: F401 - registers the environments
    from jsbsim_env.task.torchrl_env import make_env

    env = gym.make("SolarUAVAttitude-v1", aircraft=small)
    task = env.unwrapped.task
    assert task.core.aircraft.name == "small_solar_uav"
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        setup = task.core.setup
        assert 75.0 <= setup.altitude_m <= 3000.0 and 10.0 <= setup.airspeed_eas_mps <= 15.0
        assert 10.0 <= task.batch.goals[0, 2] <= 15.0  # the EAS goal: its envelope, not the paper's 8-12 m/s
        for _ in range(20):
            obs, _, terminated, _, _ = env.step(np.zeros(4, dtype=np.float32))
        assert np.isfinite(obs).all() and not terminated
    # The start the paper's aircraft makes at 10 km is refused, naming this aircraft's envelope.
    with pytest.raises(ValueError, match="small_solar_uav's flight envelope is 0..3000 m"):
        env.reset(options={"altitude_m": 10_000.0})
    td = make_env(2, aircraft=small).rollout(5)
    assert td["next", "observation"].shape == (2, 5, 8, 20)


def test_the_commands_range_over_the_aircrafts_own_travel(small):
    from jsbsim_env.control.observation import action_scale, action_to_command
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.sim.core import CommandError, CoreConfig, FlightCore
    from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig

    core = FlightCore(CoreConfig.ideal(aircraft=str(small), servo_rate_limit_degps=1000.0))
    core.reset(0, altitude_m=1000.0, airspeed_eas_mps=12.0)
    for command, expected in (([10.0, 0.0, 0.0, 0.6], 10.0), ([25.0, 0.0, 0.0, 0.6], 25.0)):
        for _ in range(25):
            core.step(np.array(command))
        assert core.sim["fcs/aileron-pos-deg"] == pytest.approx(expected, abs=0.05)
    with pytest.raises(CommandError, match="outside small_solar_uav's range"):
        core.step(np.array([30.0, 0.0, 0.0, 0.6]))  # the paper's aircraft's travel, beyond this one's stop
    # An action of +-1 is the stop of each surface (the paper's: 30, 30, 20 deg), in the task and the stack.
    found = aircraft.load_aircraft(small)
    scale = action_scale(found)
    assert scale.tolist() == [25.0, 25.0, 25.0, 0.5] and action_scale(aircraft.load_aircraft()).tolist() == [
        30.0, 30.0, 20.0, 0.5]
    assert action_to_command(np.array([1.0, -1.0, 1.0, 1.0]), scale).tolist() == [25.0, -25.0, 25.0, 1.0]
    batch = AttitudeTaskBatch(1, TaskConfig(core=CoreConfig.ideal(aircraft=str(small))))
    batch.reset_one(0, 0, altitude_m=1000.0, airspeed_eas_mps=12.0)
    batch.step(np.array([[0.0, 0.0, 1.0, 0.5]]))
    assert batch.cores[0].applied_command[2] == pytest.approx(25.0)
    # A classical controller clips at this aircraft's travel, not the paper's.
    pid = PIDAttitudeController(aircraft=small)
    measurement = [1000.0, np.radians(-40.0), 0.0, 0.0, 0.0, 0.0, 12.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]
    assert abs(pid.update(0.05, measurement, [0.0, 0.0, 12.0])[0]) == pytest.approx(25.0)


def test_each_episode_flies_the_servo_rate_limit_of_the_description(small):
    from jsbsim_env.sim.core import CoreConfig, FlightCore

    described = load_description(SMALL_AIRCRAFT).surface_rate_limit_deg_per_s
    assert described == 300.0
    for aircraft_spec, rate_degps in ((str(small), described), (aircraft.AIRCRAFT_NAME, 100.0)):
        core = FlightCore(CoreConfig(aircraft=aircraft_spec))
        core.reset(0)
        assert core.sim["fcs/surface-rate-limit-deg_s"] == pytest.approx(rate_degps)
    # A rate given (a sweep's axis) replaces it.
    core = FlightCore(CoreConfig(aircraft=str(small), servo_rate_limit_degps=40.0))
    core.reset(0)
    assert core.sim["fcs/surface-rate-limit-deg_s"] == pytest.approx(40.0)


def test_its_classical_controllers_are_designed_for_it_and_fly_it(small):
    from jsbsim_env.control.classical_design import design_altitudes_m
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.sim.core import CoreConfig
    from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
    from training.evaluation.suite import fly

    found = aircraft.load_aircraft(small)
    for kind in ("pid", "lqi"):
        table = json.loads((found.folder / f"{kind}_gains.json").read_text())
        assert table["design_eas_mps"] == 12.0
        assert [p["altitude_m"] for p in table["points"]] == pytest.approx(design_altitudes_m(found))
        controller = make_controller(kind, aircraft=small)
        batch = AttitudeTaskBatch(1, TaskConfig(core=CoreConfig(aircraft=str(small), max_steps=400)))
        goal = np.array([np.radians(3.0), 0.0, 12.0])
        rec, end = fly(controller, batch, seed=1, steps=400, goal_fn=lambda t, g=goal: g, altitude_m=1500.0,
                       airspeed_eas_mps=12.0)
        roll_deg = np.degrees(rec.arrays()["true_state"][200:, 1])
        assert not end["terminated"] and abs(roll_deg.mean() - 3.0) < 0.5, (kind, end, roll_deg.mean())
    with pytest.raises(FileNotFoundError, match="small_solar_uav .* has no gain table .*tune_classical.py"):
        make_controller("pid_tuned", aircraft=small)


def test_a_policy_is_refused_on_an_aircraft_it_was_not_trained_on_unless_asked(small):
    from jsbsim_env.control.policy import PolicyRuntime, WrongAircraftError, check_aircraft

    with pytest.raises(WrongAircraftError, match=r"trained on solar_uav \(model e093eae216c2\) and would fly "
                                                 r"small_solar_uav \(.*\) \(model [0-9a-f]{12}\)"):
        PolicyRuntime(aircraft=small)
    runtime = PolicyRuntime(aircraft=small, transfer=True, backend="torch")
    assert runtime.aircraft.name == "small_solar_uav"
    found, paper = aircraft.load_aircraft(small), aircraft.load_aircraft()
    trained_here = {"aircraft": found.name, "aircraft_model": found.fingerprint}
    check_aircraft(trained_here, SMALL_AIRCRAFT, found)  # its own aircraft: flies
    with pytest.raises(WrongAircraftError, match="trained on small_solar_uav .* would fly solar_uav"):
        check_aircraft(trained_here, SMALL_AIRCRAFT, paper)


def test_the_benchmark_and_the_tuning_fly_the_papers_conditions_in_its_envelope(small, load_script, tmp_path, capsys):
    from training.evaluation.benchmark import BenchJob, family_conditions, family_what, jobs_for, run_benchmark_job
    from training.evaluation.heldout import heldout_flights

    assert [c["altitude_m"] for c in family_conditions("turbulence", small)] == [150.0, 1500.0, 3000.0]
    assert [c["altitude_m"] for c in family_conditions("turbulence")] == [1000.0, 10000.0, 20000.0]
    assert family_what("robustness", small).startswith("the turbulence flight at 1.5 km with")  # not 10 km
    assert family_what("table9").endswith("on a straight leg at 10 km")
    flights = heldout_flights(quick=True, aircraft=small)
    assert {name: f.altitude_m for name, f in flights.items()} == {
        "turbulent_5km": 750.0, "positive_3km": 450.0, "negative_3km": 450.0, "calm_15km": 2250.0}
    assert all(f.eas_mps == 12.0 and f.aircraft == str(small / "aircraft" / "small_solar_uav") for f in flights.values())
    jobs = jobs_for(["steps"], ["lqi"], 1, quick=True, aircraft=str(small))
    assert {j.aircraft for j in jobs} == {str(small)} and len(jobs) == 4
    (row,) = run_benchmark_job(BenchJob("turbulence", {"altitude_m": 1500.0}, "lqi", 0, quick=True,
                                        aircraft=str(small)))
    assert row["ended_early"] == "" and 0.0 < row["rmse_roll_deg"] < 2.0
    # Refused before any flight: a tuned controller it has no table for, the paper's policy on it.
    benchmark = load_script("benchmark").main
    assert benchmark(["--aircraft", str(small), "--controllers", "pid_tuned", "--out", str(tmp_path / "a")]) == 2
    assert "has no gain table" in capsys.readouterr().err
    assert benchmark(["--aircraft", str(small), "--controllers", "policy,pid", "--out", str(tmp_path / "b")]) == 2
    assert "ask for a transfer experiment" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_the_suite_the_sweep_and_the_loop_bench_fly_it(small, load_script, tmp_path, capsys):
    from jsbsim_env.control.factory import make_controller
    from training.evaluation.suite import doublet_goal, doublet_runs
    from training.evaluation.sweep import Job, parse_axis, run_job

    assert doublet_goal(55.0, 12.0)[2] == 13.0 and doublet_goal(65.0)[2] == 9.0  # about its reference EAS
    doublets = doublet_runs(make_controller("pid", aircraft=small), aircraft=small)
    assert list(doublets) == ["75m", "750m", "2250m"] and not any(d["ended_early"] for d in doublets.values())
    assert all(d["pitch_doublet_deg"] == pytest.approx(2.1, abs=1e-9) for d in doublets.values())  # its glide
    # About its level-flight pitch, the EAS steps after the pitch doublet settle.
    assert all(d["level_pitch_deg"] > 5.0 for d in doublets.values())
    assert all(np.isfinite(d["settling_time_90_s_airspeed_eas_mps"][0]) for d in doublets.values())
    assert parse_axis("altitude_m=500,2500", small) == ("altitude_m", [500.0, 2500.0])
    with pytest.raises(ValueError, match=r"5000 is outside its range \[0, 3000\] m: small_solar_uav's"):
        parse_axis("altitude_m=5000", small)
    (row,) = run_job(Job("lqi", {"altitude_m": 2500.0}, 0, 1, aircraft=str(small)))
    assert not row["ended_early"] and row["rmse_roll_deg"] < 5.0
    out = tmp_path / "bench"
    assert load_script("loop_bench").main(["--aircraft", str(small), "--controller", "lqi", "--mode", "lockstep",
                                           "--duration", "4", "--out", str(out), "--json"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 100 and not summary["ended_early"] and summary["failsafe_takeovers"] == 0
    assert summary["in_process"]["rmse_ratio"]["roll_deg"] == pytest.approx(1.0, abs=1e-6)
    capsys.readouterr()


def test_the_pitch_doublet_is_the_papers_on_its_aircraft_and_no_steeper_than_a_flatter_glide(small):
    """The paper's aircraft flies the paper's +-5 deg pitch doublet about 0 (Fig. 9); the small
    example, a solar glider whose level-flight thrust at 12 m/s is 3.8 % of its weight (a 2.15 deg
    descent) and whose level-flight pitch there is 5.9 deg, flies that angle rounded down to 0.1 deg
    about that pitch: a 5 deg dive, or a goal of 0 deg, would take it far over its speed."""
    from training.evaluation.suite import (
        DOUBLET_STEPS,
        doublet_goal,
        doublet_steps,
        level_pitch_deg,
        pitch_doublet_deg,
    )

    assert pitch_doublet_deg() == 5.0 and level_pitch_deg() == 0.0 and doublet_steps() == DOUBLET_STEPS
    assert doublet_steps(10.0, pitch_deg=5.0) == DOUBLET_STEPS
    pitch = np.degrees([v for c, _, v in DOUBLET_STEPS if c == 1])
    assert pitch == pytest.approx([5.0, -5.0, 0.0], abs=1e-12)
    amplitude = pitch_doublet_deg(small)
    assert amplitude == pytest.approx(2.1, abs=1e-9) and amplitude < 5.0
    level = level_pitch_deg(small)
    assert level == pytest.approx(5.9, abs=0.15)
    goals = np.degrees([doublet_goal(t, 12.0, pitch_deg=amplitude, level_pitch_deg=level)[1]
                        for t in (0.0, 29.0, 35.0, 45.0, 55.0)])
    assert goals == pytest.approx(level + np.array([0.0, 0.0, 2.1, -2.1, 0.0]), abs=1e-9)
    assert np.degrees(doublet_goal(35.0, 12.0)[1]) == pytest.approx(5.0, abs=1e-12)  # the default: the paper's
    assert doublet_goal(35.0, 12.0, pitch_deg=amplitude)[2] == pytest.approx(12.0, abs=1e-12)


def test_where_episodes_end_moves_with_the_envelope_and_an_envelope_reaching_it_is_refused(small, tmp_path):
    import shutil
    from dataclasses import replace

    from jsbsim_env.sim.core import CoreConfig, Envelope, FlightCore

    # Its episodes end at half its lowest EAS and 25/12 of its highest, as the paper's end at 4 and 25,
    # however its configuration was made (training replaces the aircraft of a default one).

    assert FlightCore(CoreConfig(aircraft=str(small))).ends.eas_range_mps == (5.0, 31.25)
    assert FlightCore(replace(CoreConfig(), aircraft=str(small))).ends.eas_range_mps == (5.0, 31.25)
    assert FlightCore(CoreConfig()).ends.eas_range_mps == (4.0, 25.0)
    # The small aircraft as if its envelope went up to 25 km, past the flight core's 22 km.
    high = tmp_path / "aircraft" / "small_solar_uav"
    shutil.copytree(small / "aircraft" / "small_solar_uav", high)
    record = json.loads((high / aircraft.ENVELOPE_FILE).read_text())
    (high / aircraft.ENVELOPE_FILE).write_text(json.dumps({**record, "altitude_range_m": [0.0, 25000.0]}))
    with pytest.raises(ValueError, match=r"small_solar_uav's envelope \(EAS 10-15 m/s, up to 25000 m\) reaches "
                                         r"where an episode ends \(CoreConfig.envelope: EAS 5-31.25 m/s, up to 22000 m"):
        FlightCore(CoreConfig(aircraft=str(tmp_path)))
    # An Envelope given on purpose is the user's: it flies, and ends where it says.
    FlightCore(CoreConfig(aircraft=str(tmp_path), envelope=Envelope(altitude_range_m=(50.0, 30000.0))))


def test_a_damaged_envelope_record_is_refused_naming_the_file(small, tmp_path):
    import shutil

    for i, (key, bad) in enumerate((("eas_range_mps", [15.0, 10.0]), ("surface_limits_deg", {"aileron": 25.0}),
                                    ("altitude_range_m", "low"))):
        folder = tmp_path / f"root{i}" / "aircraft" / "small_solar_uav"
        shutil.copytree(small / "aircraft" / "small_solar_uav", folder)
        record = json.loads((folder / aircraft.ENVELOPE_FILE).read_text())
        (folder / aircraft.ENVELOPE_FILE).write_text(json.dumps({**record, key: bad}))
        with pytest.raises(aircraft.AircraftError, match=r"envelope.json.*build the aircraft again"):
            aircraft.load_aircraft(folder)


"""The example aircraft other than the paper's, each built from its description as a user would:
the small solar UAV (two counter-rotating rotors) and the survey UAV (one tractor propeller, a tail
incidence the build solves). Each builds with a converged lattice, reports its margin and modes
across its envelope, trims at every point the episodes start from, and flies standalone
runscripts that start trimmed."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_runscripts import _read_csv, assert_starts_trimmed

import aircraft
from jsbsim_env.analysis.runscripts import runs_for
from jsbsim_env.sim.simulation import Simulation


@pytest.fixture(params=["small_aircraft", "survey_aircraft"])
def example(request):
    return request.getfixturevalue(request.param)


def test_each_example_builds_a_converged_lattice_and_surveys_its_envelope(example):
    report = (example / "build_report.md").read_text()
    assert "  converged: each derivative within 3 %" in report
    margins = re.findall(r"^\| \d+ \| \d+\.0 \| (-?\d+\.\d) % \|", report, re.MULTILINE)
    assert len(margins) == 9  # three speeds at each of three altitudes
    trimmed = re.search(r"^(\d+) of (\d+) points trimmed\.$", report, re.MULTILINE)
    assert trimmed and trimmed.group(1) == trimmed.group(2)


def test_each_examples_runscripts_start_trimmed(example, tmp_path):
    sim = Simulation(example)
    # A single propeller's torque is held by the lateral trim (aileron, rudder and a small sideslip,
    # wings level), as tightly as two counter-rotating rotors need none.
    single_rotor = sim.engine_count == 1
    for run in runs_for(sim.aircraft):
        trim = sim.trim(run.altitude_m, run.airspeed_eas_mps)
        assert (abs(trim.aileron_deg) > 0.01 and abs(trim.rudder_deg) > 0.01) == single_rotor, trim
        done = subprocess.run([str(Path(sys.executable).with_name("jsbsim")), "--root", str(example), "--outputpath",
                               str(tmp_path), str(example / "scripts" / f"{run.name}.xml")],
                              check=False, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        assert_starts_trimmed(_read_csv(tmp_path / f"{run.name}.csv"), trim, run)


def test_the_survey_uavs_solved_tail_incidence_trims_it_with_the_elevator_near_zero(survey_aircraft):
    found = aircraft.load_aircraft(survey_aircraft)
    assert found.name == "survey_uav" and Simulation(found).engine_count == 1
    sim = Simulation(found)
    for altitude_m in found.sample_altitudes_m:
        assert abs(sim.trim(altitude_m, found.reference_eas_mps).elevator_deg) < 0.5


def test_a_single_rotors_trim_holds_every_axis_and_the_paper_aircrafts_lateral_trim_is_zero(survey_aircraft):
    # The six body accelerations JSBSim computes at the trim, in m/s² and rad/s².
    names = ("udot-ft_sec2", "vdot-ft_sec2", "wdot-ft_sec2", "pdot-rad_sec2", "qdot-rad_sec2", "rdot-rad_sec2")
    survey = Simulation(survey_aircraft)
    trim = survey.trim(survey.aircraft.sample_altitudes_m[0], survey.aircraft.reference_eas_mps)
    accelerations = np.array([survey.fdm[f"accelerations/{n}"] for n in names]) * np.array([0.3048] * 3 + [1.0] * 3)
    assert np.all(np.abs(accelerations[:3]) < 1e-3) and np.all(np.abs(accelerations[3:]) < 1e-4), accelerations
    assert abs(trim.beta_deg) < 2.0 and survey["attitude/phi-deg"] == pytest.approx(0.0, abs=1e-9)
    paper = Simulation().trim(10000.0, 10.0)
    assert (paper.aileron_deg, paper.rudder_deg, paper.beta_deg) == (0.0, 0.0, 0.0)  # by symmetry, never solved

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
    # The trim is symmetric (angle of attack, elevator, throttle): a single propeller's torque is
    # left to the runscripts' wing leveler, within a quarter of a degree of roll over the first 10 s.
    single_rotor = sim.engine_count == 1
    for run in runs_for(sim.aircraft):
        done = subprocess.run([str(Path(sys.executable).with_name("jsbsim")), "--root", str(example), "--outputpath",
                               str(tmp_path), str(example / "scripts" / f"{run.name}.xml")],
                              check=False, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        assert_starts_trimmed(_read_csv(tmp_path / f"{run.name}.csv"), sim.trim(run.altitude_m, run.airspeed_eas_mps),
                              run, roll_deg=0.5 if single_rotor else 0.05, beta_deg=0.2 if single_rotor else 0.05)


def test_the_survey_uavs_solved_tail_incidence_trims_it_with_the_elevator_near_zero(survey_aircraft):
    found = aircraft.load_aircraft(survey_aircraft)
    assert found.name == "survey_uav" and Simulation(found).engine_count == 1
    sim = Simulation(found)
    for altitude_m in found.sample_altitudes_m:
        assert abs(sim.trim(altitude_m, found.reference_eas_mps).elevator_deg) < 0.5

"""An aircraft described in a TOML file (``aircraft.design.description``): the paper's aircraft
builds from its file to today's model, and a file that cannot describe an aircraft is refused,
naming the file and the key."""

from __future__ import annotations

import re
import shutil

import pytest

import aircraft
from aircraft.design import aero_data
from aircraft.design.description import (
    PAPER_AIRCRAFT,
    SECTIONS,
    DescriptionError,
    load_description,
)
from aircraft.design.geometry import AircraftGeometry

PAPER_TEXT = PAPER_AIRCRAFT.read_text()


def _edited(tmp_path, old: str, new: str, name: str = "edited.toml"):
    """The paper's file with the first ``old`` (a regular expression, one line) replaced by ``new``."""
    text, n = re.subn(old, new, PAPER_TEXT, count=1, flags=re.MULTILINE)
    assert n == 1, old
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_papers_aircraft_file_describes_todays_aircraft_exactly():
    assert load_description(PAPER_AIRCRAFT) == AircraftGeometry()


@pytest.fixture
def build_main(load_script):
    return load_script("build_aircraft").main


def test_the_papers_aircraft_builds_from_its_file_to_todays_model(tmp_path, capsys, build_main):
    # The build with the committed aerodynamic data set writes the committed files: same model,
    # same fingerprint.
    shutil.copy(aero_data.DATA_PATH, tmp_path / "aero_data.json")
    assert build_main([str(PAPER_AIRCRAFT), "--out", str(tmp_path), "--from-data", "--no-survey",
                       "--no-controllers"]) == 0
    built = tmp_path / "aircraft" / "solar_uav"
    assert "wrote 17 files" in capsys.readouterr().out
    assert (built / aircraft.ENVELOPE_FILE).read_text() == (aircraft.aircraft_dir() / aircraft.ENVELOPE_FILE).read_text()
    assert aircraft.model_fingerprint(folder=built) == aircraft.model_fingerprint()
    for path in built.rglob("*.xml"):
        rel = path.relative_to(built)
        # Those the trim rewrites (test_runscripts), and the standalone runs' trimmed starts, named
        # by altitude for a built copy (cruise_10000m.xml) and by the paper's names in the package.
        if rel.name not in ("reset01.xml", "reset02.xml") and not rel.name.startswith("cruise_"):
            assert path.read_text() == (aircraft.aircraft_dir() / rel).read_text(), rel


def test_another_aircraft_needs_a_folder_of_its_own_and_from_data_needs_its_data(tmp_path, capsys, build_main):
    other = _edited(tmp_path, r'^name = "solar_uav"$', 'name = "small_uav"')
    assert build_main([str(other)]) == 2
    assert "give --out DIR" in capsys.readouterr().err
    assert build_main([str(other), "--out", str(tmp_path / "build"), "--from-data"]) == 2
    assert "build without --from-data first" in capsys.readouterr().err
    assert build_main([str(tmp_path / "missing.toml"), "--out", str(tmp_path)]) == 2
    assert "missing.toml" in capsys.readouterr().err


def _keys():
    """Every (section, key) line of the paper's file that a ``key = value`` line sets, once each."""
    section, seen = None, []
    for line in PAPER_TEXT.splitlines():
        head = re.match(r"^\[\[?(\w+)\]\]?", line)
        if head:
            section = head.group(1)
            continue
        key = re.match(r"^(\w+) = ", line)
        if key and (section, key.group(1)) not in seen:
            seen.append((section, key.group(1)))
    return seen


@pytest.mark.parametrize(("section", "key"), _keys(), ids=lambda x: str(x))
def test_each_missing_key_is_named_with_the_file(tmp_path, section, key):
    # The first line that sets the key goes (for the arrays of tables: the first table's).
    text, seen, out = PAPER_TEXT.splitlines(), None, []
    dropped = False
    for line in text:
        head = re.match(r"^\[\[?(\w+)\]\]?", line)
        if head:
            seen = head.group(1)
        if not dropped and seen == section and re.match(rf"^{key} = ", line):
            dropped = True
            continue
        out.append(line)
    path = tmp_path / "missing_key.toml"
    path.write_text("\n".join(out))
    where = key if section is None else (f"{section}[0].{key}" if section in ("rotors", "contacts")
                                         else f"{section}.{key}")
    with pytest.raises(DescriptionError, match=re.escape(f"{where} is missing")) as err:
        load_description(path)
    assert str(path) in str(err.value)


def test_every_section_is_in_the_papers_file_and_a_missing_one_is_named(tmp_path):
    assert {s for s, _ in _keys() if s} == set(SECTIONS)
    text = re.sub(r"^\[actuators\].*?(?=^\[\[contacts)", "", PAPER_TEXT, flags=re.MULTILINE | re.DOTALL)
    path = tmp_path / "no_actuators.toml"
    path.write_text(text)
    with pytest.raises(DescriptionError, match=re.escape("[actuators] is missing")):
        load_description(path)


WRONG_VALUES = [
    (r"^span_m = 35.0", 'span_m = "35"', "wing.span_m must be a number"),
    (r"^blade_count = 2", "blade_count = 2.0", "propeller.blade_count must be a whole number"),
    (r"^blade_count = 2", "blade_count = true", "propeller.blade_count must be a whole number"),
    (r"^inertia_kg_m2 = .*$", "inertia_kg_m2 = [15221.0, 1827.5, 16967.0]", "mass.inertia_kg_m2 must have 4 values"),
    (r"^root_le_m = .*$", 'root_le_m = [9.0, 0.0, "z"]', r"horizontal_tail.root_le_m[2] must be a number"),
    (r"^mass_kg = 359.0", "mass_kg = nan", "mass.mass_kg must be finite"),
    (r"^span_m = 35.0", "span_m = 35.0\nspan_ft = 114.8", "wing.span_ft is not a key of [wing]"),
    (r"^name = .*$", 'name = "my uav"', "name must be letters, digits and underscores"),
    (r"^\[mass\]", "[masses]\n[mass]", "masses is not a section"),
    (r"^name = .*$", 'name = "a\nb', "not a TOML file"),
]
# Values of the right type that no aircraft can have.
NON_PHYSICAL_VALUES = [
    (r"^altitude_range_m = .*$", "altitude_range_m = [20000.0, 0.0]", "envelope.altitude_range_m must be"),
    (r"^eas_range_mps = .*$", "eas_range_mps = [12.0, 8.0]", "envelope.eas_range_mps must be [low, high] with 0 <"),
    (r"^reference_eas_mps = .*$", "reference_eas_mps = 14.0", "envelope.reference_eas_mps (14 m/s) must lie within"),
    (r"^start_altitude_range_m = .*$", "start_altitude_range_m = [500.0, 25000.0]",
     "randomisation.start_altitude_range_m must be [low, high] with low <= high inside the envelope (0 to 20000 m)"),
    (r"^start_eas_range_mps = .*$", "start_eas_range_mps = [7.0, 12.0]",
     "randomisation.start_eas_range_mps must be [low, high] with low <= high inside the envelope (8 to 12 m/s)"),
    (r"^reynolds = .*$", "reynolds = [3.0e5, 1.0e6, 5.0e5]", "envelope.reynolds must be two or more breakpoints"),
    (r"^cruise_reynolds = .*$", "cruise_reynolds = 1.2e6", "envelope.cruise_reynolds (1.2e+06) must be one of"),
    (r"^lattice_reynolds = .*$", "lattice_reynolds = 5e6", "envelope.lattice_reynolds (5e+06) must lie within"),
    (r"^span_m = 35.0", "span_m = -35.0", "wing.span_m must be above 0"),
    (r"^area_m2 = 78.5", "area_m2 = 40.0", "the area is too small for that planform"),
    (r"^kink_y_m = 8.75", "kink_y_m = 18.0", "wing.kink_y_m (18.0 m) must lie inside the semi-span"),
    (r"^outer_y_m = 16.5", "outer_y_m = 18.0", "must run outwards within the semi-span"),
    (r"^chord_fraction = 0.25", "chord_fraction = 1.5", "aileron.chord_fraction must lie in (0, 1)"),
    (r"^efficiency = 0.9", "efficiency = 0.0", "horizontal_tail.efficiency must lie in (0, 1]"),
    (r"^mass_kg = 359.0", "mass_kg = 0.0", "mass.mass_kg must be above 0"),
    (r"^inertia_kg_m2 = .*$", "inertia_kg_m2 = [15221.0, 1827.5, 30000.0, 37.0]", "is no rigid body's inertia"),
    (r"^static_margin = 0.15", "static_margin = -0.05", "mass.static_margin must lie in (0, 0.5)"),
    (r"^hub_diameter_m = 0.22", "hub_diameter_m = 3.0", "propeller.hub_diameter_m (3.0 m) must be below"),
    (r"^sense = -1", "sense = 2", "rotors[0].sense must be +1"),
    (r"^motor_efficiency = 0.85", "motor_efficiency = 1.2", "propulsion.motor_efficiency must lie in (0, 1]"),
    (r"^surface_rate_limit_deg_per_s = 100.0", "surface_rate_limit_deg_per_s = 0.0",
     "actuators.surface_rate_limit_deg_per_s must be above 0"),
    (r'^kind = "BOGEY"', 'kind = "WHEEL"', "contacts[0].kind must be BOGEY or STRUCTURE"),
    (r"^fuselage_stations_m = .*$", "fuselage_stations_m = [[1.0, 0.1], [0.0, 0.2]]", "in increasing x"),
]


@pytest.mark.parametrize(("old", "new", "named"), WRONG_VALUES + NON_PHYSICAL_VALUES)
def test_a_wrong_or_non_physical_value_is_named_with_the_file(tmp_path, old, new, named):
    path = _edited(tmp_path, old, new)
    with pytest.raises(DescriptionError, match=re.escape(named)) as err:
        load_description(path)
    assert str(err.value).startswith(f"{path}: ")


SMALL_AIRCRAFT = PAPER_AIRCRAFT.with_name("small_solar_uav.toml")


def test_the_small_example_is_unlike_the_papers_aircraft():
    small, paper = load_description(SMALL_AIRCRAFT), AircraftGeometry()
    assert small.name == "small_solar_uav" and small.wing.span_m == 5.0 and 10.0 <= small.mass_kg <= 20.0
    assert small.envelope.altitude_range_m[1] < paper.envelope.altitude_range_m[1] / 5
    assert len(small.rotors) == 2 and small.envelope.reference_eas_mps > paper.envelope.reference_eas_mps


def test_the_initial_conditions_shipped_with_a_model_lie_in_its_envelope():
    from aircraft.design.xml_writer import isa_density_kg_m3, reset_points

    # The paper's: 1, 10 and 20 km at 10 m/s EAS, as committed.
    assert reset_points(AircraftGeometry()) == ((1000.0, 10.5), (10000.0, 17.2), (20000.0, 37.1))
    small = load_description(SMALL_AIRCRAFT)
    low, high = small.envelope.altitude_range_m
    points = reset_points(small)
    assert [h for h, _ in points] == [150.0, 1500.0, 3000.0] and all(low <= h <= high for h, _ in points)
    assert all(tas >= small.envelope.reference_eas_mps for _, tas in points)
    # The 1976 standard atmosphere's table (geometric altitude).
    for altitude_m, rho in ((0.0, 1.2250), (5000.0, 0.73643), (11000.0, 0.36480), (20000.0, 0.08891)):
        assert isa_density_kg_m3(altitude_m) == pytest.approx(rho, rel=2e-4)


def test_the_tail_incidence_may_be_left_for_the_build_to_solve(tmp_path):
    pytest.importorskip("aerosandbox")
    from dataclasses import replace

    import numpy as np

    from aircraft.design.analysis import ALPHA_DEG

    text = SMALL_AIRCRAFT.read_text().replace("incidence_deg = -2.0         # nose-up positive", 'incidence_deg = "trim"')
    path = tmp_path / "trimmed_tail.toml"
    path.write_text(text)
    asked = load_description(path)
    assert asked.solve_tail_incidence and not load_description(SMALL_AIRCRAFT).solve_tail_incidence
    path.write_text(text.replace('"trim"', '"level"'))
    with pytest.raises(DescriptionError, match=r"horizontal_tail.incidence_deg must be a number .* or 'trim'"):
        load_description(path)
    solved = aero_data.solve_tail_incidence(asked)
    assert -6.0 < solved.horizontal_tail.incidence_deg < 2.0
    # At the solved incidence the pitching moment at the cruise angle of attack, elevator at zero, is nil.
    alpha_cruise, _, _, polar = aero_data._balance(solved)
    j = solved.envelope.reynolds.index(solved.envelope.cruise_reynolds)
    assert abs(np.interp(alpha_cruise, ALPHA_DEG, polar["Cm"][:, j])) < aero_data.TAIL_INCIDENCE_TOLERANCE_CM
    # A build writes the model with the data set's incidence.
    data = {"meta": {"geometry": {"horizontal_tail": {"incidence_deg": solved.horizontal_tail.incidence_deg}}}}
    assert aero_data.solved_geometry(asked, data).horizontal_tail == solved.horizontal_tail
    assert aero_data.solved_geometry(replace(asked, solve_tail_incidence=False), data) == replace(
        asked, solve_tail_incidence=False)

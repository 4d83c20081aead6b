"""A description of the right types that no UAV can be (``aircraft.design.description.plausible``)
is refused before any analysis, in one line naming the key and the reason: each case below is the
small example with one key changed."""

from __future__ import annotations

import re
import time

import pytest

from aircraft.design import description as desc
from aircraft.design.description import PAPER_AIRCRAFT, DescriptionError, load_description

SMALL_AIRCRAFT = PAPER_AIRCRAFT.with_name("small_solar_uav.toml")
EXAMPLES = [PAPER_AIRCRAFT, SMALL_AIRCRAFT, PAPER_AIRCRAFT.with_name("survey_uav.toml")]


def edited(path, section: str | None, key: str, value: str):
    """``path``'s text with the first ``key = ...`` line of ``[section]`` (or ``[[section]]``, its
    first table) set to ``key = value``."""
    lines, inside, done = path.read_text().splitlines(), section is None, False
    for i, line in enumerate(lines):
        if re.match(r"^\[\[?(\w+)\]\]?", line):
            if done:
                break
            inside = re.match(rf"^\[\[?{section}\]\]?", line) is not None if section else False
        elif inside and not done and re.match(rf"^{key} = ", line):
            lines[i] = f"{key} = {value}"
            done = True
    assert done, (section, key)
    return "\n".join(lines) + "\n"


# (section, key, new value, what the message names)
ABSURD = [
    ("mass", "inertia_kg_m2", "[1e9, 1e9, 1e9, 0.1]", "mass.inertia_kg_m2 (Ixx)"),
    ("mass", "inertia_kg_m2", "[1e-6, 2.5, 2.5, 0.0]", "mass.inertia_kg_m2 (Ixx)"),
    ("mass", "mass_kg", "1e-6", "mass.mass_kg"),
    ("mass", "mass_kg", "1e6", "mass.mass_kg"),
    ("mass", "mass_kg", "600.0", "mass.mass_kg: the wing loading"),
    ("mass", "cg_z_m", "100.0", "mass.cg_z_m"),
    ("propeller", "diameter_m", "50.0", "propeller.diameter_m"),
    ("propeller", "blade_count", "1000", "propeller.blade_count"),
    ("horizontal_tail", "root_le_m", "[1000.0, 0.0, 0.05]", "horizontal_tail.root_le_m"),
    ("horizontal_tail", "root_le_m", "[-1.5, 0.0, 0.05]", "horizontal_tail.root_le_m"),
    ("vertical_tail", "root_le_m", "[-1.5, 0.0, 0.05]", "vertical_tail.root_le_m"),
    ("horizontal_tail", "tip_le_m", "[1.47, 4.0, 0.05]", "horizontal_tail.tip_le_m"),
    ("horizontal_tail", "tip_le_m", "[1.47, -0.4, 0.05]", "horizontal_tail.tip_le_m"),
    ("horizontal_tail", "tip_le_m", "[1.47, 0.05, 0.05]", "horizontal_tail (its chords, half span and arm)"),
    ("horizontal_tail", "incidence_deg", "60.0", "horizontal_tail.incidence_deg"),
    ("actuators", "aileron_limit_deg", "1e6", "actuators.aileron_limit_deg"),
    ("actuators", "rudder_limit_deg", "90.0", "actuators.rudder_limit_deg"),
    ("actuators", "surface_time_constant_s", "100.0", "actuators.surface_time_constant_s"),
    ("actuators", "surface_rate_limit_deg_per_s", "1e6", "actuators.surface_rate_limit_deg_per_s"),
    ("wing", "outer_dihedral_deg", "89.0", "wing.outer_dihedral_deg"),
    ("wing", "tip_twist_deg", "-45.0", "wing.tip_twist_deg"),
    ("wing", "incidence_deg", "30.0", "wing.incidence_deg"),
    ("wing", "area_m2", "10.0", "wing.area_m2"),
    ("envelope", "eas_range_mps", "[2.0, 15.0]", "envelope.eas_range_mps"),
    ("envelope", "eas_range_mps", "[10.0, 500.0]", "envelope.eas_range_mps"),
    ("reference", "reference_chord_m", "30.0", "reference.reference_chord_m"),
    ("reference", "reference_area_m2", "1e-3", "reference.reference_area_m2"),
    ("fuselage", "fuselage_stations_m", "[[-0.5, 0.0], [-0.2, 10.0], [1.6, 0.01]]", "fuselage.fuselage_stations_m[1]"),
    ("fuselage", "fuselage_stations_m", "[[-5000.0, 0.0], [1.6, 0.01]]", "fuselage.fuselage_stations_m[0]"),
    ("rotors", "position_m", "[-0.15, -700.0, 0.0]", "rotors[0].position_m"),
    ("contacts", "position_m", "[0.0, 0.0, -1e4]", "contacts[0].position_m"),
    ("propulsion", "max_rotor_speed_rpm", "60000.0", "propulsion.max_rotor_speed_rpm"),
    ("propulsion", "motor_max_power_w", "1e7", "propulsion.motor_max_power_w"),
    ("propulsion", "motor_max_power_w", "1e-3", "propulsion.motor_max_power_w"),
    ("propulsion", "rotor_inertia_kg_m2", "100.0", "propulsion.rotor_inertia_kg_m2"),
    ("propulsion", "rotor_time_constant_s", "1e4", "propulsion.rotor_time_constant_s"),
]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_each_example_is_plausible(example):
    load_description(example)


@pytest.mark.parametrize(("section", "key", "value", "named"), ABSURD, ids=lambda x: str(x))
def test_an_absurd_description_is_refused_in_one_line_naming_the_key_before_any_analysis(
        tmp_path, capsys, load_script, monkeypatch, section, key, value, named):
    path = tmp_path / "absurd.toml"
    path.write_text(edited(SMALL_AIRCRAFT, section, key, value))
    with pytest.raises(DescriptionError) as err:
        load_description(path)
    assert str(err.value).startswith(f"{path}: {named}") and "\n" not in str(err.value)

    # The build refuses it in one line, before any analysis and without writing anything.
    from aircraft.design import aero_data

    def no_analysis(*args, **kwargs):
        raise AssertionError("the analysis ran")

    monkeypatch.setattr(aero_data, "compute_aero_data", no_analysis)
    out = tmp_path / "build"
    start = time.perf_counter()
    assert load_script("build_aircraft").main([str(path), "--out", str(out), "--no-survey"]) == 2
    assert time.perf_counter() - start < 5.0
    message = capsys.readouterr().err
    assert message.count("\n") == 1 and named in message, message
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["absurd.toml"]


def test_each_limit_is_a_named_constant_and_the_examples_sit_inside_them():
    # The limits the examples are checked against are the module's named constants.
    assert desc.BLADE_COUNT_RANGE == (2, 8) and desc.MAX_SURFACE_TRAVEL_DEG == 45.0
    assert desc.MAX_DIHEDRAL_DEG == 20.0
    for example in EXAMPLES:
        g = load_description(example)
        assert g.propeller.diameter_m / g.wing.span_m < desc.MAX_PROPELLER_SPAN_FRACTION
        assert abs(g.wing.outer_dihedral_deg) <= desc.MAX_DIHEDRAL_DEG

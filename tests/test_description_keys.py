"""Every key of an aircraft description reaches where it acts, walked on each example aircraft
built from its file (the small solar UAV and the survey UAV): the flown model (the JSBSim files, read back through JSBSim where a flight could set
them otherwise), the record the run-time code reads (``envelope.json``, ``aircraft.Aircraft``), or
the analysis that computes the aerodynamic data set (which records the geometry it used).

A key a description holds that this walk has no place for fails it: a new key must be shown to
act, or be refused by the description's check."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pytest
import tomllib

import aircraft
from aircraft.design.description import PAPER_AIRCRAFT

SMALL_AIRCRAFT = PAPER_AIRCRAFT.with_name("small_solar_uav.toml")
M_TO_FT = 1.0 / 0.3048
SLUG_TO_KG = 14.5939


def _flat(table: dict, prefix: str = "") -> dict:
    """The description's keys as ``section.key`` (``rotors[].key`` for an array of tables, its
    values a list, one per table)."""
    out = {}
    for key, value in table.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for name in value[0]:
                out[f"{prefix}{key}[].{name}"] = [row[name] for row in value]
        else:
            out[f"{prefix}{key}"] = value
    return out


@dataclass
class Built:
    """A built example aircraft, read back: its record, files, data set and a flight core that has
    started an episode with every default."""

    found: aircraft.Aircraft
    data: dict
    core: object  # FlightCore after reset
    sim: object = None  # Simulation of the nominal model
    found_chord: float = 0.0
    report: str = ""
    described: dict | None = None

    def xml(self, name: str) -> ET.Element:
        return ET.parse(self.found.folder / name).getroot()

    def number(self, name: str, path: str) -> float:
        return float(self.xml(name).find(path).text)

    def analysed(self, key: str):
        """The value the aerodynamic analysis used for ``section.key``: its data set's record."""
        section, name = key.split(".")
        geometry = self.data["meta"]["geometry"]
        nested = {"propeller": "propeller", "wing": "wing", "aileron": "aileron", "horizontal_tail": "horizontal_tail",
                  "vertical_tail": "vertical_tail", "envelope": "envelope"}
        return geometry[nested[section]][name] if section in nested else geometry[name]


def _same(a, b, rtol: float = 1e-5) -> bool:
    """Equal to the files' six printed digits (or ``rtol``: JSBSim's own unit conversions)."""
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=rtol, atol=1e-9)


def _surface_lag_per_s(b: Built) -> float:
    return b.number("FlightControl.xml", ".//actuator/lag")


def _esc_gain(b: Built) -> float:
    function = b.xml("Systems/rotor_speed.xml").find(".//fcs_function[@name='fcs/esc-0-power-norm']")
    return float(function.find(".//product/value").text)


def _full_power_w(b: Built, eas_mps: float) -> float:
    """Each motor's shaft power with the throttle full, at sea level and ``eas_mps``."""
    sim = b.sim
    trim = sim.trim(b.found.altitude_range_m[0], b.found.reference_eas_mps)
    sim.place_with_controls(b.found.altitude_range_m[0], eas_mps, trim.alpha_deg, 0.0, trim.elevator_deg, 0.0, 1.0)
    return sim.shaft_power_w() / sim.engine_count


def _powers(report: str) -> list[tuple[float, float]]:
    """The build report's survey rows' shaft and electric power (W), each printed to 0.1 W."""
    rows = re.findall(r"^\|(?: [^|]+ \|){7} (\d+\.\d) \| (\d+\.\d) \|$", report, re.MULTILINE)
    assert len(rows) == 9, rows  # three speeds at each of three altitudes
    return [(float(shaft), float(electric)) for shaft, electric in rows]


# Each key: where it acts, checked against the described value.
WHERE = {
    "name": lambda b, v: b.found.name == v and (b.found.folder / f"{v}.xml").is_file(),
    "description": lambda b, v: b.xml(f"{b.found.name}.xml").find("fileheader/description").text.startswith(v),
    "envelope.altitude_range_m": lambda b, v: b.found.altitude_range_m == tuple(v),
    "envelope.eas_range_mps": lambda b, v: b.found.eas_range_mps == tuple(v),
    "envelope.reference_eas_mps": lambda b, v: b.found.reference_eas_mps == v and json.loads(
        (b.found.folder / "pid_gains.json").read_text())["design_eas_mps"] == v,
    "envelope.reynolds": lambda b, v: _same(b.data["grids"]["reynolds"], v),
    "envelope.cruise_reynolds": lambda b, v: _same(b.analysed("envelope.cruise_reynolds"), v),
    "envelope.lattice_reynolds": lambda b, v: _same(b.analysed("envelope.lattice_reynolds"), v),
    # Where an episode starts when not told: the flight core's ranges.
    "randomisation.start_altitude_range_m": lambda b, v: b.found.start_altitude_range_m == tuple(v)
    and tuple(b.core.altitude_range_m) == tuple(v),
    "randomisation.start_eas_range_mps": lambda b, v: b.found.start_eas_range_mps == tuple(v)
    and tuple(b.core.eas_range_mps) == tuple(v),
    "reference.reference_area_m2": lambda b, v: _same(b.sim["metrics/Sw-sqft"], v * M_TO_FT**2),
    "reference.reference_span_m": lambda b, v: _same(b.sim["metrics/bw-ft"], v * M_TO_FT),
    "reference.reference_chord_m": lambda b, v: _same(b.sim["metrics/cbarw-ft"], v * M_TO_FT),
    "mass.mass_kg": lambda b, v: _same(b.sim["inertia/mass-slugs"] * SLUG_TO_KG, v),
    "mass.inertia_kg_m2": lambda b, v: _same(tuple(b.sim.inertia_kg_m2()), v, rtol=2e-4),
    # The CG at the static margin ahead of the neutral point the analysis found.
    "mass.static_margin": lambda b, v: _same(
        b.number("MassBalance.xml", "location[@name='CG']/x"),
        b.data["stability"]["neutral_point_x_m"] - v * b.found_chord),
    "mass.cg_z_m": lambda b, v: _same(b.number("MassBalance.xml", "location[@name='CG']/z"), v),
    "propeller.diameter_m": lambda b, v: _same(b.number("Engines/propeller.xml", "diameter"), v),
    "rotors[].position_m": lambda b, v: _same(
        [[float(t.find(f"thruster/location/{c}").text) for c in "xyz"] for t in b.xml("Propulsion.xml").iter("engine")],
        v),
    "rotors[].sense": lambda b, v: [int(float(t.find("thruster/sense").text))
                                   for t in b.xml("Propulsion.xml").iter("engine")] == v,
    "propulsion.max_rotor_speed_rpm": lambda b, v: _same(
        b.number("Systems/rotor_speed.xml", ".//actuator[@name='fcs/rotor-speed-ref-rpm']/clipto/max"), v),
    # Full throttle turns each rotor where its motor's full power drives it at this EAS.
    "propulsion.throttle_reference_eas_mps": lambda b, v: abs(_full_power_w(b, v) / b.described[
        "propulsion.motor_max_power_w"] - 1.0) < 0.02,
    "propulsion.rotor_inertia_kg_m2": lambda b, v: _same(b.number("Engines/propeller.xml", "ixx"), v),
    "propulsion.motor_max_power_w": lambda b, v: _same(b.number("Engines/motor.xml", "power"), v),
    # The speed controller's power per rpm of error and of speed: I (2 pi / 60)^2 / tau, a loop of tau.
    "propulsion.esc_time_constant_s": lambda b, v: _same(
        _esc_gain(b), b.described["propulsion.rotor_inertia_kg_m2"] * M_TO_FT**2 / SLUG_TO_KG * (2 * math.pi / 60) ** 2
        / v),
    "propulsion.rotor_time_constant_s": lambda b, v: _same(b.core.sim["fcs/rotor-lag-per-s"], 1.0 / v),
    "propulsion.rotor_rate_limit_rpm_per_s": lambda b, v: _same(b.core.sim["fcs/rotor-rate-limit-rpm_s"], v),
    # The electric power the build's survey reports: the shaft power over this efficiency.
    "propulsion.motor_efficiency": lambda b, v: f"electric power at {v:g} motor efficiency" in b.report and _powers(
        b.report) and all(abs(shaft / v - electric) < 0.12 for shaft, electric in _powers(b.report)),
    # A number the analysis uses as given; "trim": the incidence the build solved, which the analysis used.
    "horizontal_tail.incidence_deg": lambda b, v: (b.data["meta"]["geometry"]["solve_tail_incidence"]
                                                   and isinstance(b.analysed("horizontal_tail.incidence_deg"), float))
    if v == "trim" else _same(b.analysed("horizontal_tail.incidence_deg"), v),
    "actuators.surface_time_constant_s": lambda b, v: _same(_surface_lag_per_s(b), 1.0 / v),
    # What every flight flies with, as the flight core leaves it after starting an episode.
    "actuators.surface_rate_limit_deg_per_s": lambda b, v: _same(b.core.sim["fcs/surface-rate-limit-deg_s"], v),
    "actuators.aileron_limit_deg": lambda b, v: b.found.surface_limits_deg[0] == v == b.core.command_high[0],
    "actuators.elevator_limit_deg": lambda b, v: b.found.surface_limits_deg[1] == v == b.core.command_high[1],
    "actuators.rudder_limit_deg": lambda b, v: b.found.surface_limits_deg[2] == v == b.core.command_high[2],
    "contacts[].name": lambda b, v: [c.get("name") for c in b.xml("GroundReactions.xml").iter("contact")] == v,
    "contacts[].kind": lambda b, v: [c.get("type") for c in b.xml("GroundReactions.xml").iter("contact")] == v,
    "contacts[].position_m": lambda b, v: _same(
        [[float(c.find(f"location/{k}").text) for k in "xyz"] for c in b.xml("GroundReactions.xml").iter("contact")],
        v),
    "contacts[].static_friction": lambda b, v: _same(
        [float(c.find("static_friction").text) for c in b.xml("GroundReactions.xml").iter("contact")], v),
    "contacts[].spring_n_per_m": lambda b, v: _same(
        [float(c.find("spring_coeff").text) for c in b.xml("GroundReactions.xml").iter("contact")], v),
    "contacts[].damping_n_s_per_m": lambda b, v: _same(
        [float(c.find("damping_coeff").text) for c in b.xml("GroundReactions.xml").iter("contact")], v),
}
# The keys that act only through the aerodynamic analysis (the polar, the lattice, the control
# surfaces' sections, the propeller's blade elements): the data set records each value it used.
ANALYSED = ("wing.", "aileron.", "horizontal_tail.", "vertical_tail.", "fuselage.", "propeller.")


# The example descriptions, each with the session fixture that builds it (conftest.py).
EXAMPLES = {"small_aircraft": SMALL_AIRCRAFT, "survey_aircraft": PAPER_AIRCRAFT.with_name("survey_uav.toml")}


@pytest.fixture(scope="module", params=list(EXAMPLES))
def built(request):
    from jsbsim_env.sim.core import CoreConfig, FlightCore
    from jsbsim_env.sim.simulation import Simulation

    root = request.getfixturevalue(request.param)
    found = aircraft.load_aircraft(root)
    core = FlightCore(CoreConfig(aircraft=str(root)))
    core.reset(0)
    b = Built(found, json.loads((root / "aero_data.json").read_text()), core)
    b.sim = Simulation(found)  # the nominal model, as built (the episode's core flies randomised coefficients)
    b.found_chord = float(b.number("Metrics.xml", "chord"))
    b.report = (root / "build_report.md").read_text()
    b.described = _flat(tomllib.loads(EXAMPLES[request.param].read_text()))
    return b


@pytest.mark.parametrize("description", list(EXAMPLES.values()), ids=lambda p: p.stem)
def test_every_key_of_the_description_has_a_place_where_it_acts(description):
    described = _flat(tomllib.loads(description.read_text()))
    unplaced = [k for k in described if k not in WHERE and not k.startswith(ANALYSED)]
    assert not unplaced, f"description keys with no place where they act: {unplaced}"
    assert not set(WHERE) - set(described), "places for keys the description does not have"


@pytest.mark.parametrize("key", list(_flat(tomllib.loads(SMALL_AIRCRAFT.read_text()))))
def test_each_key_reaches_where_it_acts(built, key):
    value = built.described[key]
    if key in WHERE:
        assert WHERE[key](built, value), f"{key} = {value!r} does not reach where it acts"
    else:  # the analysis's own input, as its data set records it
        analysed = built.analysed(key)
        same = analysed == value if isinstance(value, str) else _same(analysed, value)
        assert same, f"{key} = {value!r}, but the analysis used {analysed!r}"

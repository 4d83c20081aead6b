"""An aircraft described in a TOML file: what ``AircraftGeometry`` holds, read and checked.

The file's sections group ``AircraftGeometry``'s fields; each key is the field of the same name,
with its unit in the name (``docs/aircraft.md`` has the table, ``aircraft/solar_uav.toml`` is the
paper's aircraft in this form). A file is checked whole before anything is built from it: an
unknown, missing or mistyped key, or a value that no aircraft can have, is a ``DescriptionError``
naming the file and the key (``wing.span_m``), never a model built from it.

| section | fields |
|---|---|
| (top) | ``name``: the JSBSim aircraft name, also its folder's; ``description``: what it is (its JSBSim file header) |
| ``[envelope]`` | ``FlightEnvelope``: altitude and EAS ranges, reference EAS, the analysis's Reynolds breakpoints |
| ``[randomisation]`` | ``Randomisation``: where training episodes start (altitude and EAS ranges) |
| ``[wing]`` | ``WingGeometry``: airfoil, span, area, planform break, root chord, dihedral, twist, incidence |
| ``[aileron]`` | ``ControlSurfaceSpan``: spanwise extent, chord fraction |
| ``[horizontal_tail]``, ``[vertical_tail]`` | ``TailSurface``: section, leading edges, chords, incidence (the horizontal tail's may be ``"trim"``: the build solves the incidence that trims at the reference EAS with the elevator at zero), control chord, efficiency |
| ``[fuselage]`` | ``fuselage_stations_m``: (x, radius) stations |
| ``[reference]`` | reference area, span and chord of the coefficients |
| ``[mass]`` | mass, inertia (Ixx, Iyy, Izz, Ixz), static margin, CG height |
| ``[propeller]`` | ``PropellerGeometry`` of every rotor |
| ``[[rotors]]`` | ``Rotor``: hub position, sense of rotation (one table per rotor) |
| ``[propulsion]`` | rotor speed limit, throttle reference, inertias, motor power, lags, efficiency |
| ``[actuators]`` | surface lag and rate limit, surface travel limits |
| ``[[contacts]]`` | ``ContactPoint``: ground contacts (one table per contact) |
"""

from __future__ import annotations

import itertools
import math
import typing
from dataclasses import fields
from pathlib import Path

from .geometry import (
    AircraftGeometry,
    ContactPoint,
    ControlSurfaceSpan,
    FlightEnvelope,
    Randomisation,
    Rotor,
    TailSurface,
    WingGeometry,
)
from .propeller import PropellerGeometry

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

# Section -> the AircraftGeometry fields it holds, flat (a dataclass section is the field itself).
SECTIONS: dict[str, tuple[str, ...]] = {
    "envelope": ("envelope",),
    "randomisation": ("randomisation",),
    "wing": ("wing",),
    "aileron": ("aileron",),
    "horizontal_tail": ("horizontal_tail",),
    "vertical_tail": ("vertical_tail",),
    "fuselage": ("fuselage_stations_m",),
    "reference": ("reference_area_m2", "reference_span_m", "reference_chord_m"),
    "mass": ("mass_kg", "inertia_kg_m2", "static_margin", "cg_z_m"),
    "propeller": ("propeller",),
    "rotors": ("rotors",),
    "propulsion": ("max_rotor_speed_rpm", "throttle_reference_eas_mps", "rotor_inertia_kg_m2", "motor_max_power_w",
                   "esc_time_constant_s", "rotor_time_constant_s", "rotor_rate_limit_rpm_per_s", "motor_efficiency"),
    "actuators": ("surface_time_constant_s", "surface_rate_limit_deg_per_s", "aileron_limit_deg",
                  "elevator_limit_deg", "rudder_limit_deg"),
    "contacts": ("contacts",),
}
_NESTED = {"envelope": FlightEnvelope, "randomisation": Randomisation, "wing": WingGeometry, "aileron": ControlSurfaceSpan, "horizontal_tail": TailSurface,
           "vertical_tail": TailSurface, "propeller": PropellerGeometry}
_LISTS = {"rotors": Rotor, "contacts": ContactPoint}  # arrays of tables
_TOP = ("name", "description")  # the keys before the first section
# horizontal_tail.incidence_deg's other value: the incidence that trims at the reference EAS with the
# elevator at zero, solved by the build.
TRIM_INCIDENCE = "trim"
PAPER_AIRCRAFT = Path(__file__).resolve().parent.parent / "solar_uav.toml"  # the paper's aircraft, described


class DescriptionError(ValueError):
    """An aircraft description that cannot describe an aircraft; the message names the file and the key."""


def _convert(value, hint, key: str):
    """``value`` as the type ``hint`` asks (float, int, str, tuple of those, fixed or any length);
    a message naming ``key`` otherwise."""
    origin = typing.get_origin(hint)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"{key} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{key} must be finite, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{key} must be a whole number, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str) or not value:
            raise TypeError(f"{key} must be a non-empty string, got {value!r}")
        return value
    if origin is tuple:
        args = typing.get_args(hint)
        if not isinstance(value, list):
            raise TypeError(f"{key} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            if not value:
                raise ValueError(f"{key} must not be empty")
            return tuple(_convert(v, args[0], f"{key}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ValueError(f"{key} must have {len(args)} values, got {len(value)}")
        return tuple(_convert(v, a, f"{key}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    raise TypeError(f"{key}: unsupported type {hint}")


def _table(table, cls, prefix: str, names=None) -> dict:
    """The fields ``names`` (all of ``cls``'s when None) read from ``table``, converted; unknown and
    missing keys refused by name."""
    if not isinstance(table, dict):
        raise TypeError(f"{prefix} must be a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    wanted = [f.name for f in fields(cls) if names is None or f.name in names]
    unknown = sorted(set(table) - set(wanted))
    if unknown:
        raise KeyError(f"{prefix}.{unknown[0]} is not a key of [{prefix}] (its keys: {', '.join(wanted)})")
    out = {}
    for name in wanted:
        key = f"{prefix}.{name}"
        if name not in table:
            raise KeyError(f"{key} is missing")
        out[name] = _convert(table[name], hints[name], key)
    return out


def _tables(rows, cls, section: str) -> tuple:
    """An array of tables (``[[section]]``), each a ``cls``."""
    if not isinstance(rows, list) or not rows:
        raise TypeError(f"{section} must be one or more tables ([[{section}]])")
    return tuple(cls(**_table(r, cls, f"{section}[{i}]")) for i, r in enumerate(rows))


def geometry_from_dict(data: dict) -> AircraftGeometry:
    """An ``AircraftGeometry`` from a parsed description (module docstring); ``KeyError``,
    ``TypeError`` or ``ValueError`` naming the key otherwise. Physical checks: ``check``; plausibility (ratios
    between quantities, within what a UAV can be): ``plausible``."""
    unknown = sorted(set(data) - {*_TOP, *SECTIONS})
    if unknown:
        raise KeyError(f"{unknown[0]} is not a section of an aircraft description (its sections: "
                       f"{', '.join((*_TOP, *SECTIONS))})")
    flat: dict = {}
    for key in _TOP:
        if key not in data:
            raise KeyError(f"{key} is missing")
        flat[key] = _convert(data[key], str, key)
    if not flat["name"].isidentifier():
        raise ValueError(f"name must be letters, digits and underscores (a folder and a JSBSim name), "
                         f"got {flat['name']!r}")
    for section, names in SECTIONS.items():
        if section not in data:
            raise KeyError(f"[{section}] is missing")
        table = data[section]
        if section == "horizontal_tail" and isinstance(table, dict) and isinstance(table.get("incidence_deg"), str):
            if table["incidence_deg"] != TRIM_INCIDENCE:
                raise ValueError(f"horizontal_tail.incidence_deg must be a number (deg, nose-up positive) or "
                                 f"{TRIM_INCIDENCE!r} (the build solves the incidence that trims at the reference "
                                 f"EAS with the elevator at zero), got {table['incidence_deg']!r}")
            table = {**table, "incidence_deg": 0.0}  # the solve's first guess
            flat["solve_tail_incidence"] = True
        if section in _NESTED:
            flat[section] = _NESTED[section](**_table(table, _NESTED[section], section))
        elif section in _LISTS:
            flat[section] = _tables(data[section], _LISTS[section], section)
        else:
            flat.update(_table(data[section], AircraftGeometry, section, names))
    geometry = AircraftGeometry(**flat)
    check(geometry)
    plausible(geometry)
    return geometry


def _positive(value: float, key: str) -> None:
    if not value > 0.0:
        raise ValueError(f"{key} must be above 0, got {value}")


def check(g: AircraftGeometry) -> None:
    """Refuse what no aircraft can have (``ValueError`` naming the key): an envelope out of order,
    sizes, masses, inertias,
    lags and limits not above 0, fractions outside (0, 1), a planform whose tip chord the area
    makes zero or negative, ailerons beyond the tip, a static margin that is not stable, rotors
    turning neither way."""
    e = g.envelope
    low, high = e.altitude_range_m
    if not 0.0 <= low < high <= 30000.0:
        raise ValueError(f"envelope.altitude_range_m must be [low, high] with 0 <= low < high <= 30000 m, got "
                         f"{list(e.altitude_range_m)}")
    v_low, v_high = e.eas_range_mps
    if not 0.0 < v_low < v_high:
        raise ValueError(f"envelope.eas_range_mps must be [low, high] with 0 < low < high m/s, got "
                         f"{list(e.eas_range_mps)}")
    if not v_low <= e.reference_eas_mps <= v_high:
        raise ValueError(f"envelope.reference_eas_mps ({e.reference_eas_mps:g} m/s) must lie within "
                         f"envelope.eas_range_mps ({v_low:g} to {v_high:g} m/s)")
    r = g.randomisation
    for key, (start_low, start_high), (env_low, env_high), unit in (
            ("start_altitude_range_m", r.start_altitude_range_m, e.altitude_range_m, "m"),
            ("start_eas_range_mps", r.start_eas_range_mps, e.eas_range_mps, "m/s")):
        if not env_low <= start_low <= start_high <= env_high:
            raise ValueError(f"randomisation.{key} must be [low, high] with low <= high inside the envelope "
                             f"({env_low:g} to {env_high:g} {unit}), got {[start_low, start_high]}")
    re = e.reynolds
    if len(re) < 2 or re[0] <= 0.0 or any(b <= a for a, b in itertools.pairwise(re)):
        raise ValueError(f"envelope.reynolds must be two or more breakpoints above 0, increasing, got {list(re)}")
    if e.cruise_reynolds not in re:
        raise ValueError(f"envelope.cruise_reynolds ({e.cruise_reynolds:g}) must be one of envelope.reynolds")
    if not re[0] <= e.lattice_reynolds <= re[-1]:
        raise ValueError(f"envelope.lattice_reynolds ({e.lattice_reynolds:g}) must lie within envelope.reynolds "
                         f"({re[0]:g} to {re[-1]:g})")
    w = g.wing
    for name in ("span_m", "area_m2", "kink_y_m", "root_chord_m"):
        _positive(getattr(w, name), f"wing.{name}")
    if not w.kink_y_m < w.span_m / 2.0:
        raise ValueError(f"wing.kink_y_m ({w.kink_y_m} m) must lie inside the semi-span ({w.span_m / 2.0} m)")
    if not w.tip_chord_m > 0.0:
        raise ValueError(f"wing.area_m2 ({w.area_m2} m2) with wing.span_m, wing.kink_y_m and wing.root_chord_m "
                         f"gives a tip chord of {w.tip_chord_m:.3f} m: the area is too small for that planform")
    a = g.aileron
    if not 0.0 <= a.inner_y_m < a.outer_y_m <= w.span_m / 2.0:
        raise ValueError(f"aileron.inner_y_m and aileron.outer_y_m ({a.inner_y_m}, {a.outer_y_m} m) must run "
                         f"outwards within the semi-span ({w.span_m / 2.0} m)")
    if not 0.0 < a.chord_fraction < 1.0:
        raise ValueError(f"aileron.chord_fraction must lie in (0, 1), got {a.chord_fraction}")
    for tail in ("horizontal_tail", "vertical_tail"):
        t = getattr(g, tail)
        _positive(t.root_chord_m, f"{tail}.root_chord_m")
        _positive(t.tip_chord_m, f"{tail}.tip_chord_m")
        for name in ("control_chord_fraction", "efficiency"):
            if not 0.0 < getattr(t, name) <= 1.0:
                raise ValueError(f"{tail}.{name} must lie in (0, 1], got {getattr(t, name)}")
    for i, (_, radius) in enumerate(g.fuselage_stations_m):
        if radius < 0.0:
            raise ValueError(f"fuselage.fuselage_stations_m[{i}] has a negative radius {radius}")
    xs = [x for x, _ in g.fuselage_stations_m]
    if len(xs) < 2 or xs != sorted(xs) or len(set(xs)) < len(xs):
        raise ValueError("fuselage.fuselage_stations_m must be two or more (x, radius) stations in increasing x")
    for name in ("reference_area_m2", "reference_span_m", "reference_chord_m"):
        _positive(getattr(g, name), f"reference.{name}")
    _positive(g.mass_kg, "mass.mass_kg")
    ixx, iyy, izz, ixz = g.inertia_kg_m2
    for value, which in ((ixx, "Ixx"), (iyy, "Iyy"), (izz, "Izz")):
        _positive(value, f"mass.inertia_kg_m2 ({which})")
    if not (ixx + iyy >= izz and iyy + izz >= ixx and ixx + izz >= iyy and ixz * ixz < ixx * izz):
        raise ValueError(f"mass.inertia_kg_m2 {g.inertia_kg_m2} is no rigid body's inertia (each moment at most "
                         "the sum of the other two, Ixz^2 below Ixx Izz)")
    if not 0.0 < g.static_margin < 0.5:
        raise ValueError(f"mass.static_margin must lie in (0, 0.5) of the mean chord (a stable aircraft), "
                         f"got {g.static_margin}")
    p = g.propeller
    for name in ("diameter_m", "hub_diameter_m", "pitch_to_diameter", "chord_root_to_radius", "chord_max_to_radius",
                 "chord_tip_to_radius", "section_reynolds"):
        _positive(getattr(p, name), f"propeller.{name}")
    if not p.hub_diameter_m < p.diameter_m:
        raise ValueError(f"propeller.hub_diameter_m ({p.hub_diameter_m} m) must be below propeller.diameter_m")
    if p.blade_count < 2:
        raise ValueError(f"propeller.blade_count must be 2 or more, got {p.blade_count}")
    for i, r in enumerate(g.rotors):
        if r.sense not in (-1, 1):
            raise ValueError(f"rotors[{i}].sense must be +1 (clockwise seen from behind) or -1, got {r.sense}")
    for section, names in (("propulsion", SECTIONS["propulsion"]), ("actuators", SECTIONS["actuators"])):
        for name in names:
            _positive(getattr(g, name), f"{section}.{name}")
    if not g.motor_efficiency <= 1.0:
        raise ValueError(f"propulsion.motor_efficiency must lie in (0, 1], got {g.motor_efficiency}")
    for i, c in enumerate(g.contacts):
        if c.kind not in ("BOGEY", "STRUCTURE"):
            raise ValueError(f"contacts[{i}].kind must be BOGEY or STRUCTURE, got {c.kind!r}")
        for name in ("spring_n_per_m", "damping_n_s_per_m"):
            _positive(getattr(c, name), f"contacts[{i}].{name}")


# ---------------------------------------------------------------------------------- plausibility
# Limits on ratios between a description's quantities, beyond their signs: a well-typed value no
# UAV can have (an inertia of 1e9 kg m^2 on 12 kg, a 50 m propeller on a 5 m wing) is refused here,
# before the minutes of analysis, rather than built into a model that flies nonsense. Each limit
# holds the three example aircraft (aircraft/*.toml) with a wide margin.
G_MPS2 = 9.80665
SEA_LEVEL_DENSITY_KG_M3 = 1.225  # ISA: equivalent airspeed's dynamic pressure at every altitude
SEA_LEVEL_KINEMATIC_VISCOSITY_M2_S = 1.46e-5  # ISA, for the wing's Reynolds number at its reference EAS
# From a hand-launched model's 0.1 kg to a large HALE UAV's 20 t (a Global Hawk's 14.6 t).
MASS_RANGE_KG = (0.1, 20000.0)
# From a 0.3 m micro UAV to 100 m (Helios: 75 m); outside it the lattice's panels and the
# propeller's polars are of another kind of vehicle.
SPAN_RANGE_M = (0.3, 100.0)
# Aspect ratio b^2/S: a flying wing's 3 to a high-altitude glider's 40 (the examples: 15-17).
ASPECT_RATIO_RANGE = (3.0, 40.0)
# Weight over wing area, N/m^2: a solar HALE's 5-50 (the paper's 45) to a large jet UAV's 3,000
# (an MQ-9's 1,900).
WING_LOADING_RANGE_N_M2 = (5.0, 3000.0)
# The lift coefficient at the lowest EAS of the envelope (sea-level dynamic pressure: EAS): above
# 2.0, beyond the maximum of any wing without flaps, the aircraft cannot fly that slowly.
MAX_LIFT_COEFFICIENT = 2.0
# The highest EAS: the analysis (lattice, section polars, blade elements) is incompressible, good
# to Mach 0.3 (100 m/s at sea level).
MAX_EAS_MPS = 100.0
# envelope.cruise_reynolds against the wing's mean chord at the reference EAS at sea level
# (higher altitudes lower it): the section polars read there are another wing's when off by more.
REYNOLDS_FACTOR = 4.0
# Reference area, span and chord of the coefficients against the wing's (area, span, area/span):
# the coefficients are referred to the wing; a factor of 2 off is another aircraft's reference.
REFERENCE_FACTOR = 2.0
# Radius of gyration sqrt(I/m) over the aircraft's size (span for Ixx, length for Iyy, the larger
# for Izz): all the mass at the tips gives 0.5, a uniform rod 0.29; the examples 0.09-0.24. Below
# 0.03 the whole mass would sit at the centre of gravity.
GYRATION_FRACTION_RANGE = (0.03, 0.5)
# Outer-panel dihedral, wing twist and incidence, tail incidence (deg): beyond these the small-angle
# lattice is outside its validity, and no UAV flies them (the examples: 3-6 deg of dihedral).
MAX_DIHEDRAL_DEG = 20.0
MAX_TWIST_DEG = 10.0
MAX_INCIDENCE_DEG = 10.0
# The tails' quarter chord behind the wing's, in wing mean chords: a conventional tail acts behind
# the wing, 2-7 mean chords on UAVs and sailplanes (the examples: 3.9-4.9); nearer it sits in the
# wing's wake, farther no boom carries it.
TAIL_ARM_CHORDS_RANGE = (1.5, 15.0)
# A horizontal tail's half span, a fin's height, over the wing's semi-span (the examples: 0.15-0.26).
MAX_TAIL_SPAN_FRACTION = 0.5
# Tail volumes: horizontal S_h l_h / (S c), 0.3-0.6 on sailplanes and UAVs; vertical S_v l_v / (S b),
# 0.015-0.05 (the examples: 0.38-0.48 and 0.016-0.028).
HORIZONTAL_TAIL_VOLUME_RANGE = (0.1, 1.5)
VERTICAL_TAIL_VOLUME_RANGE = (0.005, 0.15)
# Every point of the description (fuselage stations, rotors, contacts, tails, the CG height) within
# one span of the wing root's leading edge, and the fuselage's radius within a fifth of the span:
# beyond, it is no aircraft whose wing carries it.
MAX_EXTENT_SPANS = 1.0
MAX_FUSELAGE_RADIUS_SPANS = 0.2
# Propeller diameter over the span: the examples' 0.06-0.18; at 0.4 a single nose propeller is
# already larger than any UAV's.
MAX_PROPELLER_SPAN_FRACTION = 0.4
# Blade count: the blade-element model's propellers, from 2 blades to 8 (a propfan's).
BLADE_COUNT_RANGE = (2, 8)
# Rotors: one to sixteen (Helios: 14 motors).
MAX_ROTORS = 16
# Blade tip speed at the rotor speed limit: beyond the speed of sound at sea level the
# incompressible blade elements are wrong (the examples: 157-207 m/s).
MAX_TIP_SPEED_MPS = 340.0
# A rotor's inertia over what its share of the aircraft's mass spread as a rod across the disc
# would give (mass (D/2)^2): the examples' 0.001-0.006; a rotor weighing most of the aircraft gives 0.3.
MAX_ROTOR_INERTIA_FRACTION = 0.05
# Shaft power of all motors per newton of weight: 1-12 W/N for the examples; below 0.2 no UAV flies
# level (weight times 6 m/s over a lift-to-drag ratio of 30), above 200 it is no motor its mass carries.
POWER_TO_WEIGHT_RANGE_W_N = (0.2, 200.0)
# Control surface travel, each way: beyond 45 deg a surface only stalls (the examples: 20-30 deg).
MAX_SURFACE_TRAVEL_DEG = 45.0
# Actuator lags: a servo slower than 1 s, a motor or its controller slower than 2 s, controls no
# aircraft; a servo faster than 2,000 deg/s is none that exists.
MAX_SURFACE_TIME_CONSTANT_S = 1.0
MAX_ROTOR_TIME_CONSTANT_S = 2.0
MAX_SURFACE_RATE_DEG_PER_S = 2000.0


def _within(value: float, limits: tuple[float, float], key: str, what: str, why: str) -> None:
    """``ValueError`` naming ``key`` unless ``limits[0] <= value <= limits[1]``."""
    low, high = limits
    if not low <= value <= high:
        raise ValueError(f"{key}: {what} is {value:.4g}, outside {low:g} to {high:g}: {why}")


def _tail_arm_m(t: TailSurface, wing_quarter_chord_x_m: float) -> float:
    """The tail's mean quarter chord behind the wing's, x, m."""
    le_x = (t.root_le_m[0] + t.tip_le_m[0]) / 2.0
    return le_x + (t.root_chord_m + t.tip_chord_m) / 8.0 - wing_quarter_chord_x_m


def plausible(g: AircraftGeometry) -> None:
    """Refuse (``ValueError`` naming the key and the reason) a description that ``check`` lets
    through but no UAV can be: ratios between its quantities outside the limits above."""
    w, e, p = g.wing, g.envelope, g.propeller
    _within(g.mass_kg, MASS_RANGE_KG, "mass.mass_kg", "the mass (kg)", "no UAV weighs that")
    _within(w.span_m, SPAN_RANGE_M, "wing.span_m", "the span (m)", "no UAV the analysis models has that span")
    _within(w.span_m ** 2 / w.area_m2, ASPECT_RATIO_RANGE, "wing.area_m2", "the aspect ratio span^2/area",
            "no wing of a UAV")
    mean_chord = w.area_m2 / w.span_m
    semi_span = w.span_m / 2.0
    loading = g.mass_kg * G_MPS2 / w.area_m2
    _within(loading, WING_LOADING_RANGE_N_M2, "mass.mass_kg", "the wing loading mass x g / wing.area_m2 (N/m^2)",
            "no UAV's wing carries that")
    v_low, v_high = e.eas_range_mps
    cl_low = 2.0 * g.mass_kg * G_MPS2 / (SEA_LEVEL_DENSITY_KG_M3 * v_low ** 2 * w.area_m2)
    if cl_low > MAX_LIFT_COEFFICIENT:
        raise ValueError(f"envelope.eas_range_mps: level flight at its lowest EAS ({v_low:g} m/s) needs a lift "
                         f"coefficient of {cl_low:.2f}, above {MAX_LIFT_COEFFICIENT:g}, the most a wing without flaps "
                         "gives: raise the lowest EAS or the wing area")
    if v_high > MAX_EAS_MPS:
        raise ValueError(f"envelope.eas_range_mps: its highest EAS ({v_high:g} m/s) is above {MAX_EAS_MPS:g} m/s, "
                         "where the incompressible analysis ends (Mach 0.3)")
    reynolds = e.reference_eas_mps * mean_chord / SEA_LEVEL_KINEMATIC_VISCOSITY_M2_S
    _within(e.cruise_reynolds / reynolds, (1.0 / REYNOLDS_FACTOR, REYNOLDS_FACTOR), "envelope.cruise_reynolds",
            f"its ratio to the wing's Reynolds number at the reference EAS at sea level ({reynolds:.3g})",
            "the section polars read there would be another wing's")
    for name, wing_value in (("reference_area_m2", w.area_m2), ("reference_span_m", w.span_m),
                             ("reference_chord_m", mean_chord)):
        _within(getattr(g, name) / wing_value, (1.0 / REFERENCE_FACTOR, REFERENCE_FACTOR), f"reference.{name}",
                f"its ratio to the wing's ({wing_value:.4g})", "the coefficients are referred to the wing")
    for key, value, limit in (("wing.outer_dihedral_deg", w.outer_dihedral_deg, MAX_DIHEDRAL_DEG),
                              ("wing.tip_twist_deg", w.tip_twist_deg, MAX_TWIST_DEG),
                              ("wing.incidence_deg", w.incidence_deg, MAX_INCIDENCE_DEG),
                              ("horizontal_tail.incidence_deg",
                               0.0 if g.solve_tail_incidence else g.horizontal_tail.incidence_deg, MAX_INCIDENCE_DEG),
                              ("vertical_tail.incidence_deg", g.vertical_tail.incidence_deg, MAX_INCIDENCE_DEG)):
        _within(value, (-limit, limit), key, "the angle (deg)", "no UAV's, and outside the small angles the lattice "
                "models")
    # The tails: behind the wing, of a size the wing can trim.
    wing_quarter_chord_x_m = w.root_chord_m / 4.0  # the quarter-chord line is unswept
    ht, vt = g.horizontal_tail, g.vertical_tail
    for tail, t in (("horizontal_tail", ht), ("vertical_tail", vt)):
        arm = _tail_arm_m(t, wing_quarter_chord_x_m)
        _within(arm / mean_chord, TAIL_ARM_CHORDS_RANGE, f"{tail}.root_le_m",
                f"the tail's quarter chord behind the wing's ({arm:.3g} m), in wing mean chords ({mean_chord:.3g} m),",
                "a tail ahead of the wing or in its wake does not act as one, and no boom carries one farther")
    ht_span = ht.tip_le_m[1] - ht.root_le_m[1]
    vt_height = vt.tip_le_m[2] - vt.root_le_m[2]
    for key, value, what in (("horizontal_tail.tip_le_m", ht_span, "the half span (tip y - root y, m)"),
                             ("vertical_tail.tip_le_m", vt_height, "the height (tip z - root z, m)")):
        if not value > 0.0:
            raise ValueError(f"{key}: {what} is {value:.4g}: the tip must lie outboard of (above) the root")
        _within(value / semi_span, (0.0, MAX_TAIL_SPAN_FRACTION), key, f"{what} over the wing's semi-span",
                "a tail that large is a second wing")
    ht_volume = (2.0 * ht_span * (ht.root_chord_m + ht.tip_chord_m) / 2.0 * _tail_arm_m(ht, wing_quarter_chord_x_m)
                 / (w.area_m2 * mean_chord))
    _within(ht_volume, HORIZONTAL_TAIL_VOLUME_RANGE, "horizontal_tail (its chords, half span and arm)",
            "the horizontal tail volume (area x arm / (wing area x mean chord))",
            "too small a tail cannot trim the aircraft, too large one is a second wing")
    vt_volume = (vt_height * (vt.root_chord_m + vt.tip_chord_m) / 2.0 * _tail_arm_m(vt, wing_quarter_chord_x_m)
                 / (w.area_m2 * w.span_m))
    _within(vt_volume, VERTICAL_TAIL_VOLUME_RANGE, "vertical_tail (its chords, height and arm)",
            "the vertical tail volume (area x arm / (wing area x span))",
            "too small a fin gives no directional stability, too large one is no UAV's")
    # Where things are: within the aircraft's size.
    reach = MAX_EXTENT_SPANS * w.span_m
    points = [(f"fuselage.fuselage_stations_m[{i}]", (x, 0.0, 0.0)) for i, (x, _) in enumerate(g.fuselage_stations_m)]
    points += [(f"{tail}.{end}", getattr(getattr(g, tail), end)) for tail in ("horizontal_tail", "vertical_tail")
               for end in ("root_le_m", "tip_le_m")]
    points += [(f"rotors[{i}].position_m", r.position_m) for i, r in enumerate(g.rotors)]
    points += [(f"contacts[{i}].position_m", c.position_m) for i, c in enumerate(g.contacts)]
    points.append(("mass.cg_z_m", (0.0, 0.0, g.cg_z_m)))
    for key, xyz in points:
        distance = math.sqrt(sum(v * v for v in xyz))
        if distance > reach:
            raise ValueError(f"{key}: {distance:.4g} m from the wing root's leading edge, more than "
                             f"{MAX_EXTENT_SPANS:g} span ({reach:.4g} m): no part of an aircraft lies that far out")
    for i, (_, radius) in enumerate(g.fuselage_stations_m):
        _within(radius / w.span_m, (0.0, MAX_FUSELAGE_RADIUS_SPANS), f"fuselage.fuselage_stations_m[{i}]",
                "the radius over the span", "a fuselage that wide is no wing-borne aircraft's")
    # Mass distribution: radii of gyration within the aircraft's size.
    xs = [x for x, _ in g.fuselage_stations_m] + [r.position_m[0] for r in g.rotors]
    xs += [t.root_le_m[0] + t.root_chord_m for t in (ht, vt)] + [t.tip_le_m[0] + t.tip_chord_m for t in (ht, vt)]
    length = max(max(xs) - min(xs), w.root_chord_m)
    ixx, iyy, izz, _ = g.inertia_kg_m2
    for which, inertia, size, size_name in (("Ixx", ixx, w.span_m, "the span"), ("Iyy", iyy, length, "the length"),
                                            ("Izz", izz, max(w.span_m, length), "the larger of span and length")):
        gyration = math.sqrt(inertia / g.mass_kg)
        _within(gyration / size, GYRATION_FRACTION_RANGE, f"mass.inertia_kg_m2 ({which})",
                f"the radius of gyration sqrt({which}/mass) = {gyration:.3g} m over {size_name} ({size:.3g} m)",
                "no mass spread over this aircraft gives that inertia")
    # Propulsion.
    if not 1 <= len(g.rotors) <= MAX_ROTORS:
        raise ValueError(f"rotors: {len(g.rotors)} rotors, more than {MAX_ROTORS}: no UAV has that many")
    _within(p.diameter_m / w.span_m, (0.0, MAX_PROPELLER_SPAN_FRACTION), "propeller.diameter_m",
            "the propeller diameter over the span", "no UAV's wing carries a propeller that large")
    _within(p.blade_count, BLADE_COUNT_RANGE, "propeller.blade_count", "the blade count",
            "the blade-element model's propellers have 2 to 8 blades")
    tip_speed = math.pi * p.diameter_m * g.max_rotor_speed_rpm / 60.0
    _within(tip_speed, (0.0, MAX_TIP_SPEED_MPS), "propulsion.max_rotor_speed_rpm",
            "the blade tip speed at the rotor speed limit (m/s)", "a supersonic tip is outside the blade-element model")
    rotor_mass_share = g.mass_kg / len(g.rotors) * (p.diameter_m / 2.0) ** 2
    _within(g.rotor_inertia_kg_m2 / rotor_mass_share, (0.0, MAX_ROTOR_INERTIA_FRACTION),
            "propulsion.rotor_inertia_kg_m2",
            "the rotor inertia over (the aircraft's mass per rotor) x (propeller radius)^2",
            "a rotor that heavy would weigh more than the aircraft carries")
    power = len(g.rotors) * g.motor_max_power_w / (g.mass_kg * G_MPS2)
    _within(power, POWER_TO_WEIGHT_RANGE_W_N, "propulsion.motor_max_power_w",
            "the shaft power of all motors per newton of weight (W/N)",
            "too little flies no UAV level, too much is no motor its mass carries")
    # Controls.
    for name in ("aileron_limit_deg", "elevator_limit_deg", "rudder_limit_deg"):
        _within(getattr(g, name), (0.0, MAX_SURFACE_TRAVEL_DEG), f"actuators.{name}", "the travel each way (deg)",
                "beyond it a control surface only stalls")
    _within(g.surface_time_constant_s, (0.0, MAX_SURFACE_TIME_CONSTANT_S), "actuators.surface_time_constant_s",
            "the servo lag (s)", "a servo that slow controls no aircraft")
    _within(g.surface_rate_limit_deg_per_s, (0.0, MAX_SURFACE_RATE_DEG_PER_S), "actuators.surface_rate_limit_deg_per_s",
            "the servo rate (deg/s)", "no servo moves a surface that fast")
    for name in ("esc_time_constant_s", "rotor_time_constant_s"):
        _within(getattr(g, name), (0.0, MAX_ROTOR_TIME_CONSTANT_S), f"propulsion.{name}", "the lag (s)",
                "a motor that slow controls no aircraft")


def load_description(path: Path | str) -> AircraftGeometry:
    """The aircraft described by the TOML file at ``path``; a ``DescriptionError`` naming the file
    and the key where the file cannot describe one."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as err:
        raise DescriptionError(f"{path}: cannot read the aircraft description: {err.strerror or err}") from err
    except tomllib.TOMLDecodeError as err:
        raise DescriptionError(f"{path}: not a TOML file: {err}") from err
    try:
        return geometry_from_dict(data)
    except (KeyError, TypeError, ValueError) as err:
        message = err.args[0] if isinstance(err, KeyError) and err.args else str(err)
        raise DescriptionError(f"{path}: {message}") from err


__all__ = ["PAPER_AIRCRAFT", "SECTIONS", "TRIM_INCIDENCE", "DescriptionError", "check", "geometry_from_dict",
           "load_description", "plausible"]

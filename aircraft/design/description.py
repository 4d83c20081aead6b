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
    ``TypeError`` or ``ValueError`` naming the key otherwise. Physical checks: ``check``."""
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


__all__ = ["PAPER_AIRCRAFT", "SECTIONS", "TRIM_INCIDENCE", "DescriptionError", "check", "geometry_from_dict", "load_description"]

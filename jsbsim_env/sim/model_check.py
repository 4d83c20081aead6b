"""Checks that a loaded aircraft has what the environment relies on, before it flies.

JSBSim accepts an aircraft with elements missing and flies it wrongly: a missing ``<wingarea>``,
``<wingspan>`` or ``<chord>`` reads as 0 (no aerodynamic force or moment), a missing ``<emptywt>``
as a zero mass (JSBSim then divides by zero on every step), a missing ``<ixx>`` as a zero moment of
inertia, a missing coefficient function as a zero term. A ``<function>`` that reads a property
nobody declares loads, then throws on the first initial-condition pass and again when JSBSim
unties its properties on destruction, which aborts the process.

The required terms are the ones the environment writes scales to (``SCALED_TERMS``), taken from
the generator's list, so that a term added there is required here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from aircraft.jsbsim_format import INERTIA_SCALE, TERMS

COEFFICIENT_TERMS = tuple(TERMS)  # each is a function aero/coefficient/<term>
SCALED_TERMS = (*TERMS, INERTIA_SCALE)  # each is a property aero/scale/<term> written per episode
REQUIRED_PROPERTIES = (*(f"aero/scale/{term}" for term in SCALED_TERMS),
                       *(f"aero/coefficient/{term}" for term in COEFFICIENT_TERMS))

# Reference area and lengths: JSBSim property, element of the metrics section, JSBSim's unit.
METRICS = (("metrics/Sw-sqft", "wingarea", "ft2"), ("metrics/bw-ft", "wingspan", "ft"),
           ("metrics/cbarw-ft", "chord", "ft"))


class ModelError(RuntimeError):
    """The aircraft files could not be loaded, or lack what the environment needs."""


def validate_loaded_model(fdm, aircraft_file: Path) -> None:
    """Check a model right after ``FGFDMExec.load_model`` and run its first initial-condition pass.

    Checks: wing area, span and chord positive; mass positive; the inertia tensor's principal
    moments positive and satisfying the triangle inequality; ``aero/scale/<term>`` for every
    term in ``SCALED_TERMS`` and ``aero/coefficient/<term>`` for every aerodynamic term present.
    The inertia tensor exists only after JSBSim's first initial-condition pass, so this function
    runs it (when the mass allows it) and leaves the model initialised.

    Raises:
        ModelError: naming every missing or wrong item, with the file it belongs in.
    """
    pm = fdm.get_property_manager()
    missing = [name for name in REQUIRED_PROPERTIES if not pm.hasNode(name)]
    # Declare what is missing: a function reading an undeclared property throws on the
    # initial-condition pass and from JSBSim's destructor, which aborts the process.
    for name in missing:
        pm.get_node(name, True)
    problems = _metric_problems(fdm)
    mass_slugs = fdm["inertia/mass-slugs"]
    if mass_slugs > 0.0:
        if fdm.run_ic():
            problems += [("mass_balance", text) for text in _inertia_problems(fdm)]
        else:
            problems.append(("top", "JSBSim's initial-condition pass failed"))
    else:
        # With no mass JSBSim divides by zero throughout the pass: the inertia goes unchecked.
        text = f"the mass (<emptywt> plus point masses, inertia/mass-slugs) is {_zero_or(mass_slugs, 'slug')}"
        problems.append(("mass_balance", f"{text}; the inertia was not checked"))
    coefficients = [p for p in missing if p.startswith("aero/coefficient/")]
    scales = [p for p in missing if p not in coefficients]
    if coefficients:
        problems.append(("aerodynamics", f"no function {', '.join(coefficients)}"))
    if scales:
        problems.append(("scaling", f"no property {', '.join(scales)}"))
    if problems:
        files = _section_files(aircraft_file)
        raise ModelError(f"aircraft {aircraft_file} has missing or wrong data:\n  "
                         + "\n  ".join(f"{files[section]}: {text}" for section, text in problems))


def _zero_or(value: float, unit: str, tolerance: float = 0.0) -> str:
    if abs(value) <= tolerance:
        return "0 or missing (JSBSim reads a missing element as 0)"
    return f"{value:g} {unit}, must be positive"


def _metric_problems(fdm) -> list[tuple[str, str]]:
    return [("metrics", f"<{element}> ({prop}) is {_zero_or(fdm[prop], unit)}")
            for prop, element, unit in METRICS if not fdm[prop] > 0.0]


def _inertia_problems(fdm) -> list[str]:
    # JSBSim's inertia tensor (slug ft2) from its properties: cheaper than get_J(), the same numbers.
    xx, yy, zz, xy, xz, yz = (fdm[f"inertia/i{axes}-slugs_ft2"] for axes in ("xx", "yy", "zz", "xy", "xz", "yz"))
    tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    # A missing moment reads as round-off (1e-30) after JSBSim moves the tensor to the CG.
    tolerance = 1e-9 * float(np.max(np.abs(np.diag(tensor))))
    problems = [f"<i{a}{a}> (inertia/i{a}{a}-slugs_ft2) is {_zero_or(tensor[k, k], 'slug ft2', tolerance)}"
                for k, a in enumerate("xyz") if not tensor[k, k] > tolerance]
    if problems:
        return problems
    principal = np.linalg.eigvalsh(tensor)  # ascending
    if not principal[0] > 0.0:
        problems.append(f"the inertia tensor is not positive definite (principal moments {_list(principal)} slug ft2)")
    elif principal[2] > (principal[0] + principal[1]) * (1.0 + 1e-9):
        # A rigid body's largest principal moment is at most the sum of the other two.
        problems.append(f"the principal moments of inertia ({_list(principal)} slug ft2) break the triangle "
                        "inequality: no rigid body has them")
    return problems


def _list(values) -> str:
    return ", ".join(f"{v:.6g}" for v in values)


def _section_files(aircraft_file: Path) -> dict[str, str]:
    """Where the top file puts its metrics, mass balance, aerodynamics and the scale properties."""
    top = aircraft_file.name
    files = {"top": top, "metrics": top, "mass_balance": top, "aerodynamics": top,
             "scaling": f"{top} (no <system> file declares aero/scale/)"}
    try:
        root = ET.parse(aircraft_file).getroot()
    except (OSError, ET.ParseError):
        return files
    folder = aircraft_file.parent
    for section in ("metrics", "mass_balance", "aerodynamics"):
        element = root.find(section)
        if element is not None and element.get("file"):
            files[section] = _resolve(folder, element.get("file")).relative_to(folder).as_posix()
    for element in root.findall("system"):
        path = _resolve(folder, element.get("file", ""))
        if path.is_file() and "aero/scale/" in path.read_text(errors="replace"):
            files["scaling"] = path.relative_to(folder).as_posix()
            break
    return files


def _resolve(folder: Path, name: str) -> Path:
    """A file named in the top file, found where JSBSim looks for it (``Systems/`` for systems)."""
    stem = name if name.endswith(".xml") else f"{name}.xml"
    for candidate in (folder / stem, folder / "Systems" / stem):
        if candidate.is_file():
            return candidate
    return folder / stem

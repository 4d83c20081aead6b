"""Load-time checks of the aircraft: a model with missing or wrong data is refused with a clear error."""

from __future__ import annotations

import gc
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import aircraft
from jsbsim_env.sim.model_check import COEFFICIENT_TERMS, SCALED_TERMS
from jsbsim_env.sim.simulation import ModelError, Simulation

# Any term will do; taken from the list so that the test follows the generator's names.
TERM = COEFFICIENT_TERMS[-1]


def _copy_aircraft(tmp_path: Path) -> Path:
    root = tmp_path / "root"
    shutil.copytree(aircraft.aircraft_dir(), root / "aircraft" / aircraft.AIRCRAFT_NAME)
    return root


def _remove(root: Path, rel: str, matches) -> None:
    """Remove every element of ``<aircraft>/rel`` for which ``matches(element)`` holds."""
    path = root / "aircraft" / aircraft.AIRCRAFT_NAME / rel
    tree = ET.parse(path)
    removed = 0
    for parent in tree.iter():
        for child in [c for c in parent if matches(c)]:
            parent.remove(child)
            removed += 1
    assert removed, f"nothing to remove in {rel}"
    tree.write(path)


def _tag(name):
    return lambda e: e.tag == name


def _named_function(name):
    return lambda e: e.tag == "function" and e.get("name") == name


def _declared_property(name):
    # The declaration (a <property> with a value attribute), not the references inside functions.
    return lambda e: e.tag == "property" and e.get("value") is not None and (e.text or "").strip() == name


def _load_error(root: Path) -> str:
    with pytest.raises(ModelError) as err:
        Simulation(root)
    message = str(err.value)
    del err
    gc.collect()  # JSBSim destroys its instance here: a half-declared model must not abort the process
    return message


def test_the_shipped_aircraft_passes():
    sim = Simulation()
    assert sim["metrics/Sw-sqft"] > 0.0


@pytest.mark.parametrize("rel, matches, expected", [
    ("Metrics.xml", _tag("wingarea"), ("Metrics.xml", "<wingarea>", "metrics/Sw-sqft")),
    ("Metrics.xml", _tag("chord"), ("Metrics.xml", "<chord>", "metrics/cbarw-ft")),
    ("MassBalance.xml", _tag("emptywt"), ("MassBalance.xml", "<emptywt>", "inertia/mass-slugs")),
    ("MassBalance.xml", _tag("izz"), ("MassBalance.xml", "<izz>", "inertia/izz-slugs_ft2")),
    ("Aerodynamics.xml", _named_function(f"aero/coefficient/{TERM}"), ("Aerodynamics.xml", f"aero/coefficient/{TERM}")),
    ("Systems/scaling.xml", _declared_property(f"aero/scale/{TERM}"), ("Systems/scaling.xml", f"aero/scale/{TERM}")),
    ("Systems/scaling.xml", _declared_property(f"aero/scale/{SCALED_TERMS[-1]}"),
     ("Systems/scaling.xml", f"aero/scale/{SCALED_TERMS[-1]}")),
])
def test_a_missing_item_is_named_with_its_file(tmp_path, rel, matches, expected):
    root = _copy_aircraft(tmp_path)
    _remove(root, rel, matches)
    message = _load_error(root)
    for text in expected:
        assert text in message


def test_every_problem_is_named_at_once(tmp_path):
    root = _copy_aircraft(tmp_path)
    _remove(root, "Metrics.xml", _tag("wingspan"))
    _remove(root, "Aerodynamics.xml", _named_function(f"aero/coefficient/{TERM}"))
    _remove(root, "Systems/scaling.xml", _declared_property(f"aero/scale/{SCALED_TERMS[0]}"))
    message = _load_error(root)
    for text in ("<wingspan>", f"aero/coefficient/{TERM}", f"aero/scale/{SCALED_TERMS[0]}"):
        assert text in message


def test_inertia_that_no_rigid_body_has_is_refused(tmp_path):
    root = _copy_aircraft(tmp_path)
    path = root / "aircraft" / aircraft.AIRCRAFT_NAME / "MassBalance.xml"
    tree = ET.parse(path)
    ixx, iyy = (float(tree.find(n).text) for n in ("ixx", "iyy"))
    tree.find("izz").text = f" {1.5 * (ixx + iyy)} "
    tree.write(path)
    assert "triangle inequality" in _load_error(root)

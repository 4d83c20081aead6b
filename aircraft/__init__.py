"""The solar UAV as JSBSim data.

The folder that holds this package is a JSBSim root: JSBSim finds the aircraft at
``<root>/aircraft/solar_uav/solar_uav.xml``, its systems in ``aircraft/solar_uav/Systems`` and its
initial conditions as ``aircraft/solar_uav/reset*.xml``. In a checkout the root is the repository;
in an installed package it is the ``site-packages`` folder this package sits in.
"""

from __future__ import annotations

from pathlib import Path

AIRCRAFT_NAME = "solar_uav"
"""Name of the aircraft as JSBSim knows it (``<use aircraft="solar_uav" .../>``)."""


def jsbsim_root() -> Path:
    """Folder to hand to ``jsbsim.FGFDMExec(root_dir=...)`` or ``jsbsim --root``."""
    return Path(__file__).resolve().parent.parent


def aircraft_dir(name: str = AIRCRAFT_NAME) -> Path:
    """Folder of one aircraft's XML files."""
    return Path(__file__).resolve().parent / name


def reset_files(name: str = AIRCRAFT_NAME) -> list[str]:
    """Names (without ``.xml``) of the aircraft's initial-condition files, sorted."""
    return sorted(p.stem for p in aircraft_dir(name).glob("reset*.xml"))

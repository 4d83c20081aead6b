"""The solar UAV as JSBSim data.

The folder that holds this package is a JSBSim root: JSBSim finds the aircraft at
``<root>/aircraft/solar_uav/solar_uav.xml``, its systems in ``aircraft/solar_uav/Systems`` and its
initial conditions as ``aircraft/solar_uav/reset*.xml``. In a checkout the root is the repository;
in an installed package it is the ``site-packages`` folder this package sits in.
"""

from __future__ import annotations

import hashlib
import re
import xml.etree.ElementTree as ET
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


def model_fingerprint(name: str = AIRCRAFT_NAME, folder: Path | None = None) -> str:
    """SHA-256 of an aircraft's model: every XML file of its folder (``folder``, or the packaged
    aircraft ``name``) but the initial conditions, with its path relative to the folder, and
    without what only documents it (comments, the file header, the release status).

    Two aircraft with the same fingerprint fly alike; training records keep it, so that a
    controller can be told apart from the aircraft it was not trained on.
    """
    folder = Path(folder) if folder is not None else aircraft_dir(name)
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*.xml")):
        data = path.read_bytes()
        if ET.fromstring(data).tag == "initialize":  # where a flight starts, not how it flies
            continue
        digest.update(path.relative_to(folder).as_posix().encode() + b"\0" + _flying_part(data) + b"\0")
    return digest.hexdigest()


# What documents a model without changing how it flies: comments, the file header, and the
# release status of <fdm_config>.
_DOCUMENTATION = (re.compile(rb"<!--.*?-->", re.DOTALL), re.compile(rb"<fileheader>.*?</fileheader>", re.DOTALL),
                  re.compile(rb'(<fdm_config\b[^>]*?)\s+release="[^"]*"'))


def _flying_part(data: bytes) -> bytes:
    """An aircraft file without its documentation (``_DOCUMENTATION``), for the fingerprint."""
    comments, header, release = _DOCUMENTATION
    return release.sub(rb"\1", header.sub(b"", comments.sub(b"", data)))

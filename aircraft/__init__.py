"""The aircraft as JSBSim data: the paper's solar UAV, packaged, and any aircraft built from a description.

The folder that holds this package is a JSBSim root: JSBSim finds the aircraft at
``<root>/aircraft/solar_uav/solar_uav.xml``, its systems in ``aircraft/solar_uav/Systems`` and its
initial conditions as ``aircraft/solar_uav/reset*.xml``. In a checkout the root is the repository;
in an installed package it is the ``site-packages`` folder this package sits in.

An aircraft built by ``scripts/build_aircraft.py DESCRIPTION --out DIR`` has the same layout under
``DIR``. Every aircraft folder holds ``envelope.json``, where the aircraft flies (written by the
build from its description), which is all the run-time code needs beside the JSBSim files:
``load_aircraft`` reads a name or a path into an ``Aircraft``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

AIRCRAFT_NAME = "solar_uav"
"""Name of the paper's aircraft as JSBSim knows it (``<use aircraft="solar_uav" .../>``), the default."""
ENVELOPE_FILE = "envelope.json"
"""In every aircraft folder: where the aircraft flies (``Aircraft``), written by its build."""
SURFACES = ("aileron", "elevator", "rudder")
PAPER_ALTITUDE_RANGE_M = (0.0, 20000.0)  # the paper's aircraft's envelope, where its experiments fly
PAPER_SAMPLE_ALTITUDES_M = (1000.0, 10000.0, 20000.0)  # near its floor, its middle, its ceiling


def altitude_like_m(paper_altitude_m: float, altitude_range_m: tuple[float, float]) -> float:
    """The altitude at the fraction of ``altitude_range_m`` that ``paper_altitude_m`` is of the
    paper's 0-20 km: where an aircraft with that range flies what the paper's flies at
    ``paper_altitude_m`` (1, 10, 20 km: 5 % up, the middle, the ceiling); itself for the paper's range."""
    (p0, p1), (a0, a1) = PAPER_ALTITUDE_RANGE_M, altitude_range_m
    if (a0, a1) == (p0, p1):
        return paper_altitude_m
    return a0 + (paper_altitude_m - p0) / (p1 - p0) * (a1 - a0)


def jsbsim_root() -> Path:
    """Folder to hand to ``jsbsim.FGFDMExec(root_dir=...)`` or ``jsbsim --root``."""
    return Path(__file__).resolve().parent.parent


def aircraft_dir(name: str = AIRCRAFT_NAME) -> Path:
    """Folder of one aircraft's XML files."""
    return Path(__file__).resolve().parent / name


def reset_files(name: str = AIRCRAFT_NAME) -> list[str]:
    """Names (without ``.xml``) of the aircraft's initial-condition files, sorted."""
    return sorted(p.stem for p in aircraft_dir(name).glob("reset*.xml"))


class AircraftError(ValueError):
    """A name or path that is no built aircraft; the message says what it is and what to give."""


@dataclass(frozen=True)
class Aircraft:
    """A built aircraft as the run-time code flies it: its JSBSim root and name, and where it flies
    (its folder's ``envelope.json``).

    ``altitude_range_m`` and ``eas_range_mps`` are its flight envelope: where it is trimmed, and
    the EAS goals a task draws; ``start_altitude_range_m`` and ``start_eas_range_mps`` are where a
    training episode starts; ``surface_limits_deg`` the aileron's, elevator's and rudder's travel.
    """

    root: Path
    name: str
    altitude_range_m: tuple[float, float]
    eas_range_mps: tuple[float, float]
    reference_eas_mps: float
    start_altitude_range_m: tuple[float, float]
    start_eas_range_mps: tuple[float, float]
    surface_limits_deg: tuple[float, float, float]  # aileron, elevator, rudder

    @property
    def folder(self) -> Path:
        return self.root / "aircraft" / self.name

    @property
    def command_low(self) -> tuple[float, float, float, float]:
        """The lowest command: aileron, elevator, rudder at their travel (deg), throttle 0."""
        aileron, elevator, rudder = self.surface_limits_deg
        return (-aileron, -elevator, -rudder, 0.0)

    @property
    def command_high(self) -> tuple[float, float, float, float]:
        """The highest command: aileron, elevator, rudder at their travel (deg), throttle 1."""
        aileron, elevator, rudder = self.surface_limits_deg
        return (aileron, elevator, rudder, 1.0)

    @property
    def packaged(self) -> bool:
        """Whether this is an aircraft that ships with the package (the paper's)."""
        return self.root == jsbsim_root()

    @property
    def papers(self) -> bool:
        """Whether this is the paper's aircraft as it ships (its experiments, figures and gain tables)."""
        return self.packaged and self.name == AIRCRAFT_NAME

    @functools.cached_property
    def fingerprint(self) -> str:
        """``model_fingerprint`` of its folder: what tells one aircraft from another."""
        return model_fingerprint(folder=self.folder)

    def matches_model(self, recorded: str) -> bool:
        """Whether ``recorded``, a fingerprint a training record or policy file keeps, is this
        aircraft's. A record made before the envelope joined the fingerprint keeps the XML files'
        alone (``model_fingerprint(envelope=False)``): it matches an aircraft with the same XML
        files, and cannot tell an edited envelope (a new record can)."""
        return recorded == self.fingerprint or recorded == model_fingerprint(folder=self.folder, envelope=False)

    @property
    def sample_altitudes_m(self) -> tuple[float, float, float]:
        """Three altitudes that span the envelope: 5 % up from its floor, its middle, its ceiling
        (the paper's aircraft's 1, 10 and 20 km)."""
        return tuple(self.altitude_like_m(h) for h in PAPER_SAMPLE_ALTITUDES_M)

    def altitude_like_m(self, paper_altitude_m: float) -> float:
        """Where this aircraft flies an experiment the paper's flies at ``paper_altitude_m``
        (``altitude_like_m``)."""
        return altitude_like_m(paper_altitude_m, self.altitude_range_m)

    @property
    def spec(self) -> str:
        """What ``load_aircraft`` reads back as this aircraft from any working folder: its name if
        packaged, else its folder's absolute path."""
        return self.name if self.packaged else str(self.folder)

    def describe(self) -> str:
        """One line: the name, and the folder for an aircraft that does not ship with the package."""
        return self.name if self.packaged else f"{self.name} ({self.folder})"


def _aircraft_folder(spec: str) -> Path:
    """The aircraft folder that ``spec`` (a packaged name, an aircraft folder, or a JSBSim root
    holding one aircraft) names; ``AircraftError`` otherwise."""
    path = Path(spec).expanduser()
    packaged = sorted(p.parent.name for p in Path(__file__).resolve().parent.glob(f"*/{ENVELOPE_FILE}"))
    if spec in packaged:  # a name first: a folder of the same name in the working folder is not asked for
        return aircraft_dir(spec)
    if not path.exists():
        raise AircraftError(f"aircraft {spec!r} is neither a packaged aircraft ({', '.join(packaged)}) nor a path "
                            "that exists: give a folder built by scripts/build_aircraft.py DESCRIPTION --out DIR")
    if path.is_file():
        if path.suffix == ".toml":
            raise AircraftError(f"aircraft {spec!r} is a description, not a built aircraft: build it with "
                                f"`python scripts/build_aircraft.py {spec} --out DIR`, then give DIR")
        raise AircraftError(f"aircraft {spec!r} is a file: give the folder scripts/build_aircraft.py --out built")
    path = path.resolve()
    if (path / ENVELOPE_FILE).is_file():
        return path
    found = sorted(p.parent for p in path.glob(f"aircraft/*/{ENVELOPE_FILE}"))
    if len(found) == 1:
        return found[0]
    if found:
        raise AircraftError(f"{spec} holds {len(found)} aircraft ({', '.join(p.name for p in found)}): give one "
                            f"of their folders, such as {found[0]}")
    raise AircraftError(f"{spec} holds no built aircraft (no {ENVELOPE_FILE} in it or in aircraft/*/ under it): "
                        "give a folder built by scripts/build_aircraft.py DESCRIPTION --out DIR")


def _range(record: dict, key: str, where: Path) -> tuple[float, float]:
    value = record.get(key)
    if (not isinstance(value, list) or len(value) != 2 or not all(isinstance(v, (int, float)) for v in value)
            or not all(math.isfinite(v) for v in value) or not value[0] <= value[1]):
        raise AircraftError(f"{where}: {key} must be [low, high] in order, got {value!r}; build the aircraft again")
    return float(value[0]), float(value[1])


@functools.cache
def _load(folder: Path) -> Aircraft:
    where = folder / ENVELOPE_FILE
    if folder.parent.name != "aircraft":
        raise AircraftError(f"{folder} is not in a JSBSim root's aircraft/ folder, where JSBSim looks for it")
    if not (folder / f"{folder.name}.xml").is_file():
        raise AircraftError(f"{folder} has no {folder.name}.xml, the aircraft's JSBSim file; build it again")
    try:
        record = json.loads(where.read_text())
        limits = record["surface_limits_deg"]
        surfaces = tuple(float(limits[s]) for s in SURFACES)
        reference = float(record["reference_eas_mps"])
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise AircraftError(f"{where} cannot be read ({type(err).__name__}: {err}); build the aircraft again") from err
    if not all(0.0 < x < math.inf for x in surfaces):
        raise AircraftError(f"{where}: surface_limits_deg must be above 0, got {surfaces}; build the aircraft again")
    return Aircraft(root=folder.parent.parent, name=folder.name,
                    altitude_range_m=_range(record, "altitude_range_m", where),
                    eas_range_mps=_range(record, "eas_range_mps", where), reference_eas_mps=reference,
                    start_altitude_range_m=_range(record, "start_altitude_range_m", where),
                    start_eas_range_mps=_range(record, "start_eas_range_mps", where), surface_limits_deg=surfaces)


def load_aircraft(spec: str | Path | Aircraft | None = None) -> Aircraft:
    """The aircraft ``spec`` names: ``None`` or ``"solar_uav"`` for the paper's; the name of another
    packaged aircraft; the folder of a built aircraft (``DIR/aircraft/<name>``), or the JSBSim root
    ``DIR`` that ``scripts/build_aircraft.py --out DIR`` built one aircraft into. An
    ``AircraftError`` says what ``spec`` is instead (a description file not yet built, a folder
    with no aircraft or several)."""
    if isinstance(spec, Aircraft):
        return spec
    if spec is None:
        spec = AIRCRAFT_NAME
    if not isinstance(spec, (str, Path)) or not str(spec):
        raise AircraftError(f"aircraft must be a name or a path, got {spec!r}")
    return _load(_aircraft_folder(str(spec)))


def model_fingerprint(name: str = AIRCRAFT_NAME, folder: Path | None = None, envelope: bool = True) -> str:
    """SHA-256 of an aircraft's model: every XML file of its folder (``folder``, or the packaged
    aircraft ``name``) but the initial conditions, with its path relative to the folder, and
    without what only documents it (comments, the file header, the release status); then, unless
    not ``envelope``, where it flies (``ENVELOPE_FILE``'s values, without its ``about`` line):
    its altitude and EAS ranges and surface travel decide what it is trained and flown in.

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
    where = folder / ENVELOPE_FILE
    if envelope and where.is_file():
        try:
            values = json.loads(where.read_text())
        except ValueError:  # unreadable: its bytes, which ``load_aircraft`` refuses anyway
            values = where.read_bytes().decode("latin-1")
        if isinstance(values, dict):
            values = {k: v for k, v in values.items() if k != "about"}
        digest.update(ENVELOPE_FILE.encode() + b"\0" + json.dumps(values, sort_keys=True).encode() + b"\0")
    return digest.hexdigest()


# What documents a model without changing how it flies: comments, the file header, and the
# release status of <fdm_config>.
_DOCUMENTATION = (re.compile(rb"<!--.*?-->", re.DOTALL), re.compile(rb"<fileheader>.*?</fileheader>", re.DOTALL),
                  re.compile(rb'(<fdm_config\b[^>]*?)\s+release="[^"]*"'))


def _flying_part(data: bytes) -> bytes:
    """An aircraft file without its documentation (``_DOCUMENTATION``), for the fingerprint."""
    comments, header, release = _DOCUMENTATION
    return release.sub(rb"\1", header.sub(b"", comments.sub(b"", data)))

"""Build an aircraft from its description file: aerodynamic data from the geometry, then the JSBSim files.

``python scripts/build_aircraft.py`` builds the paper's aircraft (``aircraft/solar_uav.toml``)
into the package (needs the ``aero`` extra); ``python scripts/build_aircraft.py my_uav.toml --out
DIR`` builds another into ``DIR``, a JSBSim root: ``DIR/aircraft/<name>/`` holds its files and
``DIR/aero_data.json`` its aerodynamic data set. ``--from-data`` rewrites the XML from the saved
data set only. The script then surveys the built model (``jsbsim_env.analysis.survey``).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

from .. import jsbsim_root
from . import aero_data, analysis, xml_writer
from .description import PAPER_AIRCRAFT, SECTIONS, DescriptionError, load_description
from .geometry import AircraftGeometry


class BuildError(ValueError):
    """A build that cannot run: the message is one line, naming what to change."""


STAGING_PREFIX = ".building_"  # the temporary folder a build writes into, beside its destination
DATA_FILE = "aero_data.json"  # in a built JSBSim root: the aerodynamic data set
# What a build writes at the top of a JSBSim root (``--out DIR``): the data set, the aircraft's
# folder, the standalone runs and the report. ``--from-data`` rewrites a folder holding only these.
BUILT_ENTRIES = (DATA_FILE, "aircraft", "scripts", "build_report.md")


@dataclass(frozen=True)
class Built:
    """What a build wrote: the aircraft, its data set, its JSBSim root and folder."""

    geometry: AircraftGeometry
    data: dict
    data_path: Path
    root: Path  # a JSBSim root: the aircraft's files are in root/aircraft/<name>/
    folder: Path


@dataclass(frozen=True)
class Target:
    """A build checked before any work (``prepare``): the aircraft, where it goes, and with
    ``--from-data`` the saved data set it is written from."""

    description: Path
    geometry: AircraftGeometry
    out: Path | None  # None: the package's own aircraft
    data: dict | None  # the saved data set (--from-data), else None: the analysis computes it

    @property
    def root(self) -> Path:
        """The JSBSim root the aircraft ends up in."""
        return self.out if self.out is not None else jsbsim_root()

    @property
    def data_path(self) -> Path:
        return self.out / DATA_FILE if self.out is not None else aero_data.DATA_PATH

    @property
    def folder(self) -> Path:
        return self.root / "aircraft" / self.geometry.name


def build_parser(description: str = __doc__) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter,
                                     allow_abbrev=False)
    parser.add_argument("description", nargs="?", type=Path, default=PAPER_AIRCRAFT,
                        help="the aircraft's description file (TOML; docs/aircraft.md); the paper's aircraft when "
                             "omitted")
    parser.add_argument("--out", type=Path, default=None,
                        help="a new or empty folder to build into (a JSBSim root: DIR/aircraft/<name>/); the "
                             "package's own aircraft folder when omitted, which only the package's own description "
                             "(aircraft/solar_uav.toml) may use")
    parser.add_argument("--from-data", action="store_true",
                        help="skip the aerodynamic analysis and write the XML from the saved data set (in the folder "
                             "of an earlier build of the same description)")
    return parser


def _is_packaged_description(path: Path) -> bool:
    try:
        return Path(path).resolve() == PAPER_AIRCRAFT.resolve()
    except OSError:
        return False


def _names(paths) -> str:
    names = sorted(p.name for p in paths)
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _description_key(parts: list) -> str:
    """A field path of ``AircraftGeometry`` (``["mass_kg"]``, ``["rotors", 0, "sense"]``) as the
    description's key (``mass.mass_kg``, ``rotors[0].sense``)."""
    head, rest = parts[0], parts[1:]
    section = next((s for s, names in SECTIONS.items() if head in names and s != head), None)
    key = f"{section}.{head}" if section else str(head)
    for part in rest:
        key += f"[{part}]" if isinstance(part, int) else f".{part}"
    return key


def _first_difference(a, b, parts: list):
    """The path of the first value that differs between ``a`` and ``b`` (plain JSON values), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return [*parts, k]
            found = _first_difference(a[k], b[k], [*parts, k])
            if found is not None:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return parts
        for i, (x, y) in enumerate(zip(a, b)):
            found = _first_difference(x, y, [*parts, i])
            if found is not None:
                return found
        return None
    return None if a == b else parts


def _check_data_matches(geometry: AircraftGeometry, data: dict, path: Path) -> None:
    """``BuildError`` unless the data set ``data`` was computed from ``geometry`` (its recorded
    geometry, a solved tail incidence as solved; the description text aside)."""
    recorded = data.get("meta", {}).get("geometry") if isinstance(data, dict) else None
    if not isinstance(recorded, dict):
        raise BuildError(f"{path} records no geometry: it is no data set of this build; build without --from-data")
    expected = aero_data._to_plain(asdict(geometry))
    if geometry.solve_tail_incidence:
        solved = recorded.get("horizontal_tail", {}).get("incidence_deg") if isinstance(
            recorded.get("horizontal_tail"), dict) else None
        expected["horizontal_tail"]["incidence_deg"] = solved
    expected.pop("description", None)
    recorded = {k: v for k, v in recorded.items() if k != "description"}
    parts = _first_difference(expected, recorded, [])
    if parts is not None:
        raise BuildError(f"{path} was computed from another description ({_description_key(parts)} differs): build "
                         "without --from-data into a new folder to compute the data set again")


def prepare(description: Path, out: Path | None = None, from_data: bool = False) -> Target:
    """Check a build before any work, writing nothing: the description (``load_description``, its
    plausibility included), the destination, and with ``from_data`` the saved data set.
    ``BuildError`` (one line) where:

    - without ``out``, the description is not the package's own (``aircraft/solar_uav.toml``):
      only it rebuilds the packaged aircraft, a user's description never writes into the package;
    - ``out`` lies in the package's aircraft folder, is a file, or is not empty (a build never
      writes over another build or anything else), except that ``from_data`` rewrites a folder
      holding an earlier build of the same aircraft (``BUILT_ENTRIES`` and nothing else);
    - ``from_data`` and the saved data set is missing, unreadable, or computed from another
      description (the key that differs is named)."""
    try:
        geometry = load_description(description)
    except DescriptionError as err:
        raise BuildError(str(err)) from err
    if out is None:
        if not _is_packaged_description(description):
            raise BuildError(f"{description} is not the package's own description ({PAPER_AIRCRAFT}), which alone "
                             "builds into the package: give --out DIR to build it there")
    else:
        out = Path(out)
        package = jsbsim_root() / "aircraft"
        resolved = out.resolve()
        if resolved == package or package in resolved.parents or resolved in package.parents:
            raise BuildError(f"{out} is the package's folder or holds it: give --out a folder of your own")
        if out.exists() and not out.is_dir():
            raise BuildError(f"{out} exists and is not a folder: give --out a new or empty folder")
        held = sorted(out.iterdir()) if out.is_dir() else []
        if held and not from_data:
            earlier = " (an earlier build: --from-data rewrites its XML from its data set)" \
                if (out / DATA_FILE).is_file() else ""
            raise BuildError(f"{out} is not empty, it holds {_names(held)}{earlier}: a build never writes over "
                             "another; give a new or empty folder")
        if from_data:
            foreign = [p for p in held if p.name not in BUILT_ENTRIES]
            others = [p for p in (out / "aircraft").iterdir() if p.name != geometry.name] \
                if (out / "aircraft").is_dir() else []
            if foreign or others:
                raise BuildError(f"{out} holds {_names(foreign or others)}, which no build of {geometry.name} wrote: "
                                 "--from-data rewrites only a folder holding that aircraft's build")
    data = None
    if from_data:
        path = out / DATA_FILE if out is not None else aero_data.DATA_PATH
        try:
            data = aero_data.load(path)
        except ValueError as err:
            raise BuildError(f"{err}; build without --from-data first") from err
        _check_data_matches(geometry, data, path)
    return Target(description, geometry, out, data)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the block ends (in the main thread; elsewhere nothing held)."""
    held = threading.current_thread() is threading.main_thread() and hasattr(signal, "pthread_sigmask")
    if held:
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        if held:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _first_missing(path: Path) -> Path | None:
    """The highest folder of ``path`` and its parents that does not exist yet, or None."""
    missing = None
    for p in (path, *path.parents):
        if p.exists():
            break
        missing = p
    return missing


@contextlib.contextmanager
def staging(target: Target) -> Iterator[Path]:
    """``with staging(target) as root:``: a new temporary JSBSim root beside the destination to
    build into (``root/aero_data.json``, ``root/aircraft/<name>/``, anything else the command
    writes); a rebuild's (the package's, ``--from-data``'s) starts as a copy of what it replaces.
    When the block ends without an error the build is moved into place (signals held); on any
    error or Ctrl-C the temporary folder, and any folder made for it, is removed and the
    destination is as it was. An error that is not a ``BuildError`` becomes one, in one line."""
    name = target.geometry.name
    beside = target.out.parent if target.out is not None else jsbsim_root() / "aircraft"
    made = _first_missing(beside)
    try:
        beside.mkdir(parents=True, exist_ok=True)
        root = Path(tempfile.mkdtemp(dir=beside, prefix=f"{STAGING_PREFIX}{name}_"))
    except OSError as err:
        raise BuildError(f"cannot build into {target.out or target.root}: {err.strerror or err}") from None
    try:
        if target.out is None:  # the packaged aircraft: its folder keeps what other commands wrote in it
            if target.folder.is_dir():
                shutil.copytree(target.folder, root / "aircraft" / name)
            if target.data is not None:
                shutil.copy2(target.data_path, root / DATA_FILE)
        elif target.data is not None:  # --from-data: the earlier build, rewritten
            shutil.copytree(target.out, root, dirs_exist_ok=True)
        try:
            yield root
            with _signals_held():
                _commit(target, root)
        except (BuildError, KeyboardInterrupt):
            raise
        except Exception as err:
            why = (str(err).splitlines() or [""])[0]
            raise BuildError(f"{target.description}: the build failed ({type(err).__name__}: {why}); nothing was "
                             "written") from err
    finally:
        shutil.rmtree(root, ignore_errors=True)
        if made is not None and not (target.out is not None and target.out.exists()):
            for p in (beside, *beside.parents):  # the folders made for the temporary one, if empty
                try:
                    p.rmdir()
                except OSError:
                    break
                if p == made:
                    break


def _commit(target: Target, root: Path) -> None:
    """Move the build in ``root`` into place: the whole JSBSim root for ``--out``, the aircraft's
    folder and data set for the package."""
    if target.out is None:
        folder, replaced = target.folder, root / ".replaced"
        if folder.exists():
            os.rename(folder, replaced)
        try:
            os.rename(root / "aircraft" / target.geometry.name, folder)
        except OSError:
            if replaced.exists():
                os.rename(replaced, folder)
            raise
        os.replace(root / DATA_FILE, target.data_path)
        return
    out = target.out
    if target.data is None:
        if out.exists() and any(out.iterdir()):
            raise BuildError(f"{out} was filled by something else during the build: nothing was written; give a "
                             "new or empty folder")
        os.rename(root, out)  # replaces an empty folder
        return
    replaced = out.parent / f"{STAGING_PREFIX}{out.name}_replaced_{os.getpid()}"
    os.rename(out, replaced)
    os.rename(root, out)
    shutil.rmtree(replaced, ignore_errors=True)


def build_into(target: Target, root: Path, log=print) -> Built:
    """Build ``target``'s aircraft into the JSBSim root ``root`` (``staging``'s): the analysis
    (or the saved data set), then the JSBSim files. ``log`` names the final places."""
    geometry, description = target.geometry, target.description
    data_path, folder = root / DATA_FILE, root / "aircraft" / geometry.name
    data = target.data
    if data is None:
        start = time.perf_counter()
        try:
            data = aero_data.compute_aero_data(geometry, log)
        except ValueError as err:  # a lattice that does not converge, a tail incidence that does not trim
            raise BuildError(f"{description}: {(str(err).splitlines() or [''])[0]}") from None
        aero_data.save(data, data_path)
        log(f"aerodynamic data computed in {time.perf_counter() - start:.1f} s -> {target.data_path}")
    geometry = aero_data.solved_geometry(geometry, data)  # a tail incidence the build solved, as solved
    files = xml_writer.aircraft_files(geometry, data)
    xml_writer.write(files, folder)
    log(f"wrote {len(files)} files under {target.folder}")
    return Built(geometry, data, data_path, root, folder)


def build(description: Path, out: Path | None = None, from_data: bool = False, log=print) -> Built:
    """Build the aircraft ``description`` describes into ``out`` (the package when None: only the
    package's own description may), checked first (``prepare``) and moved into place only when
    everything succeeded (``staging``); ``BuildError`` where it cannot. Returns the build as
    placed."""
    target = prepare(description, out, from_data)
    with staging(target) as root:
        built = build_into(target, root, log)
    return Built(built.geometry, built.data, target.data_path, target.root, target.folder)


def summary(data: dict) -> str:
    """The stability figures and the analysis's checks, as the build prints them."""
    st = data["stability"]
    return (f"CG x = {st['cg_x_m']:.3f} m, neutral point x = {st['neutral_point_x_m']:.3f} m, "
            f"static margin {st['static_margin']:.2f} MAC, cruise alpha {st['cruise_alpha_deg']:.2f} deg\n"
            + checks_report(data))


def checks_report(data: dict) -> str:
    """The lattice's mesh-convergence table and the induced-yaw check, as printed by the build."""
    setup, checks = data["vlm_setup"], data["checks"]
    mesh = f"{setup['spanwise_panels_per_segment']} x {setup['chordwise_panels']}"
    lines = [(f"vortex lattice: {mesh} panels (spanwise per segment x chordwise), flat wing at "
             f"{setup['wing_incidence_deg']:.2f} deg incidence; convergence at the cruise angle of attack:"),
             f"  {'derivative':>10} {'mesh':>10} {'doubled':>10} {'change':>8}"]
    table = checks["mesh_convergence"]
    for name, row in table.items():
        line = f"  {name:>10} {row['mesh']:>10.5g} {row['doubled']:>10.5g} {100 * row['relative_change']:>7.2f}%"
        if name == "Cma":
            line += f"  (the neutral point moves {100 * analysis.neutral_point_shift_mac(table):.2f} % of the mean chord)"
        lines.append(line)
    failures = analysis.convergence_failures(table)
    limits = (f"each derivative within {100 * analysis.CONVERGENCE_TOLERANCE:g} % of its value on the doubled mesh, "
              f"Cma's neutral point within {100 * analysis.NEUTRAL_POINT_TOLERANCE_MAC:g} % of the mean chord")
    lines.append(f"  converged: {limits}" if not failures else f"  NOT converged ({'; '.join(failures)}); the check: "
                 f"{limits}")
    yaw = checks["aileron_induced_yaw"]
    lines.append(f"aileron induced yaw: dCn_s = -k CL dCl_s/(pi AR), lifting line k = {yaw['lifting_line_factor']:g}, "
                 f"lattice k = {yaw['factor']:.2f} at CL {yaw['CL']:.2f}")
    return "\n".join(lines)

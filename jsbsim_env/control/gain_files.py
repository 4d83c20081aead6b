"""Where each aircraft's classical controllers keep their gain tables, and where they are designed.

The paper's aircraft's tables ship beside this module (``scripts/tune_pid.py``, ``tune_lqi.py`` and
``tune_classical.py`` write them); an aircraft built from a description keeps its own in its
folder, written by ``scripts/build_aircraft.py``. Each table records the EAS it was designed at
(``design_eas_mps``), which the controllers' dynamic-pressure scaling reads.
"""

from __future__ import annotations

from pathlib import Path

from aircraft import Aircraft, load_aircraft

PACKAGED_DIR = Path(__file__).parent  # the paper's aircraft's tables, kept in git
FILES = {"pid": "pid_gains.json", "lqi": "lqi_gains.json", "pid_tuned": "pid_tuned_gains.json",
         "lqi_tuned": "lqi_tuned_gains.json", "pid_robust": "pid_robust_gains.json",
         "lqi_robust": "lqi_robust_gains.json", "lqi_stressed": "lqi_stressed_gains.json"}
TUNINGS = {"tuned": "heldout", "robust": "robust", "stressed": "stressed"}  # a tuned table's suffix: its --flights


class GainsMissing(FileNotFoundError):
    """A controller asked for on an aircraft whose gain table has not been written."""


class GainTableError(ValueError):
    """A gain table that is there but cannot be flown: malformed, another controller's, a gain of the
    wrong sign or an impossible trim (the message names the file and what is wrong)."""


def gain_file_path(kind: str, aircraft: Aircraft | str | Path | None = None) -> Path:
    """Where the ``kind`` (``FILES``) table of ``aircraft`` (the paper's by default) is kept, whether
    or not it has been written."""
    if kind not in FILES:
        raise ValueError(f"gain table kind must be one of {', '.join(FILES)}, got {kind!r}")
    found = load_aircraft(aircraft)
    return (PACKAGED_DIR if found.papers else found.folder) / FILES[kind]


def gain_file(kind: str, aircraft: Aircraft | str | Path | None = None) -> Path:
    """``gain_file_path``, refused (``GainsMissing``, one line saying how to write it) where the
    table is not there."""
    path = gain_file_path(kind, aircraft)
    if not path.is_file():
        found = load_aircraft(aircraft)
        controller, _, tuning = kind.partition("_")
        if tuning in TUNINGS:
            how = (f"`python scripts/tune_classical.py --controller {controller}"
                   + (f" --flights {TUNINGS[tuning]}" if tuning != "tuned" else "")
                   + ("" if found.papers else f" --aircraft {found.root}") + "`")
        else:
            how = "`python scripts/build_aircraft.py DESCRIPTION --out DIR` (it designs the PID and the LQI)"
        raise GainsMissing(f"{kind}: {found.describe()} has no gain table {path}: write it with {how}")
    return path


__all__ = ["FILES", "PACKAGED_DIR", "GainsMissing", "gain_file", "gain_file_path"]

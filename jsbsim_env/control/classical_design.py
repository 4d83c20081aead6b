"""The classical controllers of a built aircraft: its PID and LQI gain tables, designed by the
procedures that designed the paper's aircraft's (``pid.write_gain_table``, ``lqi.write_gain_table``),
at its design altitudes (``design_altitudes_m``) and reference EAS, into its folder."""

from __future__ import annotations

import time
from pathlib import Path

from aircraft import Aircraft, load_aircraft
from jsbsim_env.control import gain_files, lqi, pid


def design_altitudes_m(aircraft: Aircraft) -> tuple[float, ...]:
    """Where the classical controllers are designed: the paper's design altitudes
    (``pid.DESIGN_ALTITUDES_M``, 500 m to 20 km, dense low down) moved into the aircraft's envelope
    (``Aircraft.altitude_like_m``)."""
    return tuple(aircraft.altitude_like_m(h) for h in pid.DESIGN_ALTITUDES_M)


def design_classical(aircraft: Aircraft | Path | str, log=print) -> dict[str, Path]:
    """Design and write ``aircraft``'s PID and LQI tables (``gain_files.gain_file_path``); returns
    the files. The paper's aircraft's tables ship with the package and are not rewritten here
    (``scripts/tune_pid.py``, ``scripts/tune_lqi.py``)."""
    found = load_aircraft(aircraft)
    if found.papers:
        raise ValueError("the paper's aircraft's gain tables ship with the package: scripts/tune_pid.py and "
                         "scripts/tune_lqi.py write them")
    altitudes = design_altitudes_m(found)
    written = {}
    for kind, module in (("pid", pid), ("lqi", lqi)):
        path = gain_files.gain_file_path(kind, found)
        start = time.perf_counter()
        module.write_gain_table(path, altitudes, aircraft=found, eas_mps=found.reference_eas_mps)
        log(f"{kind.upper()} designed at {', '.join(f'{h:g}' for h in altitudes)} m, EAS "
            f"{found.reference_eas_mps:g} m/s, in {time.perf_counter() - start:.0f} s -> {path}")
        written[kind] = path
    return written


__all__ = ["design_altitudes_m", "design_classical"]

"""The standalone JSBSim runscripts: generated from the trim, runnable with the ``jsbsim`` command."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

import aircraft
from jsbsim_env.analysis.runscripts import OUTPUT_RATE_HZ, RUNS, SPIN_UP_S, generated_files
from jsbsim_env.sim.simulation import FT_TO_M, Simulation

REPO_ROOT = Path(__file__).resolve().parents[1]


NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _assert_same_up_to_the_last_digit(text: str, committed: str, rel: str) -> None:
    """The same text, but that a number may differ by one unit in its last printed digit: the files
    print the trim to six digits, and a trim solved on another CPU (the same to about 1e-13) can
    round the other way there; anything more is a change."""
    hint = f"{rel} differs: run python scripts/make_runscripts.py"
    assert NUMBER.split(text) == NUMBER.split(committed), hint
    for new, old in zip(NUMBER.findall(text), NUMBER.findall(committed)):
        if "." not in new + old:  # a whole number (a time, a count, a doublet's size) is not rounded
            assert new == old, f"{hint} ({new} against {old})"
            continue
        unit = min(10.0 ** Decimal(new).as_tuple().exponent, 10.0 ** Decimal(old).as_tuple().exponent)
        assert abs(float(new) - float(old)) <= 1.000001 * unit, f"{hint} ({new} against {old})"


def test_committed_runscripts_are_what_the_generator_writes():
    for rel, text in generated_files().items():
        if rel.startswith("aircraft/"):
            path = aircraft.jsbsim_root() / rel  # the installed copy of the initial conditions
        else:
            path = REPO_ROOT / rel
        _assert_same_up_to_the_last_digit(text, path.read_text(), rel)


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    with path.open() as fh:
        rows = list(csv.reader(fh))
    # JSBSim names the columns by their full property path; keep the part after /fdm/jsbsim/.
    names = [h.strip().removeprefix("/fdm/jsbsim/") for h in rows[0]]
    data = np.array([[float(v) for v in row] for row in rows[1:]])
    return {n: data[:, i] for i, n in enumerate(names)}


def assert_starts_trimmed(out: dict[str, np.ndarray], trim, run, roll_deg: float = 0.05, beta_deg: float = 0.05) -> None:
    """The run's log starts at the release, trimmed: for its first 10 s the rotors turn at the
    trimmed speed, wings level at the trimmed sideslip (within ``roll_deg`` and ``beta_deg``), at the
    trimmed pitch and altitude (the log's first row, JSBSim's record of the initial conditions
    before the held spin-up, aside)."""
    t = out["Time"]
    assert t[0] == 0.0 and t[1] == pytest.approx(SPIN_UP_S, abs=1.5 / OUTPUT_RATE_HZ)
    first = (t >= SPIN_UP_S) & (t < SPIN_UP_S + 10.0)
    rpm = out["propulsion/engine/propeller-rpm"][first]
    assert np.all(np.abs(rpm - trim.rotor_rpm) < 0.005 * trim.rotor_rpm), (rpm.min(), rpm.max(), trim.rotor_rpm)
    assert np.all(np.abs(out["attitude/phi-deg"][first]) < roll_deg), np.abs(out["attitude/phi-deg"][first]).max()
    slip = np.abs(out["aero/beta-deg"][first] - trim.beta_deg)
    assert np.all(slip < beta_deg), (slip.max(), trim.beta_deg)
    assert np.all(np.abs(out["attitude/theta-deg"][first] - trim.pitch_deg) < 0.2)
    assert np.all(np.abs(out["position/h-sl-meters"][first] - run.altitude_m) < 2.0)


@pytest.mark.parametrize("run", RUNS, ids=lambda r: r.name)
def test_runscript_flies_the_doublets_and_returns_to_trim(run, tmp_path):
    jsbsim_cli = Path(sys.executable).with_name("jsbsim")
    done = subprocess.run([str(jsbsim_cli), "--root", str(aircraft.jsbsim_root()), "--outputpath", str(tmp_path),
                           str(REPO_ROOT / "scripts" / f"{run.name}.xml")],
                          check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    out = _read_csv(tmp_path / f"{run.name}.csv")
    t = out["Time"]
    assert t[-1] == pytest.approx(run.end_s, abs=1.0 / OUTPUT_RATE_HZ)
    trim = Simulation().trim(run.altitude_m, run.airspeed_eas_mps)

    def at(name, time_s):
        return out[name][np.searchsorted(t, time_s)]

    assert_starts_trimmed(out, trim, run)
    # The doublets reached the surfaces.
    half = run.doublet_half_period_s
    elevator_kick = at("fcs/elevator-pos-deg", run.elevator_start_s + 0.5 * half) - trim.elevator_deg
    assert elevator_kick == pytest.approx(run.elevator_doublet_deg, abs=0.05)
    aileron = at("fcs/aileron-pos-deg", run.aileron_start_s + 1.5 * half)
    assert aileron == pytest.approx(-run.aileron_doublet_deg, abs=0.05)
    # ... and moved the aircraft.
    window = (t > run.elevator_start_s) & (t < run.elevator_start_s + 10)
    assert np.ptp(out["attitude/theta-deg"][window]) > 1.0
    window = (t > run.aileron_start_s) & (t < run.aileron_start_s + 10)
    assert np.ptp(out["attitude/phi-deg"][window]) > 2.0
    # The last 20 s are back at the trimmed condition.
    last = t > run.end_s - 20
    eas_mps = out["velocities/ve-fps"][last] * FT_TO_M
    assert np.all(np.abs(eas_mps - run.airspeed_eas_mps) < 0.1)
    assert np.all(np.abs(out["attitude/theta-deg"][last] - trim.pitch_deg) < 0.3)
    assert np.all(np.abs(out["attitude/phi-deg"][last]) < 0.5)
    assert np.all(np.abs(out["velocities/h-dot-fps"][last] * FT_TO_M) < 0.1)
    assert np.all(np.abs(out["position/h-sl-meters"][last] - run.altitude_m) < 20.0)

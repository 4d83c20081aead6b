"""``scripts/heldout.py`` flies runs and the PID on flights that are not the report's."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from test_ablation import _run_folder

from training.heldout import heldout_flights
from training.report import ROUTE_SEED

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "heldout.py"


def test_heldout_flights_are_not_the_reports():
    flights = heldout_flights()
    assert all(c.seed != ROUTE_SEED for c in flights.values())
    assert {c.altitude_m for c in flights.values()}.isdisjoint({1000.0, 10000.0, 20000.0})
    assert {flights["positive_3km"].parameters, flights["negative_3km"].parameters} == {"positive", "negative"}
    assert flights["turbulent_5km"].turbulence_legs and not flights["calm_15km"].turbulence_legs


def test_heldout_scores_runs_and_the_pid(tmp_path):
    run = _run_folder(tmp_path, "cand_seed0", 0)
    command = [sys.executable, str(SCRIPT), str(run), "--pid", "--quick"]
    done = subprocess.run([*command, "--json"], check=False, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)
    assert list(rows) == ["PID", "cand_seed0"]
    for scores in rows.values():
        assert set(scores) == {"ended_early", *heldout_flights()}
        assert set(scores["turbulent_5km"]) == {"rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg"}
        assert set(scores["calm_15km"]) == {"mae_roll_deg", "mae_pitch_deg"}
    table = subprocess.run(command, check=False, capture_output=True, text=True, timeout=600)
    assert table.returncode == 0, table.stderr
    assert [line.split(" |")[0] for line in table.stdout.splitlines()[2:]] == ["| PID", "| cand_seed0"]


def test_heldout_refuses_a_folder_without_a_policy(tmp_path):
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], check=False, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode != 0 and "has no best_policy.pt" in done.stderr

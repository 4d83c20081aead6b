"""``scripts/report.py --quick`` writes every file its report names."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def test_quick_report_writes_every_named_file(tmp_path, untrained_policy):
    # An untrained policy stands in for the trained one: the report must cope with whatever it flies.
    policy = untrained_policy(tmp_path / "policy.pt", seed=2)
    out = tmp_path / "report"
    done = subprocess.run([sys.executable, str(SCRIPTS / "report.py"), "--out", str(out), "--quick", "--policy",
                           str(policy), "--no-progress"], check=False, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    text = (out / "report.md").read_text()
    named = re.findall(r"\]\(([^)]+)\)", text)
    # Quick mode: one doublet altitude, Fig. 10, and per controller 8 route figures.
    assert len(named) == 2 + 2 * 8
    for name in named:
        assert (out / name).is_file() and (out / name).stat().st_size > 1000, name
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["controllers"] == ["PID", "RL"]
    for key in ("route_10km", "perturbation", "altitudes", "backlash", "doublets", "effectiveness"):
        assert key in metrics
    assert "| PID | ours |" in text and "| RL | ours |" in text
    # It says which aircraft model the policy was trained on: the one its file records, this one.
    assert metrics["policy"]["trained_on_aircraft_model"] == metrics["policy"]["flown_aircraft_model"]
    assert "trained on the aircraft model this report flies" in text
    # The PID's rows match its metrics.
    pid = metrics["route_10km"]["PID"]["turbulent_leg"]
    assert f"| PID | ours | {pid['rmse_roll_deg']:.3f} |" in text
    # Beside the paper's window, the same leg without the turn into it.
    straight = metrics["route_10km"]["PID"]["turbulent_leg_straight"]
    assert f"| PID | ours, no corner | {straight['rmse_roll_deg']:.3f} |" in text
    assert straight["rmse_roll_deg"] != pid["rmse_roll_deg"]


def test_report_without_a_policy_file_fails_clearly(tmp_path):
    done = subprocess.run([sys.executable, str(SCRIPTS / "report.py"), "--out", str(tmp_path), "--quick", "--policy",
                           str(tmp_path / "missing.pt"), "--no-progress"],
                          check=False, capture_output=True, text=True, timeout=300)
    (line,) = done.stderr.splitlines()  # one line naming the file, no traceback
    assert done.returncode == 2 and line.startswith("report: ")
    assert "policy file" in line and str(tmp_path / "missing.pt") in line


def test_report_runs_only_the_experiments_and_controllers_named(tmp_path):
    done = subprocess.run([sys.executable, str(SCRIPTS / "report.py"), "--out", str(tmp_path), "--quick",
                           "--experiments", "altitudes", "--controllers", "PID", "--no-progress"],
                          check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["controllers"] == ["PID"] and metrics["experiments"] == ["altitudes"]
    assert set(metrics["altitudes"]) == {"1km", "20km"} and set(metrics["altitudes"]["1km"]) == {"PID"}
    for key in ("route_10km", "perturbation", "backlash", "doublets", "effectiveness"):
        assert key not in metrics
    bad = subprocess.run([sys.executable, str(SCRIPTS / "report.py"), "--out", str(tmp_path), "--quick",
                          "--experiments", "altitudes,loops"], check=False, capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "unknown or no experiment ['loops']" in bad.stderr


def test_the_provenance_line_names_the_trained_and_the_flown_model():
    from training.evaluation.report import _provenance_line

    flown = "ab" * 32
    unnamed = _provenance_line({"path": "p.pt", "trained_on_aircraft_model": None, "flown_aircraft_model": flown})
    assert "whose record names no aircraft model" in unnamed and "`abababababab`" in unnamed
    other = _provenance_line({"path": "p.pt", "trained_on_aircraft_model": "cd" * 32, "flown_aircraft_model": flown})
    assert "not on the one this report flies" in other and "`cdcdcdcdcdcd`" in other

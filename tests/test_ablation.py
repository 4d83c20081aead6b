"""``scripts/ablation.py`` scores run folders, groups seeds into candidates and reuses its scores."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "ablation.py"


def test_ablation_scores_groups_and_caches(tmp_path, untrained_run):
    runs = [untrained_run(tmp_path, f"cand_seed{s}", s) for s in (0, 1)]
    command = [sys.executable, str(SCRIPT), *map(str, runs), "--quick", "--episodes", "1"]
    done = subprocess.run(command, check=False, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    groups = json.loads(done.stdout)
    assert list(groups) == ["cand"] and len(groups["cand"]) == 2
    card = groups["cand"][0]
    assert card["wall_clock"] == {"to_policy_s": 0.5, "whole_run_s": 12.0, "frames": 0}
    assert set(card["altitudes"]) == {"1km", "20km"} and "turbulent_leg" in card["route_10km"]
    assert set(card["table9"]) == {"positive", "negative"} and "rmse_pitch_deg" in card["table9"]["negative"]
    stored = runs[0] / "scorecard" / "scorecard.json"
    stamp = stored.stat().st_mtime_ns
    table = subprocess.run([*command, "--markdown"], check=False, capture_output=True, text=True, timeout=600)
    assert table.returncode == 0, table.stderr
    assert stored.stat().st_mtime_ns == stamp  # the same policy is not flown again
    row = [line for line in table.stdout.splitlines() if line.startswith("| cand |")]
    assert len(row) == 1 and "| 2 |" in row[0] and row[0].count("|") == 12

    # A scorecard from before the Table 9 section gains that section alone: its other scores stay.
    old = json.loads(stored.read_text())
    del old["table9"]
    old["route_10km"]["turbulent_leg"]["rmse_roll_deg"] = 123.0
    stored.write_text(json.dumps(old))
    again = subprocess.run(command, check=False, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    card = json.loads(again.stdout)["cand"][0]
    assert card["route_10km"]["turbulent_leg"]["rmse_roll_deg"] == 123.0 and "table9" in card
    report = json.loads((runs[0] / "scorecard" / "metrics.json").read_text())
    assert {"route_10km", "altitudes", "perturbation"} <= set(report)


def test_ablation_refuses_a_folder_without_a_policy(tmp_path):
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], check=False, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode != 0 and "has no best_policy.pt" in done.stderr

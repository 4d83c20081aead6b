"""``scripts/ablation.py`` scores run folders, groups seeds into candidates and reuses its scores."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

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


def _benchmark_result() -> dict:
    """A benchmark.json's parts that a method row reads: two classical controllers, one candidate."""
    means = {"lqi_tuned": (0.10, 0.20, 0.30), "pid": (0.30, 0.10, 0.50), "cand": (0.12, 0.15, 0.25)}
    metrics = ("rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg")
    entry = {"controllers": {c: {"ended_early": 0, "metrics": {m: {"mean": v} for m, v in zip(metrics, vs)}}
                             for c, vs in means.items()}}
    return {"split": "validation", "aircraft": "solar_uav", "families": ["turbulence"], "episodes": 10,
            "controllers": list(means), "summary": {"turbulence": {"10 km": entry}},
            "selection": [{"controller": "cand", "met": 2, "cells": 4, "ratio": 0.9876, "all_met": False}]}


def test_a_method_row_reads_the_selection_and_the_best_classical_rmse_of_each_metric(load_script):
    ablation = load_script("ablation")
    row = ablation.method_row(_benchmark_result(), "cand")
    assert row["judged_against"] == ["pid", "lqi_tuned"]  # in the order the package names them
    assert (row["cells_met"], row["ratio"], row["split"], row["episodes"]) == ("2 of 4", "0.988", "validation", 10)
    assert row["turbulence_rmse_deg"] == {"10 km": "0.120 / 0.150 / 0.250"}
    assert row["best_classical_turbulence_rmse_deg"] == {"10 km": "0.100 / 0.100 / 0.300"}  # per metric: LQI, PID, LQI
    with pytest.raises(ValueError, match="'other' was not judged in this benchmark .*cand"):
        ablation.method_row(_benchmark_result(), "other")
    with pytest.raises(ValueError, match="not a benchmark's benchmark.json"):
        ablation.method_row({"selection": []}, "cand")


def test_the_record_renders_a_method_row_and_the_script_prints_one(load_script, tmp_path):
    ablation = load_script("ablation")
    row = {**ablation.method_row(_benchmark_result(), "cand"), "candidate": "a residual", "aircraft_name": "paper's",
           "training": "1,400", "commit": "abc1234", "kept": "no"}
    page = ablation.record_markdown({"rows": [], "previous_model_rows": [], "decisions": [], "method_rows": [row]})
    line = next(x for x in page.splitlines() if x.startswith("| a residual |"))
    assert "| 10 km: 0.120 / 0.150 / 0.250<br>0.100 / 0.100 / 0.300 | — | — |" in line and "| 2 of 4 | 0.988 |" in line
    assert "validation: turbulence" in line and line.count("|") == 13
    (tmp_path / "benchmark.json").write_text(json.dumps(_benchmark_result()))
    done = subprocess.run([sys.executable, str(SCRIPT), "--method-row", str(tmp_path), "cand"], check=False,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == ablation.method_row(_benchmark_result(), "cand")
    refused = subprocess.run([sys.executable, str(SCRIPT), "--method-row", str(tmp_path / "none"), "cand"],
                             check=False, capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and refused.stderr.strip() == (
        f"ablation: {tmp_path / 'none'} has no benchmark.json (scripts/benchmark.py --out writes it)")

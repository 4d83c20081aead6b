"""``scripts/heldout.py`` flies runs and the PID on flights that are not the report's."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from jsbsim_env.control.checked_io import atomic_save, checked_load
from jsbsim_env.control.policy import shipped_policy_path
from training.evaluation import heldout
from training.evaluation.heldout import heldout_flights, relative_score
from training.evaluation.report import ROUTE_SEED

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "heldout.py"


def test_heldout_flights_are_not_the_reports():
    flights = heldout_flights()
    assert all(c.seed != ROUTE_SEED for c in flights.values())
    assert {c.altitude_m for c in flights.values()}.isdisjoint({1000.0, 10000.0, 20000.0})
    assert {flights["positive_3km"].parameters, flights["negative_3km"].parameters} == {"positive", "negative"}
    assert flights["turbulent_5km"].turbulence_legs and not flights["calm_15km"].turbulence_legs


def _scores(value: float, ended_early: bool = False) -> dict:
    scores = {"ended_early": ended_early}
    for flight in heldout_flights():
        keys = ("mae_roll_deg", "mae_pitch_deg") if flight.startswith("calm") else ("rmse_roll_deg", "rmse_pitch_deg",
                                                                                    "rmse_beta_deg")
        scores[flight] = dict.fromkeys(keys, value)
    scores["surface_activity"] = dict.fromkeys(heldout.SURFACES, 1e-6)
    return scores


def test_relative_score_is_the_geometric_mean_of_the_ratios():
    pid = _scores(0.4)
    assert math.isclose(relative_score(_scores(0.4), pid), 1.0)
    assert math.isclose(relative_score(_scores(0.2), pid), 0.5)
    mixed = _scores(0.4)
    mixed["turbulent_5km"]["rmse_roll_deg"] = 0.4 * 2.0 ** 11  # one measure 2^11 worse in 11
    assert math.isclose(relative_score(mixed, pid), 2.0)
    mixed["calm_15km"]["mae_roll_deg"] = math.nan  # a measure a short flight lacks is left out
    assert math.isclose(relative_score(mixed, pid), 2.0 ** (11 / 10))
    assert relative_score(_scores(0.1, ended_early=True), pid) == math.inf


def test_a_chattering_surface_is_refused_whatever_its_errors():
    """Surface activity gates the score without entering the mean: within CHATTER_LIMIT times the
    PID's it changes nothing, beyond it the score is infinite."""
    pid = _scores(0.4)
    busy = _scores(0.2)
    busy["surface_activity"]["elevator"] = 0.9 * heldout.CHATTER_LIMIT * 1e-6
    assert heldout.chattering_surfaces(busy, pid) == {} and math.isclose(relative_score(busy, pid), 0.5)
    busy["surface_activity"]["elevator"] = 1.1 * heldout.CHATTER_LIMIT * 1e-6
    assert set(heldout.chattering_surfaces(busy, pid)) == {"elevator"}
    assert relative_score(busy, pid) == math.inf
    busy["surface_activity"]["elevator"] = math.nan  # no straight leg (a quick check): no verdict
    assert math.isclose(relative_score(busy, pid), 0.5)


def _full_aileron(run: Path) -> None:
    """Make the run's policy command full aileron whatever it observes: it rolls past the envelope's
    limit and ends every flight early."""
    path = run / "best_policy.pt"
    data = checked_load(path)
    data["actor"]["module.0.module.head.4.bias"][0] = 20.0  # the aileron's pre-tanh mean
    atomic_save(data, path)


def test_heldout_scores_runs_and_the_pid(tmp_path, untrained_run):
    run = untrained_run(tmp_path, "cand_seed0", 0)
    _full_aileron(run)
    command = [sys.executable, str(SCRIPT), str(run), "--pid", "--quick"]
    done = subprocess.run([*command, "--json"], check=False, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)
    assert list(rows) == ["PID", "cand_seed0"]
    for scores in rows.values():
        assert set(scores) == {"ended_early", "relative_to_pid", "surface_activity", *heldout_flights()}
        assert set(scores["surface_activity"]) == set(heldout.SURFACES)
        assert set(scores["turbulent_5km"]) == {"rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg"}
        assert set(scores["calm_15km"]) == {"mae_roll_deg", "mae_pitch_deg"}
    assert rows["PID"]["relative_to_pid"] == 1.0 and rows["cand_seed0"]["relative_to_pid"] > 0
    assert rows["cand_seed0"]["ended_early"] and not rows["PID"]["ended_early"]
    # The policy ends a flight early, so --pick refuses it and picks the shipped one.
    refused = subprocess.run([*command, "--pick"], check=False, capture_output=True, text=True, timeout=600)
    assert refused.returncode != 0 and "none to pick" in refused.stderr
    shipped = tmp_path / "shipped_seed1"
    shipped.mkdir()
    shutil.copy(shipped_policy_path(), shipped / "best_policy.pt")
    table = subprocess.run([sys.executable, str(SCRIPT), str(run), str(shipped), "--quick", "--pick"], check=False,
                           capture_output=True, text=True, timeout=600)
    assert table.returncode == 0, table.stderr
    lines = table.stdout.splitlines()
    assert [line.split(" |")[0] for line in lines[2:5]] == ["| PID", "| cand_seed0", "| shipped_seed1"]
    assert lines[-1].startswith(f"picked: {shipped} ")


def test_heldout_refuses_a_folder_without_a_policy_and_clashing_names(tmp_path, untrained_run):
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], check=False, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode != 0 and "has no best_policy.pt" in done.stderr
    runs = [untrained_run(tmp_path / side, "cand_seed0", 0) for side in ("a", "b")]
    done = subprocess.run([sys.executable, str(SCRIPT), *map(str, runs), "--pick"], check=False, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode != 0 and "distinct names" in done.stderr


class _Crashed:
    """A route result that ended early, before any turbulent leg."""

    def __init__(self):
        self.ended_early = True
        self.arrays = {"turbulence": np.zeros(3), "time_s": np.arange(3.0)}

    @staticmethod
    def window(*_):
        return np.zeros(3, dtype=bool)

    @staticmethod
    def metrics(*_):
        return dict.fromkeys(("rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg", "mae_roll_deg", "mae_pitch_deg",
                              "smoothness_aileron", "smoothness_elevator", "smoothness_rudder"), 9.0)


def test_a_crash_before_the_turbulence_is_an_early_end_not_an_error(monkeypatch):
    monkeypatch.setattr(heldout, "fly_route", lambda controller, config: _Crashed())
    monkeypatch.setattr(heldout, "steady_mask", lambda result, after_s: np.zeros(3, dtype=bool))
    scores = heldout.heldout_scores(lambda: None)
    assert scores["ended_early"] and all(math.isnan(v) for v in scores["turbulent_5km"].values())
    assert scores["negative_3km"]["rmse_roll_deg"] == 9.0
    assert heldout.relative_score(scores, _scores(0.4)) == math.inf


def test_checkpoints_picks_among_the_evaluated_policies_and_writes_the_pick(tmp_path, tiny_config):
    """A run keeps every policy it evaluated; ``--checkpoints`` flies them all and the PID and
    writes the best relative to the PID as the run's ``picked_policy.pt``, a copy of that file."""
    from training.trainer import EVALUATED_DIR, Trainer, evaluated_policy_name

    run = tmp_path / "tiny"
    Trainer(tiny_config(192), run).train()
    kept = sorted((run / EVALUATED_DIR).iterdir())
    assert [p.name for p in kept] == [evaluated_policy_name(f) for f in (96, 192)]
    assert checked_load(kept[0])["frames"] == 96 and checked_load(kept[1])["frames"] == 192
    done = subprocess.run([sys.executable, str(SCRIPT), str(run), "--checkpoints", "--quick"], check=False,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert [line.split(" |")[0] for line in done.stdout.splitlines()[2:5]] == [
        "| PID", "| tiny/policy_00000096", "| tiny/policy_00000192"]
    record = json.loads((run / "picked_policy.json").read_text())
    assert set(record["candidates"]) == {str(p) for p in kept}
    picked = Path(record["picked"])
    assert (run / "picked_policy.pt").read_bytes() == picked.read_bytes()
    scores = {path: row["relative_to_pid"] for path, row in record["candidates"].items()}
    assert scores[str(picked)] == min(scores.values())
    assert done.stdout.splitlines()[-1].startswith(f"picked: {picked} ")
    # A picked_policy.pt that is none of the run's policies is not this command's: left alone.
    (run / "picked_policy.pt").write_bytes(b"mine")
    refused = subprocess.run([sys.executable, str(SCRIPT), str(run), "--checkpoints", "--quick"], check=False,
                             capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "left alone" in refused.stderr
    assert (run / "picked_policy.pt").read_bytes() == b"mine"


def test_checkpoints_refuses_a_run_without_evaluated_policies(tmp_path, untrained_run):
    run = untrained_run(tmp_path, "cand_seed0", 0)
    done = subprocess.run([sys.executable, str(SCRIPT), str(run), "--checkpoints"], check=False, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and "holds no evaluated policies" in done.stderr
    done = subprocess.run([sys.executable, str(SCRIPT), str(run), "--checkpoints", "--pick"], check=False,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "give one of them" in done.stderr

"""scripts/ship_policy.py: everything is checked and evaluated before the shipped files change, and
the policy, its export and its record are replaced together (tests on a copy of the shipped folder)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import write_untrained_run

OLD = {"solar_uav_policy.pt": b"old policy", "solar_uav_policy.onnx": b"old export",
       "solar_uav_policy.json": b'{"old": "record"}'}


def _rewrite_policy(path: Path, **changes) -> None:
    from jsbsim_env.control.checked_io import checked_load, write_checked

    data = checked_load(path)
    data.update(changes)
    with path.open("wb") as fh:
        write_checked(data, fh)


@pytest.fixture
def ship(load_script, monkeypatch, tmp_path):
    """scripts/ship_policy.py shipping into a copy of the shipped folder holding an earlier set."""
    script = load_script("ship_policy")
    shipped = tmp_path / "package" / "shipped"
    shipped.mkdir(parents=True)
    for name, data in OLD.items():
        (shipped / name).write_bytes(data)
    monkeypatch.setattr(script, "SHIPPED_DIR", shipped)
    return script


@pytest.fixture
def run(tmp_path):
    """A run folder whose best policy (untrained) was saved at 100 frames."""
    run = write_untrained_run(tmp_path / "runs", "ship_seed0", 0)
    _rewrite_policy(run / "best_policy.pt", frames=100)
    (run / "progress.csv").write_text("frames,wall_s\n0,0.5\n100,12.0\n")
    return run


ARGS = ["--command", "python scripts/train_torchrl.py", "--commit", "abc123", "--cores", "1", "--episodes", "1"]


def _shipped(ship) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in ship.SHIPPED_DIR.iterdir()}


def _no_staging(ship) -> bool:
    return not [p for p in ship.SHIPPED_DIR.parent.iterdir() if p.name.startswith(".staging_")]


def test_a_run_trained_on_another_aircraft_is_refused_in_one_line_before_anything_is_written(ship, run, capsys):
    _rewrite_policy(run / "best_policy.pt", aircraft="other_uav", aircraft_model="f" * 64)
    assert ship.main([str(run), *ARGS]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("ship_policy: ") and "trained on other_uav (model ffffffffffff)" in lines[0], lines[0]
    assert _shipped(ship) == OLD and _no_staging(ship)


def test_a_ship_stopped_during_its_evaluation_leaves_the_shipped_set_as_it_was(ship, run, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("training.evaluation.suite.evaluate", interrupted)
    with pytest.raises(KeyboardInterrupt):
        ship.main([str(run), *ARGS])
    assert _shipped(ship) == OLD and _no_staging(ship)


def test_a_ship_that_succeeds_replaces_the_policy_its_export_and_its_record_together(ship, run, monkeypatch, capsys):
    from jsbsim_env.control.policy import onnx_source_digest, policy_digest

    monkeypatch.setattr("training.evaluation.suite.evaluate", lambda *a, **k: {"evaluated": True})
    assert ship.main([str(run), *ARGS]) == 0
    capsys.readouterr()
    shipped = ship.SHIPPED_DIR
    assert (shipped / "solar_uav_policy.pt").read_bytes() == (run / "best_policy.pt").read_bytes()
    assert onnx_source_digest(shipped / "solar_uav_policy.onnx") == policy_digest(shipped / "solar_uav_policy.pt")
    record = json.loads((shipped / "solar_uav_policy.json").read_text())
    assert record["evaluation"] == {"evaluated": True} and record["frames"] == 100 and record["commit"] == "abc123"
    assert sorted(p.name for p in shipped.iterdir()) == sorted(OLD) and _no_staging(ship)

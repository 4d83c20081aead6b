"""Robustness sweeps: the grid, the conditions, the table, and the same numbers on every backend."""

import csv
import json
import sys
from pathlib import Path

import pytest

from jsbsim_env.sim.core import CoreConfig
from training.evaluation.sweep import (
    AXES,
    AXIS_UNITS,
    SWEEP_EPISODE_SEED,
    breaking_points,
    condition_config,
    grid,
    jobs_for,
    parse_axis,
    run_job,
    run_local,
)


def test_axes_parse_and_bad_ones_are_refused():
    assert parse_axis("delay_ms=0, 100,300") == ("delay_ms", [0.0, 100.0, 300.0])
    with pytest.raises(ValueError, match="unknown axis 'delay'"):
        parse_axis("delay=1,2")
    with pytest.raises(ValueError, match="values must be numbers"):
        parse_axis("noise_scale=1,lots")
    with pytest.raises(ValueError, match="at least one finite value"):
        parse_axis("backlash_deg=")


def test_the_grid_is_every_combination_in_order():
    g = grid({"delay_ms": [0.0, 100.0], "noise_scale": [1.0, 2.0, 4.0]})
    assert len(g) == 6 and g[0] == {"delay_ms": 0.0, "noise_scale": 1.0} and g[-1] == {"delay_ms": 100.0,
                                                                                     "noise_scale": 4.0}
    assert len(jobs_for(["policy", "pid"], g, episodes=12, chunk=5)) == 2 * 6 * 3


def test_each_axis_sets_what_it_names():
    core = condition_config({"delay_ms": 200, "control_interval_ms": 80, "noise_scale": 0, "parameter_strength": 2,
                             "turbulence_sigma_mps": 0, "backlash_deg": 0.5, "altitude_m": 15000,
                             "eas_mps": 12, "servo_rate_limit_degps": 40}).core
    assert core.delay_s == (0.2, 0.2) and core.control_interval_s == (0.08, 0.08)
    assert not core.sensor_noise and not core.turbulence and core.parameter_strength == 2.0
    assert core.backlash_deg == 0.5 and core.altitude_range_m == (15000.0, 15000.0) and core.eas_range_mps == (12.0, 12.0)
    assert core.servo_rate_limit_degps == 40.0
    with pytest.raises(ValueError, match="must be >= 0"):
        CoreConfig(noise_scale=-1.0)
    with pytest.raises(ValueError, match="servo_rate_limit_degps must be positive"):
        CoreConfig(servo_rate_limit_degps=0.0)


def test_parameter_strength_zero_flies_the_nominal_aircraft():
    from jsbsim_env.sim.core import FlightCore

    core = FlightCore(condition_config({"parameter_strength": 0.0}).core)
    core.reset(SWEEP_EPISODE_SEED)
    assert all(v == 1.0 for v in core.setup.scales.values())
    core = FlightCore(condition_config({"parameter_strength": 2.0}).core)
    core.reset(SWEEP_EPISODE_SEED)
    drawn = FlightCore(CoreConfig())
    drawn.reset(SWEEP_EPISODE_SEED)
    for name, v in drawn.setup.scales.items():
        assert core.setup.scales[name] == pytest.approx(1.0 + 2.0 * (v - 1.0))


def test_rows_have_the_tables_schema_and_do_not_depend_on_the_processes():
    from training.evaluation.sweep import Job

    jobs = jobs_for(["pid"], grid({"delay_ms": [0.0, 300.0]}), episodes=2, chunk=1)
    one = run_local(jobs, workers=1)
    two = run_local(jobs, workers=2)
    assert one == two and len(one) == 4
    row = one[0]
    for key in ("controller", "axis_delay_ms", "episode", "return_norm", "ended_early", "end_reason", "rmse_roll_deg",
                "rmse_pitch_deg", "rmse_airspeed_eas_mps", "rmse_beta_deg", "final_error_pitch_deg",
                "smoothness_elevator"):
        assert key in row
    assert run_job(Job("pid", {"delay_ms": 300.0}, 1, 1)) == [r for r in one if r["axis_delay_ms"] == 300.0
                                                             and r["episode"] == 1]


def test_breaking_points_are_the_first_value_with_an_early_end():
    rows = [{"controller": "a", "axis_x": v, "ended_early": v >= 2} for v in (1, 2, 3)] + \
           [{"controller": "b", "axis_x": v, "ended_early": False} for v in (1, 2, 3)]
    assert breaking_points(rows, "x") == {"a": 2, "b": None}


def test_the_sweep_command_writes_its_table_and_the_ray_backend_gives_the_same_numbers(tmp_path, capsys, load_script):
    pytest.importorskip("ray")
    script = load_script("sweep")
    common = ["--axis", "backlash_deg=0,1", "--controllers", "pid", "--episodes", "1", "--json"]
    assert script.main([*common, "--out", str(tmp_path / "local")]) == 0
    local = json.loads(capsys.readouterr().out)
    assert script.main([*common, "--out", str(tmp_path / "ray"), "--backend", "ray"]) == 0
    capsys.readouterr()
    rows = [list(csv.DictReader((tmp_path / b / "sweep.csv").open())) for b in ("local", "ray")]
    assert rows[0] == rows[1] and len(rows[0]) == 2
    assert local["flights"] == 2 and (tmp_path / "local" / "backlash_deg.png").stat().st_size > 0
    assert (tmp_path / "local" / "command.txt").read_text().startswith("python scripts/sweep.py --axis backlash_deg")


def test_the_sweep_command_refuses_bad_input(tmp_path, capsys, load_script):
    script = load_script("sweep")
    assert script.main(["--out", str(tmp_path)]) == 2
    assert "give at least one --axis" in capsys.readouterr().err
    assert script.main(["--axis", "delay_ms=0", "--controllers", "lqr", "--out", str(tmp_path)]) == 2
    assert "--controllers takes any of policy, pid, lqi" in capsys.readouterr().err


def test_a_missing_ray_is_a_clear_message(monkeypatch):
    from training.evaluation.sweep import run_ray

    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(RuntimeError, match=r"pip install '.\[ray\]'"):
        run_ray([])


@pytest.mark.parametrize("backend", ["local", "ray"])
def test_several_seeds_train_as_their_own_runs_and_resume(backend, tmp_path, capsys, load_script, tiny_args):
    if backend == "ray":
        pytest.importorskip("ray")
    script = load_script("train_torchrl")
    args = ["--seeds", "3,4", "--backend", backend, "--run-name", "tiny", "--log.run_root", str(tmp_path),
            *tiny_args(96, seed=None), "--json"]
    assert script.main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [Path(r["run"]).name for r in summary["runs"]] == ["tiny_seed3", "tiny_seed4"]
    assert all(r["frames"] == 96 for r in summary["runs"]) and summary["final_eval_return"]["seeds"] == 2
    assert (tmp_path / "tiny_fig8.png").stat().st_size > 0
    configs = [json.loads((tmp_path / f"tiny_seed{s}" / "config.json").read_text()) for s in (3, 4)]
    assert [c["seed"] for c in configs] == [3, 4]
    # The same command with more frames resumes both.
    assert script.main([*args[:-1], "--collector.total_frames", "128", "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert all(r["frames"] == 128 for r in again["runs"])


def test_every_axis_has_its_unit():
    assert list(AXIS_UNITS) == list(AXES)

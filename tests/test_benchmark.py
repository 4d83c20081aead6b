"""The fair benchmark: its route windows hold no corner, its step metrics, and the command's
output, identical on the local and Ray backends."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from jsbsim_env.control.factory import make_controller
from jsbsim_env.control.stack import StackSettings
from training.evaluation.benchmark import (
    FAMILIES,
    BenchJob,
    BenchmarkPlan,
    corner_free,
    corner_window,
    first_corner_s,
    flown_labels,
    jobs_for,
    route_config,
    step_metrics,
    verdict_counts,
)
from training.evaluation.seeds import TEST_SEEDS


@pytest.mark.parametrize("quick", [True, False])
def test_every_route_window_is_on_the_first_leg_and_the_flight_ends_before_its_corner(quick):
    """The full-size windows, checked on the routes' own geometry: the flight ends at the window's
    end, and the first leg's corner (where the next leg begins, one turn radius before its end) is
    further than that flight reaches at its true airspeed."""
    plan = BenchmarkPlan.quick() if quick else BenchmarkPlan()
    for family in ("turbulence", "calm", "table9", "robustness"):
        assert FAMILIES[family].window in ("leg", "calm")
        for condition in FAMILIES[family].conditions:
            config = route_config(BenchJob(family, condition, "pid", 0, quick), plan)
            window = plan.calm_window_s if family == "calm" else plan.leg_window_s
            assert config.duration_s == window[1] and config.seed == TEST_SEEDS[0]
            assert first_corner_s(config) > window[1] * 1.5, (family, condition)  # a margin for the turbulence
    for condition in FAMILIES["corner"].conditions:  # the corner family's flights reach their corner
        config = route_config(BenchJob("corner", condition, "pid", 0, quick), plan)
        assert config.duration_s > first_corner_s(config) + plan.corner_window_s


def test_flown_windows_contain_no_corner():
    from jsbsim_env.control.pid import PIDAttitudeController
    from jsbsim_env.missions import RouteConfig, fly_route

    plan = BenchmarkPlan.quick()
    config = route_config(BenchJob("turbulence", {"altitude_m": 10000.0}, "pid", 0, True), plan)
    result = fly_route(PIDAttitudeController(), config)
    assert corner_free(result, *plan.leg_window_s)
    # A window over the first corner is refused: 10 km, 400 s passes the corner (about 327 s).
    long = fly_route(PIDAttitudeController(), RouteConfig(duration_s=400.0, seed=TEST_SEEDS[0]))
    assert corner_free(long, 20.0, 320.0) and not corner_free(long, 20.0, 400.0)
    start, end = corner_window(long, 60.0)
    assert abs(start - first_corner_s(long.config)) < 5.0 and end == start + 60.0
    assert corner_window(long, 100.0) is None  # the flight ends before such a window does
    assert corner_window(result, 5.0) is None  # no corner at all


def test_step_metrics_of_a_known_response():
    t = np.arange(0.0, 30.0, 0.01)
    wn, zeta = 2.0, 0.5
    s = np.clip(t - 10.0, 0.0, None)
    wd = wn * math.sqrt(1 - zeta ** 2)
    y = 5.0 * (1 - np.exp(-zeta * wn * s) * (np.cos(wd * s) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * s)))
    m = step_metrics(t, y, 10.0, 5.0, 0.05, 20.0)
    assert m["overshoot_pct"] == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)), abs=0.05)
    assert 0.5 < m["rise_time_s"] < 1.0 and 2.0 < m["settling_time_s"] < 4.5 and m["itae_deg_s2"] > 0
    never = step_metrics(t, np.where(t >= 10.0, 2.5, 0.0), 10.0, 5.0, 0.05, 20.0)
    assert never["settling_time_s"] == 20.0 and math.isnan(never["rise_time_s"])  # censored at the window


def test_jobs_fly_only_the_test_seeds():
    jobs = jobs_for(["steps"], ["pid", "policy"], 3)
    assert len(jobs) == 2 * 3 * len(FAMILIES["steps"].conditions)
    assert {TEST_SEEDS[j.realisation] for j in jobs} == set(TEST_SEEDS[:3])
    with pytest.raises(ValueError):
        jobs_for(["steps"], ["pid"], len(TEST_SEEDS) + 1)


def test_the_validation_split_flies_its_own_seeds_apart_from_the_test_set():
    from training.evaluation.benchmark import seed_of
    from training.evaluation.seeds import VALIDATION_SEEDS, overlaps_test_seeds

    jobs = jobs_for(["calm"], ["pid"], 2, split="validation")
    seeds = {seed_of(j.realisation, j.split) for j in jobs}
    assert seeds == set(VALIDATION_SEEDS[:2]) and not overlaps_test_seeds(VALIDATION_SEEDS)
    plan = BenchmarkPlan.quick()
    assert route_config(jobs[0], plan).seed == VALIDATION_SEEDS[0]
    with pytest.raises(ValueError, match="split"):
        jobs_for(["calm"], ["pid"], 2, split="train")


def test_the_benchmark_command_writes_its_outputs_and_ray_gives_the_same_numbers(tmp_path, capsys, load_script):
    pytest.importorskip("ray")
    from jsbsim_env.control.factory import CONTROLLER_NAMES

    script = load_script("benchmark")
    controllers = ",".join(c for c in CONTROLLER_NAMES if c in ("pid", "policy"))
    common = ["--controllers", controllers, "--families", "turbulence,steps", "--episodes", "2", "--quick", "--json"]
    assert script.main([*common, "--out", str(tmp_path / "local")]) == 0
    local = json.loads(capsys.readouterr().out)
    assert script.main([*common, "--out", str(tmp_path / "ray"), "--backend", "ray"]) == 0
    capsys.readouterr()
    rows = [json.loads((tmp_path / b / "benchmark.json").read_text())["rows"] for b in ("local", "ray")]
    assert rows[0] == rows[1] and len(rows[0]) == 2 * 2 * (3 + 4)
    assert all(r["corner_free"] for r in rows[0])
    pair = "pid - policy" if controllers.startswith("pid") else "policy - pid"
    d = local["summary"]["turbulence"]["10 km"]["pairs"][pair]["rmse_roll_deg"]
    assert d["n"] == 2 and d["verdict"] in ("better", "worse", "no difference")
    for name in ("benchmark.md", "command.txt", "turbulence.png", "steps.png"):
        assert (tmp_path / "local" / name).stat().st_size > 0
    text = (tmp_path / "local" / "benchmark.md").read_text()
    assert "| 10 km | rmse_roll_deg |" in text
    n = verdict_counts(local["summary"], "turbulence", "policy", "pid")
    assert sum(n.values()) == 3 * 3  # three altitudes, three scores
    assert f"| turbulence | {n['better']} better, {n['worse']} worse, {n['no difference']} = |" in text
    assert (tmp_path / "local" / "command.txt").read_text().startswith("python scripts/benchmark.py --controllers")
    # Never overwritten without --overwrite, checked before the first flight.
    assert script.main([*common, "--out", str(tmp_path / "local")]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_the_benchmark_command_refuses_bad_input(tmp_path, capsys, load_script):
    script = load_script("benchmark")
    assert script.main(["--controllers", "nonesuch", "--out", str(tmp_path)]) == 2
    assert "--controllers takes any of" in capsys.readouterr().err
    assert script.main(["--families", "turbulence,turbulence", "--out", str(tmp_path)]) == 2
    assert "each once" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.main(["--episodes", str(len(TEST_SEEDS) + 1), "--out", str(tmp_path)])


def test_a_flight_that_leaves_its_leg_inside_the_window_counts_as_an_early_end(monkeypatch):
    """A controller that flies the leg too fast reaches the corner inside the window: the job is
    not scored on a window with a corner, it is counted as not having flown the condition."""
    from training.evaluation import benchmark

    monkeypatch.setattr(benchmark, "corner_free", lambda result, start, end: False)
    job = benchmark.BenchJob("calm", {"altitude_m": 1000.0}, "pid", 0, quick=True)
    (row,) = benchmark.run_benchmark_job(job)
    assert row["ended_early"].startswith("left the first leg") and row["corner_free"]
    assert all(math.isnan(row[k]) for k in benchmark.FAMILIES["calm"].metrics)


def test_compare_flies_more_policy_files_as_controllers_of_their_own(tmp_path, capsys, load_script, untrained_policy):
    script = load_script("benchmark")
    a = untrained_policy(tmp_path / "runA" / "best_policy.pt", seed=1)
    b = untrained_policy(tmp_path / "candidate.pt", seed=2)
    assert script.compare_labels([a, b], ["pid"]) == {"runA": str(a), "candidate": str(b)}
    picked = a.parent / "picked_policy.pt"  # scripts/heldout.py --checkpoints's choice, beside the best
    assert script.compare_labels([a, picked], ["pid"]) == {"runA": str(a), "runA_picked": str(picked)}
    with pytest.raises(ValueError, match="'candidate'"):
        script.compare_labels([b, b], ["pid"])
    jobs = jobs_for(["calm"], ["pid"], 1, True, "validation", {"runA": str(a)})
    assert [(j.controller, j.policy_path, j.label) for j in jobs[:2]] == [("pid", None, None), ("policy", str(a), "runA")]
    out = tmp_path / "bench"
    assert script.main(["--controllers", "pid", "--compare", str(a), str(b), "--families", "calm", "--episodes", "2",
                        "--quick", "--split", "validation", "--json", "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)["summary"]["calm"]["1 km"]
    assert set(summary["controllers"]) == {"pid", "runA", "candidate"} and "runA - candidate" in summary["pairs"]
    record = json.loads((out / "benchmark.json").read_text())
    assert record["split"] == "validation" and {r["seed"] for r in record["rows"]} == {800_000, 800_001}
    assert script.main(["--controllers", "pid", "--compare", str(tmp_path / "missing.pt"), "--out",
                        str(tmp_path / "x")]) == 2
    assert "missing.pt" in capsys.readouterr().err


def test_network_alone_flies_each_policy_without_its_classical_stages(tmp_path, capsys, load_script, untrained_policy):
    from jsbsim_env.control.policy import PolicyRuntime
    from jsbsim_env.task.versions import V1, V3

    script = load_script("benchmark")
    v1 = untrained_policy(tmp_path / "v1run" / "best_policy.pt", seed=1, task=V1.env_id)
    v3 = untrained_policy(tmp_path / "v3run" / "best_policy.pt", seed=1, task=V3.env_id)
    alone = PolicyRuntime(v1, backend="torch", network_alone=True).stack.settings
    assert PolicyRuntime(v1, backend="torch").stack.settings == V1.flight_stack
    assert alone == StackSettings(window_steps=V1.flight_stack.window_steps)
    # The error integrals are the network's input, not a classical stage: they stay.
    assert PolicyRuntime(v3, backend="torch", network_alone=True).stack.settings == V3.flight_stack
    jobs = jobs_for(["calm"], ["pid", "policy"], 1, True, "validation", {"v3run": str(v3)}, ("policy", "v3run"),
                    policy=str(v1))
    assert [(j.controller, j.policy_path, j.label, j.network_alone) for j in jobs[:5]] == [
        ("pid", None, None, False), ("policy", None, None, False), ("policy", str(v3), "v3run", False),
        ("policy", str(v1), "policy (network alone)", True), ("policy", str(v3), "v3run (network alone)", True)]
    assert flown_labels(jobs) == ["pid", "policy", "v3run", "policy (network alone)", "v3run (network alone)"]
    out = tmp_path / "bench"
    assert script.main(["--controllers", "pid,policy", "--policy", str(v1), "--network-alone", "--families", "calm",
                        "--episodes", "1", "--quick", "--split", "validation", "--out", str(out)]) == 0
    record = json.loads((out / "benchmark.json").read_text())
    assert record["controllers"] == ["pid", "policy", "policy (network alone)"]
    assert [s["controller"] for s in record["selection"]] in (["policy", "policy (network alone)"],
                                                             ["policy (network alone)", "policy"])
    assert "## Against the best classical controller" in (out / "benchmark.md").read_text()
    capsys.readouterr()
    assert script.main(["--controllers", "pid", "--network-alone", "--out", str(tmp_path / "x")]) == 2
    assert "--network-alone needs a policy with classical stages" in capsys.readouterr().err
    assert script.main(["--controllers", "pid", "--compare", str(v3), "--network-alone", "--out",
                        str(tmp_path / "y")]) == 2  # v3 has no classical stage to take away
    with pytest.raises(ValueError, match="network_alone is a setting of a policy"):
        make_controller("pid", network_alone=True)


def test_the_mean_of_seeds_is_one_candidate_paired_on_each_realisation(tmp_path, capsys, load_script, untrained_policy):
    from training.evaluation.benchmark import mean_of_seeds

    def row(controller, realisation, roll, ended=""):
        return {"family": "turbulence", "condition": "1 km", "controller": controller, "realisation": realisation,
                "seed": 800_000 + realisation, "ended_early": ended, "corner_free": True,
                "rmse_roll_deg": roll, "rmse_pitch_deg": 0.2, "rmse_beta_deg": 0.3}

    rows = [row("s1", 0, 0.1), row("s2", 0, 0.3), row("s1", 1, 0.2), row("s2", 1, math.nan, "pitch limit"),
            row("s1", 2, 0.2), row("pid", 0, 0.5)]  # realisation 2: s2 did not fly it
    name, mean = mean_of_seeds(rows, ["s1", "s2"])
    assert name == "mean(s1,s2)" and [r["realisation"] for r in mean] == [0, 1]
    assert mean[0]["rmse_roll_deg"] == pytest.approx(0.2) and mean[0]["rmse_pitch_deg"] == pytest.approx(0.2)
    assert math.isnan(mean[1]["rmse_roll_deg"]) and mean[1]["ended_early"] == "s2: pitch limit"
    for labels in (["s1"], ["s1", "s1"], ["s1", "s9"]):
        with pytest.raises(ValueError):
            mean_of_seeds(rows, labels)

    script = load_script("benchmark")
    a = untrained_policy(tmp_path / "runA" / "best_policy.pt", seed=1)
    b = untrained_policy(tmp_path / "runB" / "best_policy.pt", seed=2)
    out = tmp_path / "bench"
    assert script.main(["--controllers", "pid", "--compare", str(a), str(b), "--mean-of", "runA,runB", "--families",
                        "calm", "--episodes", "2", "--quick", "--split", "validation", "--json", "--out", str(out)]) == 0
    record = json.loads(capsys.readouterr().out)
    summary = record["summary"]["calm"]["1 km"]
    assert "mean(runA,runB)" in summary["controllers"] and "pid - mean(runA,runB)" in summary["pairs"]
    means = [summary["controllers"][c]["metrics"]["mae_roll_deg"]["mean"] for c in ("runA", "runB", "mean(runA,runB)")]
    assert means[2] == pytest.approx((means[0] + means[1]) / 2)
    assert "mean(runA,runB)" in {s["controller"] for s in record["selection"]}
    for bad in ("runA", "runA,runC", "runA,runA"):
        assert script.main(["--controllers", "pid", "--compare", str(a), str(b), "--mean-of", bad, "--out",
                            str(tmp_path / "x")]) == 2
        assert "--mean-of" in capsys.readouterr().err

"""``scripts/tune_classical.py``: the PID and the LQI re-tuned by CMA-ES on the held-out flights,
with the budget recorded, the robustness cases enforced and the frozen test seeds refused."""

from __future__ import annotations

import json
import math
import runpy
from pathlib import Path

import numpy as np
import pytest

from jsbsim_env.control import factory, gain_files
from jsbsim_env.control.lqi import GAIN_COLUMNS, LQIAttitudeController
from jsbsim_env.control.lqi import GAINS_PATH as LQI_GAINS_PATH
from jsbsim_env.control.pid import GAINS_PATH as PID_GAINS_PATH
from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.missions import RouteConfig, fly_route
from training.evaluation import classical_tuning, heldout
from training.evaluation.seeds import TEST_SEEDS

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "tune_classical.py"


def _main(argv: list[str]) -> int:
    return runpy.run_path(str(SCRIPT))["main"](argv)


@pytest.mark.parametrize("controller", ["pid", "lqi"])
def test_a_quick_tuning_writes_a_gain_file_the_controller_flies(controller, tmp_path, monkeypatch, capsys):
    pytest.importorskip("cma")
    out = tmp_path / f"{controller}_tuned.json"
    assert _main(["--controller", controller, "--budget", "2", "--quick", "--out", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    table = json.loads(out.read_text())
    budget = table["tuning"]["budget"]
    assert budget["candidate_evaluations"] == 2 and budget["flights_per_evaluation"] == len(heldout.heldout_flights())
    assert budget["evaluations_flown"] == 2 + 2 - budget["candidates_not_robust"]
    assert budget["wall_clock_s"] > 0 and budget["workers"] == 1 and budget["quick"] is True
    assert {f["seed"] for f in budget["flights"].values()} == set(heldout.SEEDS.values())
    assert table["robustness_radius"] < classical_tuning.STABLE_RADIUS
    assert table["tuning"]["score"] <= table["tuning"]["start_score"]
    if controller == "pid":  # the PID's start is the shipped PID, the reference itself
        assert table["tuning"]["start_score"] == 1.0

    # The controller flies it, by its class and by its factory name.
    cls = PIDAttitudeController if controller == "pid" else LQIAttitudeController
    result = fly_route(cls(gains_path=out), RouteConfig(altitude_m=5000.0, duration_s=5.0))
    assert result.ended_early is None
    monkeypatch.setitem(factory.TUNED_GAIN_FILES, f"{controller}_tuned", out)
    assert isinstance(factory.make_controller(f"{controller}_tuned"), cls)
    # An existing file is not replaced without --overwrite.
    with pytest.raises(SystemExit) as exc:
        _main(["--controller", controller, "--budget", "2", "--quick", "--out", str(out)])
    assert exc.value.code == 2


def test_the_start_points_are_the_shipped_tables():
    shipped = json.loads(PID_GAINS_PATH.read_text())
    assert classical_tuning.pid_table(shipped, np.zeros(len(classical_tuning.PID_PARAMETERS)))["points"] == \
        shipped["points"]
    lqi_problem = classical_tuning.Problem("lqi")
    redesigned = json.loads(json.dumps(lqi_problem.design(lqi_problem.x0)))  # as written and read back
    shipped_lqi = json.loads(LQI_GAINS_PATH.read_text())
    # The Riccati solution differs between CPUs in its last digits (3e-10 relative seen); any change
    # of the design (a weight, a model point) moves the gains by far more than 1e-7.
    np.testing.assert_allclose([[p[c] for c in GAIN_COLUMNS] for p in redesigned["points"]],
                               [[p[c] for c in GAIN_COLUMNS] for p in shipped_lqi["points"]], rtol=1e-7, atol=1e-12)
    # Rate damping grows from the shipped (near zero) gain, in seconds of the attitude gain.
    x = np.zeros(len(classical_tuning.PID_PARAMETERS))
    x[[p.name for p in classical_tuning.PID_PARAMETERS].index("pitch_rate")] = 1.0
    point, base = classical_tuning.pid_table(shipped, x)["points"][0], shipped["points"][0]
    assert math.isclose(point["k_q"], base["k_q"] + classical_tuning.RATE_TAU_S * base["k_pitch"])


def test_a_candidate_failing_robustness_scores_infinite_without_flying(monkeypatch):
    def no_flight(*args):
        raise AssertionError("a candidate that fails the robustness cases is not flown")

    monkeypatch.setattr(classical_tuning, "fly_table", no_flight)
    problem = classical_tuning.Problem("pid")
    x = np.zeros(len(problem.parameters))
    x[[p.name for p in problem.parameters].index("pitch")] = classical_tuning.LOG_BOUND  # pitch gain x20
    with pytest.raises(classical_tuning.NotRobust):
        problem.design(x)
    [evaluation] = classical_tuning.evaluate_candidates(problem, [x], reference={})
    assert evaluation.score == math.inf and evaluation.reason.startswith("not robust")
    assert evaluation.told >= classical_tuning.PENALTY


def test_the_tuning_refuses_the_frozen_test_seeds(monkeypatch, tmp_path, capsys):
    with pytest.raises(ValueError, match="tune_classical: seed 900000 reach into the frozen test set"):
        classical_tuning.refuse_test_seeds(TEST_SEEDS.start)
    monkeypatch.setitem(heldout.SEEDS, "calm", TEST_SEEDS.start + 5)
    with pytest.raises(ValueError, match=r"^tune_classical: .*frozen test set"):
        classical_tuning.tune("pid", budget=2, quick=True)
    out = tmp_path / "pid.json"
    assert _main(["--controller", "pid", "--budget", "2", "--quick", "--out", str(out)]) == 2
    assert "tune_classical" in capsys.readouterr().err and not out.exists()


def test_tuned_controllers_need_their_gain_file(monkeypatch, tmp_path):
    monkeypatch.setitem(gain_files.FILES, "pid_tuned", "none.json")
    with pytest.raises(factory.TunedGainsMissing, match=r"scripts/tune_classical.py --controller pid"):
        factory.make_controller("pid_tuned")
    with pytest.raises(SystemExit) as exc:  # the shipped tables are never the output
        _main(["--controller", "pid", "--budget", "2", "--out", str(PID_GAINS_PATH)])
    assert exc.value.code == 2
    with pytest.raises(ValueError, match="shipped gain table"):
        classical_tuning.write_tuned_table({}, PID_GAINS_PATH)


def test_the_tuning_says_how_much_of_its_budget_it_flies(monkeypatch):
    class Stop(Exception):
        pass

    def no_flight(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(classical_tuning, "reference_scores", no_flight)
    said = []
    popsize = classical_tuning.default_popsize(len(classical_tuning.PID_PARAMETERS))
    with pytest.raises(Stop):
        classical_tuning.tune("pid", budget=popsize + 5, quick=True, progress=said.append)
    expected = (f"budget {popsize + 5}: 1 CMA-ES generation of {popsize} candidates, {popsize} in all (5 left "
                "unspent: CMA-ES flies whole generations)")
    assert said == [expected]


def test_the_robust_flights_are_the_held_out_ones_in_conditions_drawn_from_training():
    from jsbsim_env.task.versions import LATEST, task_version

    core = task_version(LATEST).task.core
    nominal, robust = heldout.heldout_flights(), heldout.heldout_flights(flights="robust")
    assert list(robust) == list(nominal)
    seeds = {config.seed for config in robust.values()}
    assert seeds == set(heldout.ROBUST_SEEDS.values()) and not seeds & set(heldout.SEEDS.values())
    assert not seeds & set(TEST_SEEDS)
    for name, config in robust.items():
        assert core.delay_s[0] <= config.delay_s <= core.delay_s[1]
        assert core.control_interval_s[0] <= 1.0 / config.control_rate_hz <= core.control_interval_s[1]
        assert config.altitude_m == nominal[name].altitude_m
        assert config.parameters == ("table4" if nominal[name].parameters == "nominal" else nominal[name].parameters)
        assert bool(config.turbulence_legs) == (name != "calm_15km")  # the calm flight measures chatter
    assert len({config.delay_s for config in robust.values()}) == len(robust)  # each flight its own draw
    assert heldout.heldout_flights(flights="robust") == robust  # the same draws every time


@pytest.mark.parametrize("flights", ["robust", "stressed"])
def test_a_quick_tuning_on_other_flights_records_them_and_writes_a_table_the_lqi_flies(flights, tmp_path):
    pytest.importorskip("cma")
    out = tmp_path / f"lqi_{flights}.json"
    assert _main(["--controller", "lqi", "--flights", flights, "--budget", "2", "--quick", "--out", str(out)]) == 0
    record = json.loads(out.read_text())["tuning"]
    assert record["flights"] == flights
    seeds = {"robust": set(heldout.ROBUST_SEEDS.values()),
             "stressed": {*heldout.SEEDS.values(), *heldout.STRESSED_SEEDS.values()}}[flights]
    recorded = record["budget"]["flights"]
    assert {f["seed"] for f in recorded.values()} == seeds
    assert record["budget"]["flights_per_evaluation"] == len(recorded) == len(heldout.heldout_flights(flights=flights))
    # Each stressed flight records its stress beside the delay it would otherwise fly with.
    assert {name: f["stress"] for name, f in recorded.items() if "stress" in f} == (
        {"turbulent_5km_delay_ms": {"delay_ms": 200.0},
         "turbulent_5km_servo_rate_limit_degps": {"servo_rate_limit_degps": 10.0}} if flights == "stressed" else {})
    assert LQIAttitudeController(gains_path=out).schedule is not None


def test_the_stressed_tuning_is_the_lqis(tmp_path):
    assert runpy.run_path(str(SCRIPT))["FLIGHT_SETS"] == heldout.FLIGHT_SETS  # spelled out there, to parse quickly
    with pytest.raises(SystemExit) as exc:
        _main(["--controller", "pid", "--flights", "stressed", "--budget", "2", "--quick", "--out", str(tmp_path / "p.json")])
    assert exc.value.code == 2
    assert not (tmp_path / "p.json").exists()


def test_the_robust_tuned_controllers_fly_by_name_from_their_shipped_tables():
    assert {"pid_robust", "lqi_robust"} <= set(factory.CONTROLLER_NAMES)
    for name, cls in (("pid_robust", PIDAttitudeController), ("lqi_robust", LQIAttitudeController)):
        assert isinstance(factory.make_controller(name), cls)
        record = json.loads(gain_files.gain_file(name).read_text())["tuning"]
        assert record["flights"] == "robust" and record["budget"]["candidate_evaluations"] == 100
        assert record["score"] < record["start_score"]


def test_the_stressed_flights_are_the_held_out_ones_and_the_turbulent_one_at_the_benchmarks_stresses():
    from training.evaluation.benchmark import STRESSED, StressedRoute

    nominal, stressed = heldout.heldout_flights(), heldout.heldout_flights(flights="stressed")
    assert {name: stressed[name] for name in nominal} == nominal  # the held-out four, as they are
    extra = {name: config for name, config in stressed.items() if name not in nominal}
    assert sorted(extra) == sorted(f"turbulent_5km_{axis}" for axis in heldout.STRESSED_SEEDS)
    for name, config in extra.items():
        axis = name.removeprefix("turbulent_5km_")
        assert isinstance(config, StressedRoute) and config.stress == ((axis, STRESSED[axis]),)
        assert config.seed == heldout.STRESSED_SEEDS[axis] and config.seed not in TEST_SEEDS
        assert config.altitude_m == nominal["turbulent_5km"].altitude_m and config.turbulence_legs == (0,)
        assert config.duration_s == heldout.STRESSED_FLIGHT_S
    core = extra["turbulent_5km_servo_rate_limit_degps"].core_config()
    assert core.servo_rate_limit_degps == pytest.approx(STRESSED["servo_rate_limit_degps"])
    assert extra["turbulent_5km_delay_ms"].core_config().delay_s == pytest.approx((0.2, 0.2))
    with pytest.raises(ValueError, match="one of heldout, robust, stressed"):
        heldout.heldout_flights(flights="gusty")


def test_a_score_against_a_reference_that_has_not_flown_its_flights_is_refused():
    scores = {"ended_early": False, "turbulent_5km": {"rmse_roll_deg": 0.1}, "turbulent_5km_delay_ms": {"rmse_roll_deg": 0.2},
              "surface_activity": {s: 1.0 for s in heldout.SURFACES}}
    reference = {"ended_early": False, "turbulent_5km": {"rmse_roll_deg": 0.2}, "surface_activity": scores["surface_activity"]}
    with pytest.raises(ValueError, match="has not flown turbulent_5km_delay_ms"):
        heldout.relative_score(scores, reference)
    reference["turbulent_5km_delay_ms"] = {"rmse_roll_deg": 0.2}
    assert heldout.relative_score(scores, reference) == pytest.approx(math.sqrt(0.5))


def test_a_missing_stressed_table_says_how_to_write_it(tmp_path, monkeypatch):
    monkeypatch.setattr(gain_files, "PACKAGED_DIR", tmp_path)
    with pytest.raises(gain_files.GainsMissing, match="tune_classical.py --controller lqi --flights stressed`"):
        gain_files.gain_file("lqi_stressed")
    with pytest.raises(gain_files.GainsMissing, match="tune_classical.py --controller pid`"):
        gain_files.gain_file("pid_tuned")


def test_the_stressed_lqi_flies_by_name_from_its_shipped_table_and_kept_every_stressed_flight():
    assert isinstance(factory.make_controller("lqi_stressed"), LQIAttitudeController)
    record = json.loads(gain_files.gain_file("lqi_stressed").read_text())["tuning"]
    assert record["flights"] == "stressed" and record["budget"]["candidate_evaluations"] == 100
    assert record["score"] < record["start_score"] and not record["scores"]["ended_early"]
    assert set(record["scores"]) >= {f"turbulent_5km_{axis}" for axis in heldout.STRESSED_SEEDS}

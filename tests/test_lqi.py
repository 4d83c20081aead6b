"""The gain-scheduled LQI baseline (``jsbsim_env.control.lqi``): its design on the linear models
(robustness, steps without steady error, the feedforward's faster start), its flight on the
aircraft, its anti-windup and its gain file."""

import json
import math

import numpy as np
import pytest

from jsbsim_env.control import lqi, tuning
from jsbsim_env.control.factory import CONTROLLER_NAMES, make_controller
from jsbsim_env.sim.core import COMMAND_HIGH, COMMAND_LOW
from jsbsim_env.sim.simulation import Simulation
from training import runtime

ALTITUDES_M = (500.0, 5000.0, 20000.0)


@pytest.fixture(scope="module")
def plants():
    sim = Simulation()
    return {h: tuning.LinearPlant.at(sim, h, 10.0) for h in ALTITUDES_M}


@pytest.mark.parametrize("altitude_m", ALTITUDES_M)
@pytest.mark.parametrize("lateral", [False, True], ids=["longitudinal", "lateral"])
def test_design_is_stable_with_the_pid_robustness_margins(plants, altitude_m, lateral):
    design = lqi.robust_block(plants[altitude_m], lateral)
    radii = design.radii()
    assert radii["nominal"] < lqi.STABLE_RADIUS
    assert radii["gain_x2"] < lqi.STABLE_RADIUS
    assert radii["delay_plus2"] < lqi.STABLE_RADIUS
    # and the analysis would see an unstable loop: four times the gain and much more delay break it
    assert max(tuning.spectral_radius(design.closed(factor=50.0)[0]),
               tuning.spectral_radius(design.closed(delay_steps=40)[0])) > 1.0


def _step(design: lqi.BlockDesign, ref: np.ndarray, seconds: float) -> np.ndarray:
    a, b = design.closed()
    return tuning.step_response(a, b, ref, int(seconds / design.dt_s))


@pytest.mark.parametrize("altitude_m", ALTITUDES_M)
def test_roll_and_pitch_steps_settle_without_error_and_feedforward_starts_them_faster(plants, altitude_m):
    plant = plants[altitude_m]
    for lateral, ref, index in ((True, np.array([math.radians(5.0), 0.0]), 1),
                                (False, np.array([math.radians(2.0), 0.0]), 2)):
        with_ff = lqi.BlockDesign(plant, lateral)
        without = lqi.BlockDesign(plant, lateral, feedforward=False)
        x_ff, x_no = _step(with_ff, ref, 60.0), _step(without, ref, 60.0)
        target = ref[0]
        for x in (x_ff, x_no):  # integrators: no steady error either way
            assert abs(x[-1, index] - target) < 0.01 * target
        # with the feedforward, the first two seconds track the step better
        early = int(2.0 / with_ff.dt_s)
        err_ff = np.mean(np.abs(x_ff[:early, index] - target))
        err_no = np.mean(np.abs(x_no[:early, index] - target))
        assert err_ff < 0.7 * err_no, (lateral, err_ff, err_no)


def test_holds_roll_and_pitch_goals_on_the_aircraft():
    from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
    from training.evaluation.suite import fly

    goal = np.array([math.radians(5.0), math.radians(2.0), 10.0])
    controller = make_controller("lqi")
    from jsbsim_env.sim.core import CoreConfig

    # calm air and the nominal aircraft, with the routes' one step of delay and sensor noise, a perturbed start
    core = CoreConfig.ideal(max_steps=1200, control_interval_s=(0.04, 0.04), delay_s=(0.04, 0.04), sensor_noise=True,
                            noise_reversion_per_s=1.0,  # as the routes: the task default is a random walk
                            perturb_attitude_deg=2.0, perturb_rate_degps=1.0, perturb_eas_mps=0.5)
    batch = AttitudeTaskBatch(1, TaskConfig(core=core))
    rec, end = fly(controller, batch, seed=5, steps=1200, goal_fn=lambda t: goal, altitude_m=5000.0,
                   airspeed_eas_mps=10.0)  # 48 s
    assert not end["terminated"], end
    t = np.array(rec.time_s)
    assert t[-1] > 47.0
    last = np.array(rec.true_state)[t > t[-1] - 10.0]
    assert np.max(np.abs(np.degrees(last[:, 1] - goal[0]))) < 0.2
    assert np.max(np.abs(np.degrees(last[:, 2] - goal[1]))) < 0.2
    assert np.max(np.abs(np.degrees(last[:, 8]))) < 0.2  # the sideslip integrator coordinates the turn


def test_anti_windup_bounds_the_integrators():
    controller = lqi.LQIAttitudeController()
    g = controller.schedule.at(5000.0)
    m = np.zeros(13)
    m[0], m[6] = 5000.0, 10.0
    # a roll error the ailerons cannot remove, held for a long time: the ailerons saturate
    for _ in range(5000):
        command = controller.update(0.04, m, np.array([math.radians(40.0), math.radians(20.0), 20.0]))
        assert np.all(command >= COMMAND_LOW) and np.all(command <= COMMAND_HIGH)
    assert abs(g[lqi._N_LONG + 8] * controller.z_roll) <= lqi.SURFACE_INTEGRATOR_LIMIT_DEG + 1e-9
    assert abs(g[8] * controller.z_pitch) <= lqi.SURFACE_INTEGRATOR_LIMIT_DEG + 1e-9
    assert abs(g[19] * controller.z_eas) <= lqi.THROTTLE_INTEGRATOR_LIMIT + 1e-9
    # a saturated actuator stops its integrator: it does not move while the command stays clipped
    held = controller.z_roll
    controller.update(0.04, m, np.array([math.radians(40.0), math.radians(20.0), 20.0]))
    assert controller.z_roll == held
    controller.reset()
    assert controller.z_roll == controller.z_pitch == controller.z_eas == controller.z_beta == 0.0


def test_gain_file_round_trips_and_records_its_margins(tmp_path):
    table = lqi.write_gain_table(tmp_path / "g.json", altitudes_m=(1000.0, 10000.0))
    schedule = lqi.LQIGainSchedule(tmp_path / "g.json")
    for row, values in zip(table["points"], schedule.values):
        assert values.tolist() == [row[n] for n in lqi.GAIN_COLUMNS]
        for block in ("long", "lat"):
            assert max(row["margins"][block][k] for k in ("nominal", "gain_x2", "delay_plus2")) < lqi.STABLE_RADIUS
    mid = schedule.at(5500.0)
    assert mid == pytest.approx([(a + b) / 2 for a, b in zip(schedule.values[0], schedule.values[1])])
    # the shipped table is this design at every design altitude
    shipped = json.loads(lqi.GAINS_PATH.read_text())
    assert [p["altitude_m"] for p in shipped["points"]] == list(lqi.DESIGN_ALTITUDES_M)
    fresh = lqi.design_point(Simulation(), 5000.0)
    assert [shipped["points"][3][n] for n in lqi.GAIN_COLUMNS] == pytest.approx([fresh[n] for n in lqi.GAIN_COLUMNS], rel=1e-4, abs=1e-9)
    assert shipped["points"][3]["margins"]["long"] == pytest.approx(fresh["margins"]["long"], rel=1e-4)
    (tmp_path / "bad.json").write_text('{"points": [{"altitude_m": 1}]}')
    with pytest.raises(ValueError):
        lqi.LQIGainSchedule(tmp_path / "bad.json")


def test_lqi_is_a_controller_by_name():
    assert "lqi" in CONTROLLER_NAMES
    c = make_controller("lqi")
    m = np.zeros(13)
    m[0], m[6] = 1000.0, 10.0
    with pytest.raises(ValueError):
        c.update(0.0, m, np.zeros(3))
    with pytest.raises(ValueError):
        c.update(0.04, np.full(13, np.nan), np.zeros(3))


def test_the_commands_take_the_lqi_by_name(load_script):
    evaluate = load_script("evaluate")
    assert runtime.CONTROLLER_NAMES == CONTROLLER_NAMES  # spelled out there for the commands' options
    assert evaluate.CONTROLLER_NAMES == CONTROLLER_NAMES
    loop_bench = load_script("loop_bench")
    for name in CONTROLLER_NAMES:
        assert loop_bench.build_parser().parse_args(["--controller", name]).controller == name
    assert evaluate.build_parser().parse_args(["--controller", "lqi"]).controller == "lqi"
    from training.evaluation.report import CONTROLLERS, EXTRA_CONTROLLERS

    assert "LQI" in EXTRA_CONTROLLERS and "LQI" not in CONTROLLERS  # the report flies it when named
    assert {name.lower() for name in EXTRA_CONTROLLERS} | {"pid", "policy"} == set(CONTROLLER_NAMES)
    bench = load_script("loop_bench").build_parser()
    (choices,) = [a.choices for a in bench._actions if a.dest == "controller"]
    assert tuple(choices) == CONTROLLER_NAMES  # spelled out there, to parse without loading the simulation

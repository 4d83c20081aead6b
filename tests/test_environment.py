"""The attitude-tracking environment: core disturbances, task, TorchRL and gymnasium interfaces."""

from __future__ import annotations

import math
import shutil
import xml.etree.ElementTree as ET
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
import torch

import aircraft
import jsbsim_env
from jsbsim_env.control.observation import OBS_SIZE, ActionError, action_to_command, command_to_action
from jsbsim_env.sim import disturbances as dist
from jsbsim_env.sim.core import NOISE_SIGMA, CommandError, CoreConfig, Envelope, FlightCore
from jsbsim_env.sim.simulation import TERRAIN_ELEVATION_M
from jsbsim_env.task.attitude import GOAL_HIGH, GOAL_LOW, AttitudeTask, TaskConfig, reward_terms
from jsbsim_env.task.metrics import EpisodeRecorder, actuator_smoothness, rmse, smoothness
from jsbsim_env.task.torchrl_env import SolarUAVAttitudeEnv, make_env


def _hold(task: AttitudeTask) -> np.ndarray:
    """Trim command plus wings-level feedback: keeps an episode going."""
    s, trim = task.core.last_true_state, task.core.setup.trim_command
    command = trim + np.array([1.5 * math.degrees(s[1]) + 0.5 * math.degrees(s[3]),
                               2.0 * math.degrees(s[2]) + 0.5 * math.degrees(s[4]), 0.0, 0.0])
    return np.clip(command_to_action(command), -1.0, 1.0)


def _fly(task: AttitudeTask, steps: int, seed: int) -> np.ndarray:
    obs, _ = task.reset(seed)
    out = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = task.step(_hold(task))
        out.append(np.append(obs, reward))
        if terminated or truncated:
            break
    return np.concatenate(out)


# ----------------------------------------------------------------------------- interfaces

def test_torchrl_specs_plain_and_with_training_transforms():
    from torchrl.envs.utils import check_env_specs

    check_env_specs(SolarUAVAttitudeEnv(2, seed=3))
    env = make_env(2, seed=3)
    check_env_specs(env)
    td = env.rollout(10, break_when_any_done=False)
    assert td["next", "observation"].shape == (2, 10, 8, OBS_SIZE)
    assert make_env(1, seed=3, window=3).rollout(2)["next", "observation"].shape == (1, 2, 3, OBS_SIZE)
    # The window holds the last 8 observations, oldest first.
    torch.testing.assert_close(td["next", "observation"][:, 3, -2], td["next", "observation"][:, 2, -1])
    assert td["next", "step_count"][:, -1].flatten().tolist() == [10, 10]
    torch.testing.assert_close(td["next", "episode_reward"][:, -1], td["next", "reward"].sum(1))


def test_torchrl_partial_reset_keeps_the_other_aircraft():
    env = SolarUAVAttitudeEnv(2, seed=5)
    env.reset()
    td = env.rand_step(env.reset())
    before = env.batch.cores[1].step_index
    from tensordict import TensorDict

    env.reset(TensorDict({"_reset": torch.tensor([[True], [False]])}, batch_size=[2]))
    assert env.batch.cores[0].step_index == 0 and env.batch.cores[1].step_index == before
    assert td["next", "reward_terms"].shape == (2, 4)


# The scaled observation has no hard bounds (rates, altitude), so its Box is unbounded on
# purpose; the checker's advice about that is the only thing it says.
@pytest.mark.filterwarnings("ignore:.*A Box observation space (minimum|maximum) value is:UserWarning")
def test_gymnasium_env_passes_check_env():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(jsbsim_env.ENV_ID)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=1)
    assert obs.shape == (OBS_SIZE,) and obs.dtype == np.float32 and "setup" in info
    obs, reward, _, _, info = env.step(np.zeros(4, np.float32))
    assert math.isclose(reward, 1.0 - sum(info[k] for k in ("penalty_roll", "penalty_pitch", "penalty_airspeed",
                                                             "penalty_beta")))


# ----------------------------------------------------------------------------- reproducibility

def test_same_seed_same_trajectory_bit_for_bit_and_different_seeds_differ():
    a, b = AttitudeTask(), AttitudeTask()
    first = _fly(a, 60, seed=11)
    _fly(a, 30, seed=99)  # a used instance ...
    again = _fly(a, 60, seed=11)  # ... replays the seed exactly
    other_instance = _fly(b, 60, seed=11)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(first, other_instance)
    assert not np.array_equal(first, _fly(b, 60, seed=12))


def test_torchrl_env_is_reproducible_from_its_seed():
    def run(seed):
        env = SolarUAVAttitudeEnv(2, seed=0)
        env.set_seed(seed)
        torch.manual_seed(0)
        return env.rollout(15, break_when_any_done=False)["next", "observation"]

    torch.testing.assert_close(run(4), run(4), rtol=0, atol=0)
    assert not torch.equal(run(4), run(5))


# ----------------------------------------------------------------------------- timing

def _record_inputs(core: FlightCore, prop: str) -> list[tuple[int, float]]:
    """Wrap the core's JSBSim step to log ``prop`` as the actuators see it at each simulation step."""
    log: list[tuple[int, float]] = []
    run = core._run

    def logged():
        log.append((len(log), core.sim[prop]))
        run()

    core._run = logged
    return log


def test_delay_applies_the_command_at_the_simulation_step_it_falls_on():
    core = FlightCore(CoreConfig(turbulence=False, sensor_noise=False))
    core.reset(seed=21)
    setup = core.setup
    assert 0.080 <= setup.delay_s <= 0.120 and 0.040 <= setup.control_interval_s <= 0.060
    log = _record_inputs(core, "fcs/aileron-cmd-norm")
    k_change = 5
    for k in range(12):
        aileron = 6.0 if k >= k_change else 0.0
        core.step(setup.trim_command + np.array([aileron, 0, 0, 0]))
    values = np.array([v for _, v in log])
    first = int(np.argmax(values > 0.1))
    expected = math.ceil((k_change * setup.control_interval_s + setup.delay_s) / core.dt_s - 1e-9)
    assert first == expected
    # Not rounded to whole control intervals: the applied time is within one simulation step of the drawn delay.
    assert abs(first * core.dt_s - (k_change * setup.control_interval_s + setup.delay_s)) < core.dt_s + 1e-12
    assert values[first] == pytest.approx(6.0 / 30.0)


def test_control_interval_is_the_drawn_one():
    core = FlightCore(CoreConfig(turbulence=False))
    for seed in (1, 2, 3):
        core.reset(seed=seed)
        interval = core.setup.control_interval_s
        times = []
        for _ in range(40):
            core.step(core.setup.trim_command)
            times.append(core.time_s)
        k = np.arange(1, 41)
        assert np.all(np.abs(np.array(times) - k * interval) <= core.dt_s / 2 + 1e-12)
        assert (times[-1] - times[0]) / 39 == pytest.approx(interval, abs=core.dt_s / 39)


def test_zero_delay_and_fixed_interval_in_the_ideal_setting():
    core = FlightCore(CoreConfig.ideal())
    core.reset(seed=1)
    assert core.setup.delay_s == 0.0 and core.setup.control_interval_s == 0.05


# ----------------------------------------------------------------------------- noise

def test_ou_noise_increments_have_the_stated_sigma():
    rng = np.random.default_rng(0)
    noise = dist.OrnsteinUhlenbeckNoise(NOISE_SIGMA)
    dt = 0.05
    samples = np.array([noise.step(dt, rng) for _ in range(20000)])
    increments = np.diff(samples, axis=0)
    expected = NOISE_SIGMA * math.sqrt(dt)
    nonzero = expected > 0
    np.testing.assert_allclose(increments.std(axis=0)[nonzero], expected[nonzero], rtol=0.05)
    assert np.all(samples[:, ~nonzero] == 0.0)  # altitude and actuator positions are not noised


def test_ou_noise_with_reversion_is_stationary_at_sigma_over_sqrt_2k():
    rng = np.random.default_rng(1)
    noise = dist.OrnsteinUhlenbeckNoise([1.0], reversion_per_s=2.0)
    samples = np.array([noise.step(0.05, rng)[0] for _ in range(40000)])[2000:]
    assert samples.std() == pytest.approx(1.0 / math.sqrt(2 * 2.0), rel=0.05)


def test_observation_is_the_true_state_plus_the_noise():
    task = AttitudeTask(TaskConfig(core=CoreConfig(turbulence=False)))
    task.reset(3)
    for _ in range(5):
        task.step(_hold(task))
    b = task.batch
    measured = b.measurements()[0]
    assert np.any(measured != np.array(b.states[0]))
    np.testing.assert_allclose(measured - np.array(b.states[0]), b.cores[0].noise.state, atol=1e-12)


# ----------------------------------------------------------------------------- parameters

def test_table4_scales_stay_in_range_and_reach_jsbsim():
    core = FlightCore(CoreConfig(turbulence=False))
    seen = {}
    for seed in range(6):
        core.reset(seed=seed)
        for group, (terms, (lo, hi)) in dist.RANDOMISATION_GROUPS.items():
            for term in terms:
                value = core.setup.scales[term]
                assert lo <= value <= hi, (group, term, value)
                assert core.sim[f"aero/scale/{term}"] == pytest.approx(value)
                seen.setdefault(term, set()).add(round(value, 9))
        assert core.sim["aero/scale/CLalpha"] == 1.0  # not in Table 4
    assert all(len(v) == 6 for v in seen.values())  # drawn anew each episode


def test_named_parameter_sets():
    core = FlightCore(CoreConfig(parameters="positive", turbulence=False))
    core.reset(seed=0)
    assert core.sim["aero/scale/Clp"] == pytest.approx(0.7)
    assert core.sim["aero/scale/I"] == pytest.approx(0.95)
    core.reset(seed=0, parameters="negative")
    assert core.sim["aero/scale/Cmde"] == pytest.approx(0.85)
    core.reset(seed=0, parameters="nominal")
    assert core.sim["aero/scale/Cmde"] == 1.0
    with pytest.raises(ValueError, match="unknown parameter set"):
        core.reset(seed=0, parameters="heavy")


def test_turbulence_and_delay_settings_are_checked_and_change_a_flight():
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="turbulence_sigma_mps"):
            CoreConfig(turbulence_sigma_mps=bad)
    for bad in ((0.1, 0.05), (-0.01, 0.1), (0.08, float("nan"))):
        with pytest.raises(ValueError, match="delay_s"):
            CoreConfig(delay_s=bad)
    with pytest.raises(ValueError, match="control_interval_s"):
        CoreConfig(control_interval_s=(0.0, 0.05))
    # The training settings' turbulence and delay do change a flight (the trainer's own evaluation
    # flies the paper's: tests/test_training.py).
    def policy(td):  # neutral surfaces and half throttle in both flights
        return td.set("action", torch.zeros(td.shape[0], 4))

    rougher = TaskConfig(core=CoreConfig(turbulence_sigma_mps=1.5, delay_s=(0.0, 0.02)))
    rough, calm = (make_env(num_envs=2, config=config, seed=5).rollout(20, policy, break_when_any_done=False)
                   ["next", "observation"] for config in (rougher, TaskConfig()))
    assert not torch.equal(rough, calm)


def test_backlash_width_and_servo_rate_limit_reach_jsbsim():
    core = FlightCore(CoreConfig.ideal(backlash_deg=0.3, servo_rate_limit_degps=40.0))
    core.reset(seed=0)
    assert core.sim["fcs/backlash-width-deg"] == pytest.approx(0.3)
    assert core.sim["fcs/surface-rate-limit-deg_s"] == 40.0
    assert core.setup.servo_rate_limit_degps == pytest.approx(40.0)


def test_servo_rate_scale_draws_each_episodes_rate_and_leaves_the_other_draws_alone():
    nominal = FlightCore(CoreConfig())
    drawn = FlightCore(CoreConfig(servo_rate_scale=(0.1, 1.0)))
    rates = []
    for seed in range(6):
        nominal.reset(seed=seed)
        drawn.reset(seed=seed)
        assert nominal.setup.servo_rate_limit_degps == pytest.approx(100.0)  # the paper's aircraft's own
        rate = drawn.setup.servo_rate_limit_degps
        assert 10.0 - 1e-9 <= rate <= 100.0 + 1e-9 and drawn.sim["fcs/surface-rate-limit-deg_s"] == pytest.approx(rate)
        # The same altitude, airspeed, delay and coefficients: the rate is drawn after all of them.
        assert (drawn.setup.altitude_m, drawn.setup.delay_s, drawn.setup.scales) == \
            (nominal.setup.altitude_m, nominal.setup.delay_s, nominal.setup.scales)
        rates.append(rate)
    assert len(set(rates)) == len(rates)
    drawn.reset(seed=3)
    assert drawn.setup.servo_rate_limit_degps == pytest.approx(rates[3])  # a function of the seed
    scaled = FlightCore(CoreConfig(servo_rate_limit_degps=40.0, servo_rate_scale=(0.5, 0.5)))
    scaled.reset(seed=0)
    assert scaled.setup.servo_rate_limit_degps == pytest.approx(20.0)


@pytest.mark.parametrize("bad", [(0.0, 1.0), (0.5, 0.2), (float("nan"), 1.0), (0.1, float("inf"))])
def test_a_servo_rate_scale_that_is_not_a_positive_range_is_refused(bad):
    with pytest.raises(ValueError, match="servo_rate_scale must be a finite range"):
        CoreConfig(servo_rate_scale=bad)


# ----------------------------------------------------------------------------- reward

def test_reward_is_the_sum_of_its_terms_and_matches_eq_22():
    d = math.radians
    goal = [d(2.0), d(-3.0), 10.0]
    state = np.zeros(13)
    state[1], state[2], state[6], state[8] = d(3.0), d(0.0), 11.0, d(6.0)
    p_roll, p_pitch, p_speed, p_beta, r = reward_terms(state, goal)
    assert p_roll == pytest.approx(1.0 / 5.0)
    assert p_pitch == pytest.approx(0.3)  # 3 deg / 6 = 0.5, capped at 0.3
    assert p_speed == pytest.approx(1.0 / 5.0)
    assert p_beta == pytest.approx(0.1)  # 6 deg / 30 = 0.2, capped at 0.1
    assert r == pytest.approx(1.0 - 0.2 - 0.3 - 0.2 - 0.1)
    perfect = np.zeros(13)
    perfect[1], perfect[2], perfect[6] = goal
    assert reward_terms(perfect, goal)[4] == pytest.approx(1.0)
    # Every penalty capped: the floor of Eq. 22.
    worst = np.zeros(13)
    worst[1], worst[2], worst[6], worst[8] = d(90), d(-90), 30.0, d(90)
    assert reward_terms(worst, goal)[4] == pytest.approx(0.0)


def test_reward_reported_in_info_sums_up_during_an_episode():
    task = AttitudeTask()
    task.reset(8)
    for _ in range(10):
        _, reward, _, _, info = task.step(_hold(task))
        terms = [info[k] for k in ("penalty_roll", "penalty_pitch", "penalty_airspeed", "penalty_beta")]
        assert reward == pytest.approx(1.0 - sum(terms))
        assert reward == pytest.approx(reward_terms(info["true_state"], info["goal"])[4])


def test_goals_change_step_wise_inside_their_ranges():
    task = AttitudeTask(TaskConfig(core=CoreConfig(turbulence=False), goal_hold_s=(0.5, 1.0)))
    task.reset(4)
    goals = []
    for _ in range(100):
        _, _, terminated, truncated, info = task.step(_hold(task))
        goals.append(info["goal"])
        if terminated or truncated:
            break
    g = np.array(goals)
    assert np.all(g >= GOAL_LOW) and np.all(g <= GOAL_HIGH)
    changes = np.any(np.diff(g, axis=0) != 0, axis=1)
    assert 3 <= changes.sum() < len(g) - 1  # steps, held in between


# ----------------------------------------------------------------------------- episode end

def _run_until_end(task: AttitudeTask, action, steps: int = 600) -> dict:
    for _ in range(steps):
        _, _, terminated, truncated, info = task.step(action)
        if terminated or truncated:
            return {"terminated": terminated, "truncated": truncated, **info}
    return {"terminated": False, "truncated": False, "termination": ""}


@pytest.mark.parametrize("cause, core_kw, action", [
    ("roll limit", {}, [1.0, 0.0, 0.0, 0.0]),
    ("pitch limit", {"envelope": Envelope(alpha_range_deg=(-90, 90), eas_range_mps=(0.1, 90))},
     [0.0, 1.0, 0.0, 0.0]),
    ("angle of attack limit", {"envelope": Envelope(alpha_range_deg=(-3.0, 3.0))}, [0.0, -1.0, 0.0, 0.3]),
    ("airspeed limit", {"envelope": Envelope(eas_range_mps=(9.0, 11.0))}, [0.0, 0.5, 0.0, -1.0]),
    ("altitude too high", {"envelope": Envelope(altitude_range_m=(50.0, 5010.0))}, [0.0, -0.3, 0.0, 1.0]),
    # Started 80 m above the terrain.
    ("ground strike", {"altitude_range_m": (TERRAIN_ELEVATION_M + 80.0,) * 2,
                       "envelope": Envelope(max_abs_pitch_deg=89.0, alpha_range_deg=(-90, 90), eas_range_mps=(0.1, 90))},
     [0.0, 1.0, 0.0, 0.0]),
])
def test_each_termination_cause_is_reachable(cause, core_kw, action):
    core = replace(CoreConfig.ideal(), **{"altitude_range_m": (5000.0, 5000.0), **core_kw})
    task = AttitudeTask(TaskConfig(core=core))
    task.reset(0)
    end = _run_until_end(task, np.array(action, dtype=float))
    assert end["terminated"] and end["termination"].startswith(cause), end["termination"]


def test_flight_core_trims_the_aircraft_of_its_own_root(tmp_path):
    root = tmp_path / "root"
    shutil.copytree(aircraft.aircraft_dir(), root / "aircraft" / aircraft.AIRCRAFT_NAME)
    mass_file = root / "aircraft" / aircraft.AIRCRAFT_NAME / "MassBalance.xml"
    tree = ET.parse(mass_file)
    tree.find("emptywt").text = f" {1.2 * float(tree.find('emptywt').text)} "
    tree.write(mass_file)
    packaged, heavier = FlightCore(CoreConfig.ideal()), FlightCore(CoreConfig.ideal(aircraft=root))
    assert heavier.trim_table is not packaged.trim_table
    # One table per aircraft, whether it is named by its JSBSim root or its folder.
    assert heavier.trim_table is FlightCore(CoreConfig.ideal(aircraft=str(root / "aircraft" / "solar_uav"))).trim_table
    for core in (packaged, heavier):
        core.reset(0, altitude_m=1000.0, airspeed_eas_mps=10.0)  # a grid point: the trim itself
        f = core.sim.fdm
        assert abs(f["accelerations/wdot-ft_sec2"]) < 1e-2 and abs(f["accelerations/qdot-rad_sec2"]) < 1e-3
    # More weight at the same speed: more lift, so a higher angle of attack and more thrust.
    assert heavier.setup.trim_command[3] > packaged.setup.trim_command[3]
    assert heavier.trim_table.lookup(1000.0, 10.0).alpha_deg > packaged.trim_table.lookup(1000.0, 10.0).alpha_deg + 0.5


def test_flight_from_sea_level_keeps_the_gear_clear_and_the_ground_strike_check():
    core = FlightCore(CoreConfig.ideal())
    core.reset(0, altitude_m=0.0, airspeed_eas_mps=10.0)
    assert core.height_above_ground_m() == pytest.approx(-TERRAIN_ELEVATION_M, abs=1e-6)
    for _ in range(100):  # 5 s at the trim command
        core.step(core.setup.trim_command)
        assert core.envelope_violation() is None
        assert core.sim["gear/wow"] == 0.0
    assert abs(core.last_true_state[0]) < 5.0
    # 50 m above the terrain is still where an episode ends.
    core.reset(0, altitude_m=TERRAIN_ELEVATION_M + 40.0, airspeed_eas_mps=10.0)
    assert core.envelope_violation().startswith("ground strike")


def test_non_finite_state_terminates():
    task = AttitudeTask(TaskConfig(core=CoreConfig.ideal()))
    task.reset(0)
    task.core.sim["aero/scale/CL0"] = math.nan  # a broken coefficient poisons the state
    obs, reward, terminated, _, info = task.step(np.zeros(4))
    assert terminated and info["termination"].startswith("non-finite state")
    assert np.all(np.isfinite(obs)) and reward == 0.0


def test_truncation_after_max_steps():
    task = AttitudeTask(TaskConfig(core=replace(CoreConfig.ideal(), max_steps=15)))
    task.reset(0)
    end = _run_until_end(task, command_to_action(task.core.setup.trim_command), steps=20)
    assert end["truncated"] and not end["terminated"] and task.batch.steps[0] == 15


# ----------------------------------------------------------------------------- bad actions

def test_bad_actions_raise_and_small_overshoot_is_clipped():
    task = AttitudeTask(TaskConfig(core=CoreConfig.ideal()))
    task.reset(0)
    for bad in ([math.nan, 0, 0, 0], [0, 1.5, 0, 0], [0, 0, -math.inf, 0]):
        with pytest.raises(ActionError):
            task.step(np.array(bad))
    with pytest.raises(ActionError, match="shape"):
        action_to_command(np.zeros(3))
    task.step(np.array([1.0 + 1e-7, 0, 0, 0]))
    assert task.core.applied_command is not None
    np.testing.assert_allclose(action_to_command([1.0 + 1e-7, -1, 0, 1]), [30.0, -30.0, 0.0, 1.0])
    core = task.core
    with pytest.raises(CommandError):
        core.step(np.array([0.0, 40.0, 0.0, 0.5]))
    with pytest.raises(CommandError):
        core.step(np.array([0.0, 0.0, 0.0, math.nan]))


def test_torchrl_env_rejects_nan_actions():
    env = SolarUAVAttitudeEnv(2, seed=0)
    td = env.reset()
    td["action"] = torch.tensor([[0.0, 0.0, 0.0, 0.0], [math.nan, 0.0, 0.0, 0.0]])
    with pytest.raises(ActionError, match="aircraft 1"):
        env.step(td)


# ----------------------------------------------------------------------------- metrics

def test_rmse_and_smoothness_on_known_signals():
    assert rmse(np.full(50, 3.0), 1.0) == pytest.approx(2.0)
    t = np.arange(1000) / 25.0
    assert rmse(np.sin(2 * np.pi * 0.5 * t)) == pytest.approx(1 / math.sqrt(2), rel=1e-6)
    assert smoothness(np.full(1000, 0.4), 25.0) == pytest.approx(0.0, abs=1e-15)
    assert smoothness(0.7 * np.sin(2 * np.pi * 2.0 * t), 25.0) == pytest.approx(2 * 0.7 * 2.0 / (1000 * 25.0))
    # Faster or larger motion is less smooth.
    assert smoothness(np.sin(2 * np.pi * 4.0 * t), 25.0) > smoothness(np.sin(2 * np.pi * 1.0 * t), 25.0)


def test_actuator_smoothness_takes_surfaces_in_radians():
    t = np.arange(1000) / 25.0
    wave = np.sin(2 * np.pi * 1.0 * t)
    commands = np.stack([10.0 * wave, 0 * wave, 0 * wave, 0.1 * wave + 0.5], axis=1)
    sm = actuator_smoothness(commands, 25.0)
    assert sm["smoothness_aileron"] == pytest.approx(smoothness(math.radians(10.0) * wave, 25.0))
    assert sm["smoothness_elevator"] == pytest.approx(0.0, abs=1e-15)
    assert sm["smoothness_throttle"] == pytest.approx(2 * 0.1 * 1.0 / (1000 * 25.0))


def test_episode_recorder_metrics_and_plot(tmp_path):
    task = AttitudeTask(TaskConfig(core=CoreConfig(turbulence=False)))
    task.reset(2)
    rec = EpisodeRecorder()
    for _ in range(40):
        action = _hold(task)
        _, _, _, _, info = task.step(action)
        rec.record(info["time_s"], info["true_state"], info["goal"], action_to_command(action),
                   [info[k] for k in ("penalty_roll", "penalty_pitch", "penalty_airspeed", "penalty_beta")])
    m = rec.tracking_metrics()
    a = rec.arrays()
    assert m["rmse_roll_deg"] == pytest.approx(rmse(np.degrees(a["true_state"][:, 1]), np.degrees(a["goal"][:, 0])))
    rec.plot(tmp_path / "episode.png", "test")
    rec.save(tmp_path / "episode.npz")
    assert (tmp_path / "episode.png").stat().st_size > 10000
    assert np.load(tmp_path / "episode.npz")["true_state"].shape == (40, 13)


def test_the_privileged_entries_hold_what_the_aircraft_cannot_measure():
    from jsbsim_env.sim.model_check import SCALED_TERMS
    from jsbsim_env.task.attitude import PRIVILEGED_NAMES, PRIVILEGED_SIZE

    env = make_env(2, TaskConfig(surface_trim_gain=1.0, goal_trim_time_constant_s=10.0), seed=3, privileged=True)
    td = env.rollout(20)
    assert td["privileged"].shape == (2, 20, PRIVILEGED_SIZE) == (2, 20, len(PRIVILEGED_NAMES))
    batch = env.base_env.batch
    last = td["next", "privileged"][:, -1]
    np.testing.assert_allclose(last.numpy(), batch.privileged(), rtol=0, atol=0)
    scales = last[0, PRIVILEGED_NAMES.index(f"scale_{SCALED_TERMS[0]}")]
    assert scales == pytest.approx((batch.cores[0].setup.scales.get(SCALED_TERMS[0], 1.0) - 1.0) / 0.2, abs=1e-6)
    gust = last[:, PRIVILEGED_NAMES.index("gust_u"):PRIVILEGED_NAMES.index("gust_r") + 1]
    assert gust.abs().sum() > 0  # the paper's turbulence is on
    assert "privileged" not in make_env(1, TaskConfig(), seed=3).rollout(2).keys()  # noqa: SIM118 - a TensorDict

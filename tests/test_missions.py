"""Route missions: the PID baseline flies the 10 km route inside a corridor; settings are checked."""

from __future__ import annotations

import numpy as np
import pytest

from jsbsim_env.control.base import AttitudeController
from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.missions import MissionResult, RouteConfig, fly_route


@pytest.fixture(scope="module")
def pid_route():
    # First leg, the corner and part of the second leg, with turbulence on the second leg.
    config = RouteConfig(altitude_m=10_000.0, duration_s=500.0, turbulence_legs=(1,), seed=3)
    return fly_route(PIDAttitudeController(), config)


def test_pid_is_an_attitude_controller():
    assert isinstance(PIDAttitudeController(), AttitudeController)


def test_pid_flies_the_route_inside_the_corridor(pid_route):
    r = pid_route
    assert r.ended_early is None
    a = r.arrays
    assert a["leg"].max() >= 1, "reached the second leg"
    assert set(np.unique(a["turbulence"][a["leg"] == 1])) == {1.0}
    assert set(np.unique(a["turbulence"][a["leg"] == 0])) == {0.0}
    m = r.metrics()
    # Corridor: the corner is cut by about one turn radius at the 5 deg roll limit (346 m at
    # 10 km, 10 m/s EAS); height within 10 m; attitude errors of a well-tuned loop.
    assert m["max_cross_track_m"] < 450.0
    assert m["max_altitude_error_m"] < 10.0
    assert m["rmse_roll_deg"] < 1.0 and m["rmse_pitch_deg"] < 0.5
    assert m["rmse_airspeed_eas_mps"] < 0.3
    assert np.all(np.abs(a["command"][:, :3]) <= np.array([30.0, 30.0, 20.0]))


def test_level_flight_window_is_tight(pid_route):
    # Straight and level before the corner, out of turbulence.
    m = pid_route.metrics(60.0, 280.0)
    assert m["mae_roll_deg"] < 0.2 and m["mae_pitch_deg"] < 0.2
    assert m["max_cross_track_m"] < 20.0


def test_pid_surfaces_do_not_depend_on_the_attitude_eas_demand():
    """TECS flies the speed: the PID's EAS demand only drives the throttle TECS replaces, so the
    measured-EAS demand (the default) and the route's EAS fly the same route."""
    def fly(demand: str):
        return fly_route(PIDAttitudeController(), RouteConfig(duration_s=60.0, turbulence_legs=(0,), seed=4,
                                                              attitude_eas_demand=demand))

    measured, route = fly("measured"), fly("route")
    np.testing.assert_array_equal(measured.arrays["command"], route.arrays["command"])
    np.testing.assert_array_equal(measured.arrays["eas_cmd_mps"], route.arrays["eas_cmd_mps"])  # scored on the route's
    assert set(measured.arrays["eas_cmd_mps"]) == {RouteConfig().eas_mps}


def test_bad_route_settings():
    with pytest.raises(ValueError, match="attitude_eas_demand"):
        RouteConfig(attitude_eas_demand="tecs")
    with pytest.raises(ValueError, match="waypoints"):
        RouteConfig(waypoints_ne_m=((0.0, 0.0),)).waypoints()
    with pytest.raises(ValueError, match="shorter than 1 m"):
        RouteConfig(waypoints_ne_m=((0.0, 0.0), (0.0, 0.5))).waypoints()
    with pytest.raises(ValueError, match="no samples"):
        fly_route(PIDAttitudeController(), RouteConfig(duration_s=1.0)).metrics(100.0, 200.0)


def test_the_rectangle_grows_with_the_turn_radius_above_10_km():
    from jsbsim_env.missions import standard_density_kg_m3
    from jsbsim_env.sim.simulation import Simulation

    sim = Simulation()
    for altitude_m in (0.0, 1_000.0, 10_000.0, 11_000.0, 15_000.0, 20_000.0):
        assert standard_density_kg_m3(altitude_m) == pytest.approx(sim.density_kg_m3(altitude_m), rel=0.012)
    drawn = np.array([[0.0, 0.0], [6000.0, 0.0], [6000.0, 3000.0], [0.0, 3000.0]])
    for altitude_m in (1_000.0, 10_000.0):  # the paper's route and everything below it: as drawn
        np.testing.assert_array_equal(RouteConfig(altitude_m=altitude_m).waypoints(), drawn)
    high = RouteConfig(altitude_m=20_000.0)
    assert high.rectangle_scale() == pytest.approx(4.69, abs=0.01)
    np.testing.assert_allclose(high.waypoints(), drawn * high.rectangle_scale())
    np.testing.assert_array_equal(RouteConfig(altitude_m=20_000.0, scale_with_altitude=False).waypoints(), drawn)
    given = ((0.0, 0.0), (500.0, 0.0))  # waypoints given are flown as given
    np.testing.assert_array_equal(RouteConfig(altitude_m=20_000.0, waypoints_ne_m=given).waypoints(), given)
    # The steady-state window starts later after each corner, as the turns there take longer.
    from training.evaluation.report import steady_mask

    t = np.arange(0.0, 400.0, 1.0)
    arrays = {"time_s": t, "leg": (t >= 200.0).astype(float)}
    low = steady_mask(MissionResult(RouteConfig(altitude_m=1_000.0), arrays, None), 60.0)
    assert np.flatnonzero(low)[0] == 60 and np.flatnonzero(low[200:])[0] == 60
    late = steady_mask(MissionResult(high, arrays, None), 60.0)
    first = np.ceil(60.0 * np.sqrt(high.rectangle_scale()))  # 130 s
    assert np.flatnonzero(late)[0] == first and np.flatnonzero(late[200:])[0] == first


def test_mission_metrics_on_known_signals():
    n = 1000
    t = np.arange(n) / 25.0
    zeros = np.zeros(n)
    arrays = {name: zeros.copy() for name in ("north_m", "east_m", "heading_rad", "cross_track_m", "leg",
                                              "turbulence", "roll_cmd_rad", "pitch_cmd_rad")}
    arrays.update(time_s=t, altitude_m=np.full(n, 10_000.0), eas_mps=np.full(n, 10.3), eas_cmd_mps=np.full(n, 10.0),
                  roll_rad=np.full(n, np.radians(0.5)), pitch_rad=np.radians(0.2 * np.sin(2 * np.pi * 0.5 * t)),
                  beta_rad=zeros.copy(), actuator=np.zeros((n, 4)))
    arrays["command"] = np.stack([5.0 * np.sin(2 * np.pi * 1.0 * t), zeros, zeros, np.full(n, 0.3)], axis=1)
    m = MissionResult(RouteConfig(), arrays, None).metrics()
    assert m["rmse_roll_deg"] == pytest.approx(0.5) and m["mae_roll_deg"] == pytest.approx(0.5)
    assert m["rmse_pitch_deg"] == pytest.approx(0.2 / np.sqrt(2), rel=1e-6)
    assert m["mae_pitch_deg"] == pytest.approx(0.2 * 2 / np.pi, rel=5e-3)  # 50 samples a period
    assert m["rmse_airspeed_eas_mps"] == pytest.approx(0.3)
    assert m["smoothness_aileron"] == pytest.approx(2 * np.radians(5.0) * 1.0 / (n * 25.0))
    assert m["smoothness_throttle"] == pytest.approx(0.0, abs=1e-15)
    half = MissionResult(RouteConfig(), arrays, None).metrics(0.0, 20.0)
    assert half["rmse_roll_deg"] == pytest.approx(0.5)
    # The flight lasted 40 s: a window after it is an error for metrics, and NaN for the report,
    # which must describe a controller that crashed rather than stop at it.
    from training.evaluation.report import window_metrics

    result = MissionResult(RouteConfig(), arrays, "roll limit")
    with pytest.raises(ValueError, match="no samples"):
        result.metrics(50.0, 60.0)
    late = window_metrics(result, 50.0, 60.0)
    assert set(late) == set(m) and all(np.isnan(v) for v in late.values())
    assert window_metrics(result, 0.0, 20.0) == half
    # ``only`` narrows a window to the samples asked for (the level window's straight flight).
    second_half = arrays["time_s"] >= 20.0
    assert window_metrics(result, 0.0, 40.0, only=second_half) == result.metrics(20.0, 40.0)
    with pytest.raises(ValueError, match="where asked"):
        result.metrics(0.0, 20.0, only=second_half)
    assert all(np.isnan(v) for v in window_metrics(result, 0.0, 20.0, only=second_half).values())


def test_pid_on_the_policy_evaluation_suite():
    """The evaluation suite flies any controller of the shared interface: the PID follows every
    doublet step at 5,000 m closely and flies disturbed training-style episodes to the end."""
    from training.evaluation.suite import doublet_runs, evaluate

    doublets = doublet_runs(PIDAttitudeController(), altitudes_m=(5000.0,))["5000m"]
    assert not doublets["ended_early"] and doublets["pitch_doublet_deg"] == pytest.approx(5.0, abs=1e-12)
    for key in ("steady_state_error_roll_deg", "steady_state_error_pitch_deg", "steady_state_error_airspeed_eas_mps"):
        assert all(e < 0.5 for e in doublets[key]), key  # NaN fails too
    assert all(t < 8.0 for t in doublets["settling_time_90_s_roll_deg"]) and doublets["rmse_beta_deg"] < 2.0
    episodes = evaluate(PIDAttitudeController(), episodes=2)["episodes"]
    assert episodes["ended_early"] == 0 and episodes["mean_length"] == 500
    assert episodes["mean_return_norm"] > 0.4  # random actions score 0.13

"""Turbulence: the Dryden series, its rotational gusts against a frozen field in JSBSim, the
MIL-F-8785C intensities and the clips."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from aircraft.design import aero_data
from aircraft.design.analysis import _mac_quarter_chord, _trapezoid_area_m2
from aircraft.design.geometry import AircraftGeometry
from jsbsim_env.sim import turbulence as turb
from jsbsim_env.sim.core import CoreConfig, FlightCore
from jsbsim_env.sim.simulation import FT_TO_M, LBF_TO_N, M_TO_FT, Simulation

SPAN_M = 35.0
PSF_TO_PA = 47.880258888889
LBFFT_TO_NM = LBF_TO_N * FT_TO_M


@pytest.fixture(scope="module")
def tas_mps():
    """True airspeed (m/s) at an altitude (m) and EAS (m/s), from JSBSim's atmosphere."""
    sim = Simulation()
    return lambda altitude_m, eas_mps: eas_mps * math.sqrt(1.225 / sim.density_kg_m3(altitude_m))


# ----------------------------------------------------------------------------- the series

@pytest.mark.parametrize("altitude_m", [500.0, 10000.0, 20000.0])
def test_series_has_its_intensity_and_stays_within_its_clips(altitude_m, tas_mps):
    rng = np.random.default_rng(int(altitude_m))
    series = turb.dryden_series(200000, altitude_m, tas_mps(altitude_m, 10.0), SPAN_M, 0.05, rng)
    assert np.all(np.abs(series.wind_mps) <= series.wind_clip_mps)
    assert np.all(np.abs(series.rate_radps) <= series.rate_clip_radps)
    np.testing.assert_allclose(series.wind_clip_mps, turb.PAPER_WIND_CLIP_MPS)  # 4 sigma at 0.5 m/s
    # 10,000 s is 190-700 correlation times: the sample standard deviation is within a few percent.
    np.testing.assert_allclose(series.wind_mps.std(axis=0), 0.5, rtol=0.1)
    assert np.all(np.degrees(series.rate_radps.std(axis=0)) > 0.05)


def test_series_starts_in_the_stationary_state(tas_mps):
    """The first sample of an episode has the full intensity, also where the correlation time L/V
    is longest (1 km, EAS 8 m/s: 63 s)."""
    v = tas_mps(1000.0, 8.0)
    first = np.array([turb.dryden_series(1, 1000.0, v, SPAN_M, 0.04, np.random.default_rng(s)).wind_mps[0]
                      for s in range(300)])
    # 900 independent Gaussian samples: their standard deviation is within 2.4 % (one sigma).
    np.testing.assert_allclose(first.std(), 0.5, rtol=0.07)


def test_roll_gust_has_the_milspec_variance(tas_mps):
    """MIL-F-8785C: Phi_p(w) = sigma_w^2 / (V L_w) * 0.8 (pi L_w / 4b)^(1/3) / (1 + (4b w / pi V)^2);
    integrated over 0..inf (the integral of 1 / (1 + (tau w)^2) is pi / (2 tau), tau = 4b / (pi V)):
    sigma_p^2 = 0.1 pi^2 sigma_w^2 / (b L_w) * (pi L_w / 4b)^(1/3)."""
    altitude_m, v, dt_s = 10000.0, tas_mps(10000.0, 10.0), 0.05
    lw = turb.dryden_scale_lengths_m(altitude_m)[2]
    expected = math.sqrt(0.1 * math.pi**2 * 0.5**2 / (SPAN_M * lw) * (math.pi * lw / (4 * SPAN_M)) ** (1 / 3))
    noise = np.random.default_rng(3).standard_normal(200000) * math.sqrt(math.pi / dt_s)
    p = signal.lfilter(*turb.dryden_filters(altitude_m, v, SPAN_M, (0.5,) * 3, dt_s)["p"], noise)
    # 10,000 s over a time constant of 2.6 s: the sample value is within 1.1 % (one sigma).
    assert p.std() == pytest.approx(expected, rel=0.05)


# ----------------------------------------------------------------------------- rotational gusts in JSBSim

def _tail(axis: str) -> tuple[float, float, float, float]:
    """Area (m^2), efficiency, 3-D lift slope (per rad, on its own area) and arm behind the CG (m)
    of the horizontal tail (pitch) or the fin (yaw), from the design data."""
    geometry, stability = AircraftGeometry(), aero_data.load()["stability"]
    slopes = stability["lift_slopes_per_rad"]
    if axis == "pitch":
        surface, area, slope = geometry.horizontal_tail, 2 * _trapezoid_area_m2(geometry.horizontal_tail), \
            slopes["elevator_3d"]  # the panel is half the tail
    else:
        surface, area, slope = geometry.vertical_tail, _trapezoid_area_m2(geometry.vertical_tail), slopes["rudder_3d"]
    return area, surface.efficiency, slope, float(_mac_quarter_chord(surface)[0]) - stability["cg_x_m"]


# Ratio bands of the model's moment over the tail's. Pitch: a w field varying along x is, at every
# point of the x axis, what a pitch rate is, so the whole Cmq applies; the tail part alone
# (-2 eta V_H a_t l_t / c) is about 94 % of the model's Cmq, the wing's own pitch damping the rest:
# ratio about 1.06, to within 1 % of the MIL-F-8785C low-pass at this wavelength. Yaw: a v field
# varying along x meets the fin only (the wing's share of Cnr needs a u varying along the span), and
# the model applies the yaw gust to the tails' share of its yaw-rate derivatives; the lattice puts
# that share about 7 % below the isolated fin's estimate (the wing's sidewash at the fin): ratio
# about 0.93. Each band keeps the sign and the tail's share and leaves about 10 % for revised tables.
RATIO_BANDS = {"pitch": (0.95, 1.2), "yaw": (0.8, 1.05)}


@pytest.mark.parametrize("axis", ["pitch", "yaw"])
def test_rate_gust_gives_the_tail_moment_of_a_frozen_field(axis):
    """The trimmed aircraft (1 km, EAS 10 m/s) meets a frozen sinusoidal field of w (pitch) or v
    (yaw), 3 km long, at its airspeed. JSBSim gets the linear gust and the rate gust that
    ``gradient_rate_gusts`` makes of it; the moment of the rate gust (with minus without it) is
    compared with the one from the tail's local angle of attack (sideslip) against the wing's:

        pitch: dM = -qbar S_t eta a_t l_t (alpha_tail - alpha_cg), alpha(x) = alpha - w(x) / V
        yaw:   dN = +qbar S_v eta a_v l_v (beta_fin - beta_cg),    beta(x) = beta - v(x) / V

    with the tail l behind the CG meeting the field l / V later. The aircraft is held in its
    trimmed state while the field passes it (JSBSim's initial-condition pass evaluates the model
    without moving it): a free aircraft would respond to the gust and change the state between
    the two evaluations. At 3 km the MIL-F-8785C low-pass (time constant 4b/(pi V) = 4.2 s in
    pitch, 3b/(pi V) in yaw) lags the gradient by 4-5 deg and the finite tail arm (8.6 m) barely
    differs from the gradient: the correlation is above 0.99 and the amplitude within 1 %.
    """
    sim = Simulation()
    trim = sim.trim(1000.0, 10.0)
    f = sim.fdm
    # Held in its state, the aircraft has no alpha-dot; JSBSim would derive one from the
    # accelerations the gust causes within the initial-condition pass.
    f["aero/scale/CLadot"] = f["aero/scale/Cmadot"] = 0.0
    v0, dt_s, amplitude_mps, wavelength_m, run_in_s = trim.airspeed_tas_mps, 0.05, 0.3, 3000.0, 30.0
    area_m2, efficiency, slope_per_rad, arm_m = _tail(axis)
    t = np.arange(int((run_in_s + wavelength_m / v0) / dt_s)) * dt_s

    def field(x_m):
        return amplitude_mps * np.sin(2 * np.pi * x_m / wavelength_m)

    gust, zero = field(v0 * t), np.zeros(t.size)
    if axis == "pitch":
        rate = turb.gradient_rate_gusts(gust, zero, v0, SPAN_M, dt_s)[0]
        rate_prop, moment_prop, sign = "atmosphere/gust-q-rad_sec", "moments/m-aero-lbsft", -1.0
    else:
        rate = turb.gradient_rate_gusts(zero, gust, v0, SPAN_M, dt_s)[1]
        rate_prop, moment_prop, sign = "atmosphere/gust-r-rad_sec", "moments/n-aero-lbsft", 1.0
    model, tail = [], []
    for k in range(int(run_in_s / dt_s), t.size, 10):  # after the low-pass has settled
        body = (0.0, 0.0, gust[k]) if axis == "pitch" else (0.0, gust[k], 0.0)
        ned = turb.body_to_ned(f["attitude/phi-rad"], f["attitude/theta-rad"], f["attitude/psi-rad"], body)
        for name, value in zip(("north", "east", "down"), ned):
            f[f"atmosphere/gust-{name}-fps"] = value * M_TO_FT
        f[rate_prop] = rate[k]
        f.run_ic()
        with_rate = f[moment_prop]
        f[rate_prop] = 0.0
        f.run_ic()
        model.append((with_rate - f[moment_prop]) * LBFFT_TO_NM)
        v, qbar = f["velocities/vt-fps"] * FT_TO_M, f["aero/qbar-psf"] * PSF_TO_PA
        tail_minus_cg = -(field(v0 * t[k] - arm_m) - field(v0 * t[k])) / v  # of alpha (pitch), beta (yaw)
        tail.append(sign * qbar * area_m2 * efficiency * slope_per_rad * arm_m * tail_minus_cg)
    model, tail = np.array(model), np.array(tail)
    ratio = float(model @ tail / (tail @ tail))
    assert np.corrcoef(model, tail)[0, 1] > 0.99
    lo, hi = RATIO_BANDS[axis]
    assert lo < ratio < hi, f"{axis}: model / tail moment {ratio:.3f}"


def test_rotational_gust_changes_the_roll_moment():
    core = FlightCore(CoreConfig.ideal())
    core.reset(seed=0, altitude_m=5000.0, airspeed_eas_mps=10.0)
    sim = core.sim
    sim.fdm.run_ic()
    calm = sim["moments/l-aero-lbsft"]
    sim["atmosphere/gust-p-rad_sec"] = 0.005
    sim.fdm.run_ic()
    # A gust rate is the body rate with the opposite sign: it produces roll damping moment in reverse.
    assert sim["moments/l-aero-lbsft"] != pytest.approx(calm)


# ----------------------------------------------------------------------------- in the flight core

def test_turbulence_reaches_jsbsim_and_differs_between_seeds():
    core = FlightCore(CoreConfig(sensor_noise=False))
    gusts = {}
    for seed in (1, 2):
        core.reset(seed=seed, altitude_m=15000.0)
        history = []
        for _ in range(20):
            core.step(core.setup.trim_command)
            history.append([core.sim[f"atmosphere/gust-{a}-fps"] for a in ("north", "east", "down")]
                           + [core.sim[f"atmosphere/gust-{a}-rad_sec"] for a in "pqr"])
        h = np.array(history)
        assert np.all(np.linalg.norm(h[:, :3], axis=1) * FT_TO_M <= np.linalg.norm(core.turbulence.wind_clip_mps))
        assert np.all(np.abs(h[:, 3:]) <= core.turbulence.rate_clip_radps + 1e-12)
        assert np.any(h != 0.0)
        gusts[seed] = h
    assert not np.allclose(gusts[1], gusts[2])


# ----------------------------------------------------------------------------- intensity against altitude

KT_TO_FPS = 1852.0 / 3600.0 / FT_TO_M


@pytest.mark.parametrize("severity, altitude_ft, sigma_uvw_fps", [
    # MIL-F-8785C Fig. 7 (probability of exceedance 1e-2, 1e-3, 1e-5), isotropic above 2000 ft.
    ("light", 7500.0, (6.7,) * 3),
    ("light", 45000.0, (0.0,) * 3),
    ("moderate", 15000.0, (8.0,) * 3),
    ("severe", 25000.0, (20.0,) * 3),
    # Below 1000 ft: sigma_w = W20 / 10 (W20 15, 30, 45 kt) and sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4.
    ("light", 500.0, (1.5 * KT_TO_FPS / 0.5885**0.4,) * 2 + (1.5 * KT_TO_FPS,)),
    ("severe", 100.0, (4.5 * KT_TO_FPS / 0.2593**0.4,) * 2 + (4.5 * KT_TO_FPS,)),
    # 1500 ft: halfway between 3 kt at 1000 ft and Fig. 7's 9.725 ft/s at 2000 ft.
    ("moderate", 1500.0, ((3.0 * KT_TO_FPS + 9.725) / 2,) * 3),
])
def test_milspec_intensity_matches_the_published_values(severity, altitude_ft, sigma_uvw_fps):
    sigmas = turb.intensities_mps(altitude_ft * FT_TO_M, severity)
    np.testing.assert_allclose(np.array(sigmas) / FT_TO_M, sigma_uvw_fps, rtol=1e-3, atol=1e-9)


def test_flight_core_takes_the_intensity_from_its_config():
    assert turb.intensities_mps(8000.0, turb.PAPER, 0.7) == (0.7, 0.7, 0.7)
    core = FlightCore(CoreConfig(turbulence_intensity="light", sensor_noise=False))
    core.reset(seed=0, altitude_m=15000.0)  # 49,000 ft: light turbulence ends at 35,000-45,000 ft
    assert not np.any(core.turbulence.wind_mps)
    core = FlightCore(CoreConfig(turbulence_intensity="moderate", sensor_noise=False))
    core.reset(seed=0, altitude_m=5000.0)
    np.testing.assert_allclose(core.turbulence.wind_clip_mps, 4 * np.array(turb.intensities_mps(5000.0, "moderate")))
    with pytest.raises(ValueError, match="turbulence_intensity"):
        CoreConfig(turbulence_intensity="strong")


# ----------------------------------------------------------------------------- clips

@pytest.mark.parametrize("altitude_m, eas_mps", [(500.0, 8.0), (5000.0, 12.0), (20000.0, 8.0)])
def test_default_clip_is_as_rare_as_the_wind_clip(altitude_m, eas_mps, tas_mps):
    series = turb.dryden_series(100000, altitude_m, tas_mps(altitude_m, eas_mps), SPAN_M, 0.05,
                                np.random.default_rng(7))
    # The clip is 4 of each channel's standard deviations (5,000 s over time constants of 2-7 s:
    # the sample value within 2 %) ...
    np.testing.assert_allclose(series.rate_radps.std(axis=0), series.rate_clip_radps / 4, rtol=0.05)
    # ... beyond which a Gaussian lies 0.006 % of the time; 1 % leaves room for the sampling.
    assert np.all(np.mean(np.abs(series.rate_radps) >= series.rate_clip_radps, axis=0) < 0.01)
    assert np.all(np.mean(np.abs(series.wind_mps) >= series.wind_clip_mps, axis=0) < 0.01)


def test_paper_clip_is_2_mps_and_0_3_degps(tas_mps):
    series = turb.dryden_series(20000, 5000.0, tas_mps(5000.0, 10.0), SPAN_M, 0.05, np.random.default_rng(8),
                                clip="paper")
    np.testing.assert_array_equal(series.wind_clip_mps, 2.0)
    np.testing.assert_allclose(np.degrees(series.rate_clip_radps), 0.3)
    np.testing.assert_allclose(np.degrees(np.abs(series.rate_radps).max(axis=0)), 0.3)  # and reached
    core = FlightCore(CoreConfig(turbulence_clip="paper", sensor_noise=False))
    core.reset(seed=0)
    np.testing.assert_allclose(np.degrees(core.turbulence.rate_clip_radps), 0.3)
    with pytest.raises(ValueError, match="turbulence_clip"):
        CoreConfig(turbulence_clip="none")

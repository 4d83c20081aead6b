"""Physics checks of the BEMT propeller model (aircraft/design/propeller.py)."""

import math

import numpy as np
import pytest

from aircraft.design.propeller import PropellerGeometry, propeller_coefficients

pytest.importorskip("aerosandbox")  # the blade polar comes from NeuralFoil, an optional extra

DEFAULT = PropellerGeometry()
LOW_PITCH = PropellerGeometry(pitch_to_diameter=0.8)


def figure_of_merit(ct: float, cp: float) -> float:
    """Static figure of merit: ideal induced power over actual power.

    Ideal (momentum) power of a disk of area A = pi D^2 / 4 giving thrust T is
    T^1.5 / sqrt(2 rho A) = CT^1.5 rho n^3 D^5 / sqrt(pi / 2) with T = CT rho n^2 D^4; divided
    by P = CP rho n^3 D^5 this gives FM = sqrt(2 / pi) CT^1.5 / CP.
    """
    return math.sqrt(2.0 / math.pi) * ct**1.5 / cp


@pytest.fixture(scope="module")
def default():
    return propeller_coefficients(DEFAULT)


@pytest.fixture(scope="module")
def low_pitch():
    return propeller_coefficients(LOW_PITCH)


def test_results_finite_and_grid(default):
    j = default.advance_ratio
    assert np.all(np.isfinite(default.thrust_coeff)) and np.all(np.isfinite(default.power_coeff))
    assert j[0] == 0.0 and np.all(np.diff(j) > 0)
    # the default grid reaches past zero thrust into the windmilling region
    assert j[-1] > default.zero_thrust_advance_ratio() + 0.2
    assert default.thrust_coeff[-1] < 0 and default.power_coeff[-1] < 0


def test_zero_thrust_advance_ratio_near_geometric_pitch(default, low_pitch):
    for geometry, coeffs in ((DEFAULT, default), (LOW_PITCH, low_pitch)):
        j0 = coeffs.zero_thrust_advance_ratio()
        assert 0.8 * geometry.pitch_to_diameter < j0 < 1.3 * geometry.pitch_to_diameter
    assert low_pitch.zero_thrust_advance_ratio() < default.zero_thrust_advance_ratio()


def test_thrust_falls_with_advance_ratio(default, low_pitch):
    for coeffs in (default, low_pitch):
        working = coeffs.advance_ratio <= coeffs.zero_thrust_advance_ratio()
        ct = coeffs.thrust_coeff[working]
        peak = int(np.argmax(ct))
        # at most one stall hump at low J, then CT falls steadily to zero thrust
        assert np.all(np.diff(ct[: peak + 1]) >= 0)
        assert np.all(np.diff(ct[peak:]) < 0)
        assert coeffs.advance_ratio[peak] < 0.5 * coeffs.zero_thrust_advance_ratio()


def test_power_positive_below_zero_thrust(default):
    below = default.advance_ratio < default.zero_thrust_advance_ratio()
    assert np.all(default.power_coeff[below] > 0)


def test_peak_efficiency(default, low_pitch):
    for coeffs in (default, low_pitch):
        eta = coeffs.efficiency()
        assert 0.6 < eta.max() < 0.92
        assert coeffs.advance_ratio[np.argmax(eta)] < coeffs.zero_thrust_advance_ratio()
        assert np.all(eta[coeffs.thrust_coeff <= 0] == 0)


def test_static_figure_of_merit(default, low_pitch):
    fm_low = figure_of_merit(low_pitch.thrust_coeff[0], low_pitch.power_coeff[0])
    assert 0.4 < fm_low < 0.85
    # at P/D 1.3 the static blade is stalled, so hovering costs more power
    fm_default = figure_of_merit(default.thrust_coeff[0], default.power_coeff[0])
    assert 0.0 < fm_default < fm_low


def test_station_count_converged(default):
    j = default.advance_ratio[::8]
    fine = propeller_coefficients(DEFAULT, advance_ratios=j, stations=80)
    assert np.allclose(fine.thrust_coeff, default.thrust_coeff[::8], atol=2e-4)
    assert np.allclose(fine.power_coeff, default.power_coeff[::8], atol=2e-4)


def test_deterministic(default):
    again = propeller_coefficients(DEFAULT)
    assert np.array_equal(again.advance_ratio, default.advance_ratio)
    assert np.array_equal(again.thrust_coeff, default.thrust_coeff)
    assert np.array_equal(again.power_coeff, default.power_coeff)

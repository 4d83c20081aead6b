"""Where in frequency a controller leaves its errors (``training.evaluation.spectrum``)."""

from __future__ import annotations

import numpy as np
import pytest

from training.evaluation.spectrum import BANDS_HZ, band_shares, mean_step_change


def test_a_sinusoids_power_lies_in_its_band_and_the_mean_is_not_counted():
    t = np.arange(0.0, 200.0, 0.04)
    slow = 5.0 + np.sin(2 * np.pi * 0.1 * t)  # 0.1 Hz on a steady offset
    shares = band_shares(slow, 0.04)
    assert shares[1] == pytest.approx(1.0, abs=1e-6) and sum(shares) == pytest.approx(1.0)
    mixed = np.sin(2 * np.pi * 0.1 * t) + np.sin(2 * np.pi * 2.0 * t)  # equal power at 0.1 and 2 Hz
    shares = band_shares(mixed, 0.04)
    assert shares[1] == pytest.approx(0.5, abs=1e-3) and shares[4] == pytest.approx(0.5, abs=1e-3)
    assert len(shares) == len(BANDS_HZ) and band_shares(np.ones(20), 0.04) == [0.0] * len(BANDS_HZ)


@pytest.mark.parametrize(("signal", "dt_s"), [(np.ones(5), 0.04), (np.array([1.0] * 9 + [np.nan]), 0.04),
                                              (np.ones((10, 2)), 0.04), (np.ones(10), 0.0)])
def test_too_short_non_finite_or_badly_sampled_signals_are_refused(signal, dt_s):
    with pytest.raises(ValueError, match="samples|interval"):
        band_shares(signal, dt_s)


def test_the_mean_step_change_is_how_busy_a_command_is():
    assert mean_step_change([0.0, 1.0, 0.0, 1.0]) == 1.0 and mean_step_change([2.0, 2.0, 2.0]) == 0.0


def test_the_script_refuses_an_unknown_controller(load_script, capsys):
    assert load_script("error_spectrum").main(["--controllers", "pid,mpc"]) == 2
    assert "--controllers takes any of" in capsys.readouterr().err

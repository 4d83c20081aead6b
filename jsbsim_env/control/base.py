"""The interface every attitude controller shares (PID baseline, trained policy, ...).

A controller is called once per control step with the measured state and the attitude
setpoint and returns the physical command; the flight core applies it with its delay, lag,
rate limits and backlash. Units follow ``jsbsim_env.sim.core``:

| argument | contents |
|---|---|
| ``dt_s`` | seconds since the previous call (the control interval) |
| ``measurement`` | ``core.STATE_NAMES``: altitude m, roll, pitch rad, p, q, r rad/s, V_eas m/s, alpha, beta rad, aileron, elevator, rudder rad, throttle |
| ``setpoint`` | roll_cmd rad, pitch_cmd rad, V_eas_cmd m/s |
| returns | aileron, elevator, rudder deg, throttle 0..1, inside the aircraft's range (``Aircraft.command_low``/``command_high``) |
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class AttitudeController(Protocol):
    """``reset()`` at the start of a flight, then ``update(dt_s, measurement, setpoint)`` each step."""

    def reset(self) -> None: ...

    def update(self, dt_s: float, measurement: np.ndarray, setpoint: np.ndarray) -> np.ndarray: ...

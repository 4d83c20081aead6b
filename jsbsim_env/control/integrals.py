"""Error integrals the learned controller reads: integral action it learns to use, rather than a
classical integrator added to its command.

``ErrorIntegrals`` integrates, over the flight, the roll and pitch errors against the goal the
network is given and the sideslip (its goal is zero), each in deg s. The network sees them in its
observation (``jsbsim_env.control.observation.INTEGRAL_NAMES``) and sets the surfaces from them as
it sets them from anything else: whether a steady error is removed, and how fast, is learned.
Without them the network sees 8 control steps (0.4 s), and cannot tell a steady error of a tenth of
a degree from sensor noise.

| rule | value | why |
|---|---|---|
| integrates while | the error is below ``ACTIVE_BELOW_DEG`` | a goal step's transient is not a steady error (conditional integration, as the goal trim) |
| bounded to | +-``LIMIT_DEG_S`` | no windup beyond what a steady error of a few tenths of a degree builds in a minute |
| starts at | 0, with each flight | as the surface trim |

The training task and the flight stack run the same object on the same measurements (the
measured state, noise included), so the network trains on the integrals it flies with.
"""

from __future__ import annotations

import math

from jsbsim_env.sim.core import STATE_NAMES

ACTIVE_BELOW_DEG = 1.0
LIMIT_DEG_S = 10.0
_ROLL, _PITCH, _BETA = (STATE_NAMES.index(n) for n in ("roll_rad", "pitch_rad", "beta_rad"))
_DEG = math.degrees(1.0)


def check_error_integrals(value, name: str = "error_integrals") -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is True or False (whether a network reads
    the error integrals)."""
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")  # noqa: TRY004 - a bad setting, by name


class ErrorIntegrals:
    """The roll, pitch and sideslip error integrals (deg s) of one aircraft, on plain floats."""

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        self.integral_deg_s = [0.0, 0.0, 0.0]

    def integrate(self, dt_s: float, measurement, goal) -> list[float]:
        """One control interval on a measured state (``core.STATE_NAMES``) against the goal the network
        is given (roll, pitch rad, ...); returns the integrals (deg s) of goal - measured roll, goal -
        measured pitch and - measured sideslip."""
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"control interval must be positive and finite, got {dt_s} s")
        errors_deg = ((float(goal[0]) - float(measurement[_ROLL])) * _DEG,
                      (float(goal[1]) - float(measurement[_PITCH])) * _DEG,
                      -float(measurement[_BETA]) * _DEG)
        for j, error in enumerate(errors_deg):
            if abs(error) < ACTIVE_BELOW_DEG:  # a NaN error integrates nothing either
                self.integral_deg_s[j] = min(max(self.integral_deg_s[j] + dt_s * error, -LIMIT_DEG_S), LIMIT_DEG_S)
        return self.integral_deg_s


__all__ = ["ACTIVE_BELOW_DEG", "LIMIT_DEG_S", "ErrorIntegrals", "check_error_integrals"]

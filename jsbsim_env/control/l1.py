"""L1 lateral guidance: a roll demand that brings the aircraft onto a straight leg.

After Park, Deyst and How (2004) as implemented in PX4's ``ECL_L1_Pos_Controller`` and
ArduPilot's ``AP_L1_Control``. With the ground velocity v, the L1 distance
L1 = period x damping / pi x |v| and the leg A -> B (unit vector t):

* eta2 = angle between the ground velocity and the leg, atan2(v x t, v . t);
* eta1 = asin(clamp(cross-track error / L1, +-sin 45 deg));
* eta = clamp(eta1 + eta2, +-90 deg), lateral acceleration a = 4 damping^2 |v|^2 / L1 sin(eta);
* roll demand = atan(a / g), limited to the attitude controller's range.

The period grows with the ground speed where the roll limit would otherwise clip the demand at a
small heading error. With L1 as above, the heading-error term asks for 4 pi damping |v| / period
times sin(eta2), and the 5 deg roll limit allows g tan 5 deg = 0.86 m/s^2. At 10 km (about 17 m/s
true airspeed) the 25 s period clips from 7.6 deg of heading error; at 20 km (about 37 m/s) it
would clip from 3.5 deg, and the demand then jumps between the two roll limits on a straight leg.
So the period is at least 4 pi damping |v| sin(``linear_heading_deg``) / (g tan roll_limit): 20 s
at 10 km, where the 25 s period stands, and 43 s at 20 km.

If the aircraft is farther than L1 from A and more than 135 deg behind it (seen along the leg),
it first flies to A (PX4's capture case). Coordinates are local north/east in metres; positive roll banks right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

G_MPS2 = 9.80665


@dataclass(frozen=True)
class L1Params:
    period_s: float = 25.0  # NAV_L1_PERIOD (PX4 default 20; longer for this slow, large aircraft)
    damping: float = 0.75  # NAV_L1_DAMPING (PX4 default)
    roll_limit_rad: float = math.radians(5.0)  # the paper's roll_cmd range (Table 2)
    linear_heading_deg: float = 6.0  # the roll limit clips the demand from no smaller a heading error (module doc)

    def __post_init__(self):
        if not (self.period_s > 0.0 and 0.0 < self.damping <= 2.0 and 0.0 < self.roll_limit_rad < math.pi / 2
                and 0.0 <= self.linear_heading_deg < 90.0):
            raise ValueError(f"L1 parameters out of range: period_s {self.period_s} (> 0), damping {self.damping} "
                             f"(0, 2], roll_limit_rad {self.roll_limit_rad} (0, pi/2), linear_heading_deg "
                             f"{self.linear_heading_deg} [0, 90)")

    def period_at(self, ground_speed_mps: float) -> float:
        """The guidance period (s) at this ground speed: ``period_s``, or longer where the roll limit
        would clip the demand from a heading error below ``linear_heading_deg`` (module doc)."""
        clip_free_s = (4.0 * math.pi * self.damping * ground_speed_mps * math.sin(math.radians(self.linear_heading_deg))
                       / (G_MPS2 * math.tan(self.roll_limit_rad)))
        return max(self.period_s, clip_free_s)


@dataclass(frozen=True)
class L1Output:
    roll_rad: float
    cross_track_m: float  # positive: the aircraft is right of the leg
    lateral_accel_mps2: float
    l1_distance_m: float


def _cross(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


class L1Guidance:
    """Stateless guidance law; ``update`` follows the leg from ``a`` to ``b``."""

    def __init__(self, params: L1Params | None = None):
        self.p = params or L1Params()

    def reset(self) -> None:
        """Nothing to reset; here for the shared controller interface."""

    def l1_distance_m(self, ground_speed_mps: float) -> float:
        return self.p.period_at(ground_speed_mps) * self.p.damping / math.pi * ground_speed_mps

    def update(self, position_ne_m: tuple[float, float], velocity_ne_mps: tuple[float, float],
               a_ne_m: tuple[float, float], b_ne_m: tuple[float, float]) -> L1Output:
        """Roll demand for the leg ``a`` -> ``b`` (north, east in metres) from the position and
        the ground velocity (north, east in m/s)."""
        values = (*position_ne_m, *velocity_ne_mps, *a_ne_m, *b_ne_m)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"L1 guidance inputs must be finite: {values}")
        p = self.p
        vn, ve = velocity_ne_mps
        speed = max(math.hypot(vn, ve), 0.1)
        l1 = self.l1_distance_m(speed)
        k_l1 = 4.0 * p.damping * p.damping
        ab_n, ab_e = b_ne_m[0] - a_ne_m[0], b_ne_m[1] - a_ne_m[1]
        length = math.hypot(ab_n, ab_e)
        if length < 1e-6:
            raise ValueError("L1 leg has zero length")
        tn, te = ab_n / length, ab_e / length
        an, ae = position_ne_m[0] - a_ne_m[0], position_ne_m[1] - a_ne_m[1]  # A -> aircraft
        along = an * tn + ae * te
        cross_track = _cross(tn, te, an, ae)  # positive right of the leg (north-east axes)
        distance_a = math.hypot(an, ae)
        if distance_a > l1 and along / max(distance_a, 1.0) < -math.sqrt(0.5):
            # Farther than L1 from A and more than 135 deg behind it: head for A first.
            to_a_n, to_a_e = -an / distance_a, -ae / distance_a
            eta = math.atan2(_cross(vn, ve, to_a_n, to_a_e), vn * to_a_n + ve * to_a_e)
        else:
            eta2 = math.atan2(_cross(vn, ve, tn, te), vn * tn + ve * te)
            eta1 = math.asin(min(max(-cross_track / l1, -math.sqrt(0.5)), math.sqrt(0.5)))
            eta = eta1 + eta2
        eta = min(max(eta, -math.pi / 2), math.pi / 2)
        accel = k_l1 * speed * speed / l1 * math.sin(eta)
        roll = min(max(math.atan(accel / G_MPS2), -p.roll_limit_rad), p.roll_limit_rad)
        return L1Output(roll, cross_track, accel, l1)

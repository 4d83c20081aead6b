"""Total Energy Control System: pitch and throttle demands from height and airspeed demands.

After the TECS of PX4's estimation and control library (``tecs.cpp``, 2017) and Lambregts' total
energy control: the throttle controls the specific total energy E_T = g h + V^2/2, the pitch the
energy balance E_B = w_P g h - w_K V^2/2 (w_K = ``speed_weight``, w_P = 2 - w_K).

Per update (SI units, TAS for the energy terms):

* the height and airspeed demands move towards the commanded ones no faster than the climb and
  sink limits and ``max_speed_rate_mps2`` (PX4's setpoint rate limits), so that a step command
  does not appear as a large energy error;
* height-rate demand  h_dot_sp = (h_sp - h) / time_const, limited to [-max_sink, max_climb];
  TAS-rate demand     V_dot_sp = (V_sp - V) / time_const;
* throttle = cruise throttle + feed-forward of the demanded total-energy rate, mapped linearly
  between the energy rate at zero and at full throttle, + (E_T error + throttle_damping x
  E_T-rate error) / (throttle_time_const x energy-rate range) + integral of the E_T error;
* pitch = level-flight pitch + (E_B error + pitch_damping x E_B-rate error + E_B-rate demand x
  time_const + integral) / (V g time_const), limited to the pitch range and to a
  vertical-acceleration limit.

The energy rates at zero and full throttle come from the aircraft's linear models (the design
table of ``pid.py``: cruise throttle, level-flight pitch and TAS acceleration per unit throttle
at each altitude), where PX4 takes them from its climb and sink parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

G_MPS2 = 9.80665


@dataclass(frozen=True)
class TECSParams:
    """PX4 parameter names in brackets; defaults are PX4's unless noted."""

    time_const_s: float = 5.0  # FW_T_TIME_CONST: height and pitch loop time constant
    throttle_time_const_s: float = 8.0  # FW_T_THRO_CONST
    integrator_gain: float = 0.1  # FW_T_INTEG_GAIN, 1/s
    throttle_damping: float = 0.5  # FW_T_THR_DAMP, s
    pitch_damping: float = 0.0  # FW_T_PTCH_DAMP, s
    speed_weight: float = 1.0  # FW_T_SPDWEIGHT: 0 height only ... 2 speed only
    max_climb_mps: float = 1.0  # FW_T_CLMB_MAX (here: a gentle climb for a 10 m/s EAS glider-like aircraft)
    max_sink_mps: float = 1.5  # FW_T_SINK_MAX (here, as above)
    pitch_limits_rad: tuple[float, float] = (math.radians(-10.0), math.radians(10.0))  # the paper's theta_cmd range (Table 2)
    vert_accel_limit_mps2: float = 2.0  # FW_T_VERT_ACC (PX4: 7; gentler for this airframe)
    throttle_limits: tuple[float, float] = (0.0, 1.0)
    speed_rate_filter_s: float = 0.5  # first-order filter on the differentiated airspeed
    max_speed_rate_mps2: float = 0.2  # rate limit of the airspeed demand (PX4 limits it by the achievable acceleration)


@dataclass(frozen=True)
class TECSOutput:
    pitch_rad: float
    throttle: float
    height_rate_setpoint_mps: float
    total_energy_error_m2ps2: float
    balance_error_m2ps2: float


class TECS:
    """``reset()``, then ``update(dt_s, ...)`` at the outer-loop rate (25 Hz in the missions)."""

    def __init__(self, params: TECSParams | None = None):
        self.p = params or TECSParams()
        self.reset()

    def reset(self) -> None:
        self._initialised = False
        self.throttle_integral = 0.0
        self.pitch_integral = 0.0
        self.last_pitch_rad = 0.0
        self.pitch_unclamped_rad = 0.0
        self._tas_prev = None
        self.tas_rate_mps2 = 0.0
        self._ste_rate_error = 0.0

    def update(self, dt_s: float, altitude_m: float, climb_rate_mps: float, tas_mps: float, eas_to_tas: float,
               pitch_rad: float, altitude_sp_m: float, eas_sp_mps: float, throttle_cruise: float,
               tas_accel_per_throttle_mps2: float, pitch_offset_rad: float = 0.0) -> TECSOutput:
        """One TECS step.

        Args:
            dt_s: time since the last update.
            altitude_m, climb_rate_mps, tas_mps, pitch_rad: measured height, climb rate, true airspeed, pitch.
            eas_to_tas: V_tas / V_eas at this altitude.
            altitude_sp_m, eas_sp_mps: the demands.
            throttle_cruise: throttle of level flight at the demanded speed.
            tas_accel_per_throttle_mps2: dV_tas/dt per unit throttle (linear model), for the
                energy rates at zero and full throttle.
            pitch_offset_rad: pitch of level flight (PX4's FW_PSP_OFF), added to the demand so
                the integrator does not have to find the angle of attack.
        """
        p = self.p
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"TECS time step must be positive and finite, got {dt_s}")
        for name, value in (("altitude", altitude_m), ("climb rate", climb_rate_mps), ("TAS", tas_mps),
                            ("pitch", pitch_rad), ("altitude demand", altitude_sp_m), ("EAS demand", eas_sp_mps)):
            if not math.isfinite(value):
                raise ValueError(f"TECS input {name} is not finite: {value}")
        if not self._initialised:
            self._tas_prev = tas_mps
            self.last_pitch_rad = self.pitch_unclamped_rad = pitch_rad
            self.altitude_demand_m, self.eas_demand_mps = altitude_m, tas_mps / eas_to_tas
            self._initialised = True
        # Airspeed rate: differentiated and filtered (PX4 uses a complementary filter with the
        # longitudinal acceleration; airspeed alone is what this aircraft's sensor set gives).
        raw_rate = (tas_mps - self._tas_prev) / dt_s
        self._tas_prev = tas_mps
        a = dt_s / (p.speed_rate_filter_s + dt_s)
        self.tas_rate_mps2 += a * (raw_rate - self.tas_rate_mps2)

        # Rate-limited demands.
        self.altitude_demand_m += min(max(altitude_sp_m - self.altitude_demand_m, -p.max_sink_mps * dt_s),
                                      p.max_climb_mps * dt_s)
        self.eas_demand_mps += min(max(eas_sp_mps - self.eas_demand_mps, -p.max_speed_rate_mps2 * dt_s),
                                   p.max_speed_rate_mps2 * dt_s)
        h_sp = self.altitude_demand_m
        tas_sp = self.eas_demand_mps * eas_to_tas
        h_rate_sp = min(max((h_sp - altitude_m) / p.time_const_s, -p.max_sink_mps), p.max_climb_mps)
        tas_rate_sp = (tas_sp - tas_mps) / p.time_const_s

        spe_sp, ske_sp = h_sp * G_MPS2, 0.5 * tas_sp * tas_sp
        spe, ske = altitude_m * G_MPS2, 0.5 * tas_mps * tas_mps
        spe_rate_sp, ske_rate_sp = h_rate_sp * G_MPS2, tas_mps * tas_rate_sp
        spe_rate, ske_rate = climb_rate_mps * G_MPS2, tas_mps * self.tas_rate_mps2

        # ---- throttle from total energy
        thr_min, thr_max = p.throttle_limits
        ste_rate_max = tas_accel_per_throttle_mps2 * tas_mps * (thr_max - throttle_cruise)
        ste_rate_min = -tas_accel_per_throttle_mps2 * tas_mps * (throttle_cruise - thr_min)
        ste_error = spe_sp - spe + ske_sp - ske
        ste_rate_sp = min(max(spe_rate_sp + ske_rate_sp, ste_rate_min), ste_rate_max)
        self._ste_rate_error = 0.2 * (ste_rate_sp - spe_rate - ske_rate) + 0.8 * self._ste_rate_error
        if ste_rate_sp >= 0.0:
            predicted = throttle_cruise + ste_rate_sp / ste_rate_max * (thr_max - throttle_cruise)
        else:
            predicted = throttle_cruise + ste_rate_sp / ste_rate_min * (thr_min - throttle_cruise)
        ste_to_throttle = 1.0 / (p.throttle_time_const_s * (ste_rate_max - ste_rate_min))
        throttle = (ste_error + self._ste_rate_error * p.throttle_damping) * ste_to_throttle + predicted
        throttle = min(max(throttle, thr_min), thr_max)
        # Integrator bounded so it can always pull the throttle 10 % into saturation and back.
        self.throttle_integral += ste_error * p.integrator_gain * dt_s * ste_to_throttle
        self.throttle_integral = min(max(self.throttle_integral, thr_min - throttle - 0.1), thr_max - throttle + 0.1)
        throttle = min(max(throttle + self.throttle_integral, thr_min), thr_max)

        # ---- pitch from energy balance
        w_k = min(max(p.speed_weight, 0.0), 2.0)
        w_p = 2.0 - w_k
        seb_error = (spe_sp * w_p - ske_sp * w_k) - (spe * w_p - ske * w_k)
        seb_rate_sp = spe_rate_sp * w_p - ske_rate_sp * w_k
        seb_rate_error = seb_rate_sp - (spe_rate * w_p - ske_rate * w_k)
        climb_angle_to_seb_rate = tas_mps * p.time_const_s * G_MPS2
        pitch_min, pitch_max = p.pitch_limits_rad
        integ_input = seb_error * p.integrator_gain
        # Do not integrate further into a saturated pitch demand.
        if self.pitch_unclamped_rad > pitch_max:
            integ_input = min(integ_input, 0.0)
        elif self.pitch_unclamped_rad < pitch_min:
            integ_input = max(integ_input, 0.0)
        self.pitch_integral += integ_input * dt_s
        correction = seb_error + seb_rate_error * p.pitch_damping + seb_rate_sp * p.time_const_s
        self.pitch_unclamped_rad = pitch_offset_rad + (correction + self.pitch_integral) / climb_angle_to_seb_rate
        pitch = min(max(self.pitch_unclamped_rad, pitch_min), pitch_max)
        step = dt_s * p.vert_accel_limit_mps2 / tas_mps
        pitch = min(max(pitch, self.last_pitch_rad - step), self.last_pitch_rad + step)
        self.last_pitch_rad = pitch
        return TECSOutput(pitch, throttle, h_rate_sp, ste_error, seb_error)

"""Blade-element momentum theory (BEMT) performance of a fixed-pitch propeller.

Produces the propeller tables JSBSim uses, in its coefficient convention
(n in rev/s, D in m, V in m/s, T in N, P in W, rho in kg/m^3)::

    J = V / (n D),   CT = T / (rho n^2 D^4),   CP = P / (rho n^3 D^5),   eta = J CT / CP

Method: the blade is split into annuli (cosine spacing, evaluated at the annulus mid-points).
At each station the only unknown is the inflow angle phi, found from the residual of
Ning (2014), written for a propeller (the induction speeds the axial flow up, a > 0,
and the swirl slows the rotational flow, a' > 0)::

    R(phi) = sin(phi) / (1 + a) - lambda_r cos(phi) / (1 - a')
    a / (1 + a)   = k  = sigma' cn / (4 F sin^2 phi)
    a' / (1 - a') = k' = sigma' ct / (4 F sin phi cos phi)

with lambda_r = V / (Omega r) = J / (pi x), x = r / R, local solidity sigma' = B c / (2 pi r),
cn = cl cos(phi) - cd sin(phi), ct = cl sin(phi) + cd cos(phi), and F the product of the
Prandtl tip and hub loss factors.  R is multiplied by 4 F sin(phi): this removes its pole
at phi = 0 and keeps it finite in the static case (lambda_r = 0, a -> infinity) without
changing the roots.  The root is bracketed as Ning recommends and found with Brent's method,
so every station converges, windmilling ones past the zero-thrust J included.  The relative
speed then follows from the swirl equation, W = Omega r (1 - a') / cos(phi), finite at V = 0.
No high-induction (Glauert/Buhl) correction is applied: over the default J range the
windmilling induction stays small (a > -0.06 for the default geometry).

Reference: S. A. Ning, "A simple solution method to the blade element momentum equations
with guaranteed convergence", Wind Energy 17(9), 1327-1345, 2014, doi:10.1002/we.1636.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

_ALPHA_TABLE_DEG = np.linspace(-180.0, 180.0, 1441)  # 0.25 deg polar table
_X_CHORD_MAX = 0.4  # r/R where the chord peaks
_J_STEP = 0.05  # default advance-ratio grid spacing
_J_MARGIN = 0.5  # default grid runs this far past the first J with CT <= 0
_J_LIMIT = 20.0  # give up if thrust never reverses before this J
_PHI_EPS = 1e-9  # rad; phi = 0 is no solution (the residual was multiplied by sin phi)
_BRACKETS = (  # Ning (2014) search order: normal operation, propeller brake, then beyond pi/2
    (_PHI_EPS, math.pi / 2),
    (-math.pi / 4, -_PHI_EPS),
    (math.pi / 2, math.pi - _PHI_EPS),
)


@dataclass(frozen=True)
class PropellerGeometry:
    """Geometry of one propeller (documented design values)."""

    diameter_m: float = 2.2
    hub_diameter_m: float = 0.22
    blade_count: int = 2
    pitch_to_diameter: float = 1.3  # geometric pitch P/D at 0.75 R, constant-pitch (helical) twist
    chord_root_to_radius: float = 0.10  # blade chord / tip radius at the hub station
    chord_max_to_radius: float = 0.13  # max chord / R, reached near 0.4 R
    chord_tip_to_radius: float = 0.06  # chord / R at the tip
    airfoil: str = "clarky"  # AeroSandbox airfoil-database name used for the blade sections
    section_reynolds: float = 2.0e5  # representative blade-section Reynolds number for the polar
    section_mach: float = 0.0


@dataclass(frozen=True)
class PropellerCoefficients:
    """Propeller coefficients against advance ratio, JSBSim convention (see module docstring)."""

    advance_ratio: np.ndarray  # J = V/(n D), ascending, starting at 0
    thrust_coeff: np.ndarray  # CT = T/(rho n^2 D^4)
    power_coeff: np.ndarray  # CP = P/(rho n^3 D^5)

    def efficiency(self) -> np.ndarray:
        """Propulsive efficiency J*CT/CP; 0 where CT <= 0 or CP <= 0 (no useful thrust)."""
        useful = (self.thrust_coeff > 0) & (self.power_coeff > 0)
        safe_cp = np.where(useful, self.power_coeff, 1.0)
        return np.where(useful, self.advance_ratio * self.thrust_coeff / safe_cp, 0.0)

    def zero_thrust_advance_ratio(self) -> float:
        """J where CT first crosses zero (linear interpolation); nan if it never does."""
        ct, j = self.thrust_coeff, self.advance_ratio
        idx = np.flatnonzero((ct[:-1] > 0) & (ct[1:] <= 0))
        if idx.size == 0:
            return math.nan
        i = idx[0]
        return float(j[i] + (j[i + 1] - j[i]) * ct[i] / (ct[i] - ct[i + 1]))


def section_polar(
    geometry: PropellerGeometry, alpha_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Section lift and drag coefficients (cl, cd) of the blade airfoil at angles alpha_deg (deg).

    Uses NeuralFoil (through AeroSandbox, imported here so the package works without it) at
    geometry.section_reynolds and geometry.section_mach.  NeuralFoil blends its output into a
    flat-plate model past stall, so the polar is finite and continuous over -180..180 deg.
    """
    import aerosandbox as asb

    aero = asb.Airfoil(geometry.airfoil).get_aero_from_neuralfoil(
        alpha=np.asarray(alpha_deg, dtype=float),
        Re=geometry.section_reynolds,
        mach=geometry.section_mach,
        model_size="large",
    )
    return np.asarray(aero["CL"], dtype=float), np.asarray(aero["CD"], dtype=float)


def _chord_to_radius(geometry: PropellerGeometry, x: np.ndarray) -> np.ndarray:
    """Chord/R at x = r/R: two parabolas meeting with zero slope at the max chord (C1-smooth)."""
    g = geometry
    inboard = x < _X_CHORD_MAX
    end_x = np.where(inboard, g.hub_diameter_m / g.diameter_m, 1.0)
    end_c = np.where(inboard, g.chord_root_to_radius, g.chord_tip_to_radius)
    s = (x - _X_CHORD_MAX) / (end_x - _X_CHORD_MAX)
    return g.chord_max_to_radius + (end_c - g.chord_max_to_radius) * s**2


def _station_load_factors(x, sigma, beta, lam, x_hub, blades, cl_table, cd_table):
    """Solve one station; return (W/(Omega r))^2 * cn and (W/(Omega r))^2 * ct."""

    def forces(phi):
        s, c = math.sin(phi), math.cos(phi)
        alpha = (math.degrees(beta - phi) + 180.0) % 360.0 - 180.0
        cl = float(np.interp(alpha, _ALPHA_TABLE_DEG, cl_table))
        cd = float(np.interp(alpha, _ALPHA_TABLE_DEG, cd_table))
        # Prandtl tip and hub loss; |sin phi| floored so F -> 1 as phi -> 0
        sin_abs = max(abs(s), 1e-12)
        f_tip = 0.5 * blades * (1.0 - x) / (x * sin_abs)
        f_hub = 0.5 * blades * (x - x_hub) / (x_hub * sin_abs)
        loss = (2.0 / math.pi) ** 2 * math.acos(math.exp(-f_tip))
        loss *= math.acos(math.exp(-f_hub))
        return s, c, cl * c - cd * s, cl * s + cd * c, loss

    def residual(phi):
        s, c, cn, ct, loss = forces(phi)
        return 4.0 * loss * s * s - sigma * cn - lam * (4.0 * loss * s * c + sigma * ct)

    for lo, hi in _BRACKETS:
        if residual(lo) * residual(hi) <= 0.0:
            phi = brentq(residual, lo, hi, xtol=1e-12)
            break
    else:
        raise RuntimeError(f"BEMT: no inflow-angle root at r/R={x:.3f}, lambda_r={lam:.3f}")
    s, c, cn, ct, loss = forces(phi)
    # (W / Omega r)^2 = ((1 - a') / cos phi)^2, finite also when V = 0
    w2 = (4.0 * loss * s / (4.0 * loss * s * c + sigma * ct)) ** 2
    return w2 * cn, w2 * ct


def propeller_coefficients(
    geometry: PropellerGeometry = PropellerGeometry(),
    advance_ratios: np.ndarray | None = None,
    stations: int = 40,
) -> PropellerCoefficients:
    """CT and CP against J by BEMT with Prandtl tip and hub loss (method in the module docstring).

    advance_ratios: J values to evaluate (ascending from 0 for a JSBSim table).  By default J
    runs from 0 in steps of 0.05 up to 0.5 past the first J with CT <= 0 (0 to 2.0 for the
    default geometry), so the table includes windmilling (CT < 0, and CP < 0 further out).
    stations: number of radial blade elements between hub and tip.
    """
    g = geometry
    cl_table, cd_table = section_polar(g, _ALPHA_TABLE_DEG)
    x_hub = g.hub_diameter_m / g.diameter_m
    # cosine spacing concentrates stations where the hub and tip losses vary quickly
    edges = x_hub + (1.0 - x_hub) * 0.5 * (1.0 - np.cos(np.linspace(0.0, math.pi, stations + 1)))
    x, dx = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    chord = _chord_to_radius(g, x)
    sigma = g.blade_count * chord / (2.0 * math.pi * x)
    beta = np.arctan(g.pitch_to_diameter / (math.pi * x))  # helical twist: constant pitch P

    def coefficients_at(j: float) -> tuple[float, float]:
        lam = j / (math.pi * x)  # V / (Omega r)
        loads = np.array([
            _station_load_factors(*station, x_hub, g.blade_count, cl_table, cd_table)
            for station in zip(x, sigma, beta, lam)
        ])
        # dT = B/2 rho W^2 c cn dr, dP = Omega r B/2 rho W^2 c ct dr; with W = w Omega r, r = x D/2
        # and Omega = 2 pi n: dCT/dx = B pi^2/8 x^2 (c/R) w^2 cn, dCP/dx = pi x (same with ct)
        weight = g.blade_count * math.pi**2 / 8.0 * x**2 * chord * dx
        ct = np.sum(weight * loads[:, 0])
        return float(ct), float(np.sum(math.pi * x * weight * loads[:, 1]))

    if advance_ratios is not None:
        j_values = np.asarray(advance_ratios, dtype=float)
        rows = [coefficients_at(j) for j in j_values]
    else:
        rows, k, k_stop = [], 0, None
        while k_stop is None or k <= k_stop:
            if k * _J_STEP > _J_LIMIT:
                raise RuntimeError(f"BEMT: thrust still positive at J={_J_LIMIT}")
            rows.append(coefficients_at(k * _J_STEP))
            if k_stop is None and rows[-1][0] <= 0.0:
                k_stop = k + round(_J_MARGIN / _J_STEP)
            k += 1
        j_values = _J_STEP * np.arange(k)
    ct, cp = np.array(rows).reshape(-1, 2).T
    return PropellerCoefficients(advance_ratio=j_values, thrust_coeff=ct, power_coeff=cp)


def full_power_speed_rpm(advance_ratio: np.ndarray, power_coeff: np.ndarray, diameter_m: float, power_w: float,
                         density_kg_m3: float, airspeed_mps: float) -> float:
    """Rotor speed (rpm) at which the propeller absorbs ``power_w`` at ``airspeed_mps`` and ``density_kg_m3``.

    Solves CP(J) rho n^3 D^5 = P with J = V/(n D) on the tabulated power coefficient; the absorbed
    power rises monotonically with n over the table's range. Infinite where the propeller cannot
    absorb ``power_w`` below ``MAX_SOLVED_RPS`` (thin air: the caller caps the speed at the rotor's
    limit).
    """
    def excess_w(n_rps: float) -> float:
        j = airspeed_mps / (n_rps * diameter_m)
        return float(np.interp(j, advance_ratio, power_coeff)) * density_kg_m3 * n_rps**3 * diameter_m**5 - power_w

    low_rps = max(airspeed_mps / (diameter_m * float(np.max(advance_ratio))), 0.1)
    if excess_w(MAX_SOLVED_RPS) < 0.0:
        return math.inf
    return 60.0 * brentq(excess_w, low_rps, MAX_SOLVED_RPS)


MAX_SOLVED_RPS = 200.0  # 12,000 rpm: far above any rotor's limit here

"""The documented geometry of the solar UAV: the single source every aerodynamic number is computed from.

Frame: JSBSim's structural frame, which is also AeroSandbox's geometry frame: x aft, y out of the
right wing, z up, in metres, origin at the wing root leading edge.

The published figures (the paper's Table 1: span 35 m, area 78.5 m², aspect ratio 15.6, chord 2.27 m,
mass 359 kg, the inertia tensor) are kept exactly. What the paper does not publish (airfoil, planform
break, tails, control-surface sizes, propellers) is chosen here as a conventional layout for a
high-altitude solar aircraft of this size, each value with the reason beside it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .. import PAPER_SAMPLE_ALTITUDES_M, altitude_like_m
from .propeller import PropellerGeometry


@dataclass(frozen=True)
class WingGeometry:
    """Main wing: a rectangular centre section and tapered outer panels with dihedral and washout."""

    airfoil: str = "fx63137"  # Wortmann FX 63-137: the classic high-lift low-Reynolds section of solar aircraft
    span_m: float = 35.0  # the paper's Table 1
    area_m2: float = 78.5  # the paper's Table 1
    kink_y_m: float = 8.75  # end of the rectangular centre section (half of the semi-span)
    root_chord_m: float = 2.40  # centre-section chord; the tip chord follows from the area
    outer_dihedral_deg: float = 5.0  # outer panels only: roll stability (Clβ < 0) with a flat centre
    tip_twist_deg: float = -2.0  # washout: the tips stall last, keeping the ailerons effective
    incidence_deg: float = 0.0  # wing-root incidence to the fuselage datum

    @property
    def tip_chord_m(self) -> float:
        """Tip chord that gives the published area with the planform above."""
        half_area_m2 = self.area_m2 / 2.0
        outer_span_m = self.span_m / 2.0 - self.kink_y_m
        return 2.0 * (half_area_m2 - self.kink_y_m * self.root_chord_m) / outer_span_m - self.root_chord_m


@dataclass(frozen=True)
class TailSurface:
    """A trapezoidal tail surface; for the horizontal tail the values describe one half."""

    airfoil: str
    root_le_m: tuple[float, float, float]  # leading edge of the root section
    tip_le_m: tuple[float, float, float]  # leading edge of the tip section
    root_chord_m: float
    tip_chord_m: float
    incidence_deg: float  # for the horizontal tail: nose-up positive
    control_chord_fraction: float  # elevator / rudder chord over local chord (hinge at 1 - this)
    efficiency: float  # dynamic-pressure ratio q_tail / q (wing wake, boom interference)


@dataclass(frozen=True)
class ControlSurfaceSpan:
    """Spanwise extent of one aileron (right side; the left is its mirror image)."""

    inner_y_m: float = 11.0
    outer_y_m: float = 16.5
    chord_fraction: float = 0.25  # aileron chord over local wing chord, hinge at 75 % chord


@dataclass(frozen=True)
class Rotor:
    """One propeller: hub position and sense of rotation (+1 clockwise seen from behind)."""

    position_m: tuple[float, float, float]
    sense: int


@dataclass(frozen=True)
class ContactPoint:
    """A JSBSim ground contact."""

    name: str
    kind: str  # "BOGEY" (wheel or skid) or "STRUCTURE" (detects a ground strike)
    position_m: tuple[float, float, float]
    static_friction: float
    spring_n_per_m: float
    damping_n_s_per_m: float


@dataclass(frozen=True)
class FlightEnvelope:
    """Where the aircraft flies, as its aerodynamic analysis covers it: the Reynolds number on the
    mean chord is the analysis's flight-condition variable, each breakpoint flown at the reference
    equivalent airspeed at the altitude (within ``altitude_range_m``) where it gives that number."""

    altitude_range_m: tuple[float, float] = (0.0, 20000.0)  # the paper's 0-20 km
    eas_range_mps: tuple[float, float] = (8.0, 12.0)  # the paper's Section 3.4: goals and starts, trimmed
    reference_eas_mps: float = 10.0  # cruise EAS, the middle of the paper's 8-12 m/s
    # 10 m/s EAS on the 2.27 m chord: about 1.9e6 at sea level, 0.4e6 at 20 km.
    reynolds: tuple[float, ...] = (3.0e5, 5.0e5, 7.5e5, 1.0e6, 1.5e6, 2.0e6)
    cruise_reynolds: float = 1.0e6  # the breakpoint of the cruise lift coefficient and static margin (mid-envelope)
    lattice_reynolds: float = 1.0e6  # the flight condition of the vortex lattice (mid-envelope)

    @property
    def sample_altitudes_m(self) -> tuple[float, float, float]:
        """Three altitudes that span the envelope: near its floor (5 % up the range), its middle and
        its ceiling (``aircraft.Aircraft.sample_altitudes_m``); the model's initial conditions fly them."""
        return tuple(altitude_like_m(h, self.altitude_range_m) for h in PAPER_SAMPLE_ALTITUDES_M)


@dataclass(frozen=True)
class Randomisation:
    """Where a training episode starts: altitude and EAS drawn uniformly in these ranges, inside
    the envelope (the paper's Section 3.4 for its aircraft)."""

    start_altitude_range_m: tuple[float, float] = (500.0, 20000.0)
    start_eas_range_mps: tuple[float, float] = (8.0, 12.0)


@dataclass(frozen=True)
class AircraftGeometry:
    """Everything the aerodynamic, mass and propulsion models are built from."""

    name: str = "solar_uav"  # the JSBSim aircraft name, also the name of its folder
    # What the aircraft is, for its JSBSim file header.
    description: str = ("Large solar-powered UAV: 35 m span, 359 kg, four electric propellers, conventional tail. "
                        "Reproduces the aircraft of Yan et al., Drones 2024, 8(9):428, Table 1.")
    envelope: FlightEnvelope = field(default_factory=FlightEnvelope)
    randomisation: Randomisation = field(default_factory=Randomisation)
    wing: WingGeometry = field(default_factory=WingGeometry)
    aileron: ControlSurfaceSpan = field(default_factory=ControlSurfaceSpan)
    # Tail volume 0.40, typical of sailplanes and HALE aircraft (0.35-0.5); symmetric section.
    horizontal_tail: TailSurface = field(
        default_factory=lambda: TailSurface(
            airfoil="naca0010",
            root_le_m=(9.0, 0.0, 0.25),
            tip_le_m=(9.15, 3.6, 0.25),
            root_chord_m=1.30,
            tip_chord_m=1.00,
            incidence_deg=-2.5,
            control_chord_fraction=0.35,
            efficiency=0.9,
        )
    )
    # Vertical-tail volume 0.016: low, as on long-span solar aircraft where roll damping dominates.
    vertical_tail: TailSurface = field(
        default_factory=lambda: TailSurface(
            airfoil="naca0010",
            root_le_m=(8.8, 0.0, 0.25),
            tip_le_m=(9.3, 0.0, 3.65),
            root_chord_m=1.80,
            tip_chord_m=1.10,
            incidence_deg=0.0,
            control_chord_fraction=0.35,
            efficiency=0.9,
        )
    )
    # Nacelle pod under the wing root and a tail boom; (x, radius) stations in metres.
    fuselage_stations_m: tuple[tuple[float, float], ...] = (
        (-2.0, 0.0),
        (-1.7, 0.22),
        (-0.8, 0.35),
        (1.2, 0.30),
        (2.6, 0.10),
        (10.6, 0.07),
    )
    reference_area_m2: float = 78.5  # the paper's Table 1
    reference_span_m: float = 35.0  # the paper's Table 1
    reference_chord_m: float = 2.27  # the paper's Table 1
    static_margin: float = 0.15  # the centre of gravity sits 15 % MAC ahead of the neutral point
    cg_z_m: float = 0.0  # in the wing plane, on the propeller thrust line (thrust gives no pitching moment)
    mass_kg: float = 359.0  # the paper's Table 1
    # The paper's Table 1, kg·m²; ixz is the product of inertia ∫xz dm (flight-dynamics sign convention).
    inertia_kg_m2: tuple[float, float, float, float] = (15221.0, 1827.5, 16967.0, 37.0)
    propeller: PropellerGeometry = field(default_factory=PropellerGeometry)
    # Four rotors on the wing leading edge, outboard pairs counter-rotating so torques cancel.
    rotors: tuple[Rotor, ...] = (
        Rotor(position_m=(-0.9, -9.5, 0.0), sense=-1),
        Rotor(position_m=(-0.9, -4.0, 0.0), sense=+1),
        Rotor(position_m=(-0.9, 4.0, 0.0), sense=-1),
        Rotor(position_m=(-0.9, 9.5, 0.0), sense=+1),
    )
    max_rotor_speed_rpm: float = 1800.0  # tip-speed limit: 207 m/s, helical tip Mach 0.72 at 20 km
    # Full throttle commands the rotor speed at which the motors deliver full power at this
    # equivalent airspeed and the present air density (see Systems/rotor_speed.xml).
    throttle_reference_eas_mps: float = 10.0
    rotor_inertia_kg_m2: float = 0.3  # propeller and motor rotor about the shaft (carbon blades, 1.5 kg)
    # Shaft power per motor: three times what cruise at 20 km and 12 m/s EAS needs (6.8 kW for the
    # four), which sets the climb margin there; full throttle is this power (Systems/rotor_speed.xml).
    motor_max_power_w: float = 5000.0
    esc_time_constant_s: float = 0.03  # closed speed loop of the motor controller
    rotor_time_constant_s: float = 0.2  # the paper's Section 2.3 (throttle lag)
    rotor_rate_limit_rpm_per_s: float = 480.0  # the paper's Section 2.3
    motor_efficiency: float = 0.85  # shaft power over electric power: the build report's electric power
    surface_time_constant_s: float = 0.02  # the paper's Section 2.3
    surface_rate_limit_deg_per_s: float = 100.0  # the paper's Section 2.3
    aileron_limit_deg: float = 30.0  # the paper's Section 2.3
    elevator_limit_deg: float = 30.0  # the paper's Section 2.3
    rudder_limit_deg: float = 20.0  # the paper's Section 2.3
    # Landing gear: a nose skid, two main wheels under the pod, a tail skid; wing tips and the fin
    # tip as STRUCTURE points that report a ground strike. Springs sized for 359 kg.
    contacts: tuple[ContactPoint, ...] = (
        ContactPoint("NOSE_SKID", "BOGEY", (-1.6, 0.0, -0.75), 0.5, 60000.0, 6000.0),
        ContactPoint("LEFT_MAIN", "BOGEY", (1.0, -0.4, -0.75), 0.5, 60000.0, 6000.0),
        ContactPoint("RIGHT_MAIN", "BOGEY", (1.0, 0.4, -0.75), 0.5, 60000.0, 6000.0),
        ContactPoint("TAIL_SKID", "STRUCTURE", (10.4, 0.0, -0.2), 0.8, 60000.0, 6000.0),
        ContactPoint("LEFT_TIP", "STRUCTURE", (0.8, -17.5, 0.77), 0.8, 60000.0, 6000.0),
        ContactPoint("RIGHT_TIP", "STRUCTURE", (0.8, 17.5, 0.77), 0.8, 60000.0, 6000.0),
    )

    # The description asked for the horizontal tail's incidence that trims the aircraft at its
    # reference EAS with the elevator at zero (``horizontal_tail.incidence_deg = "trim"``); the build
    # solves it (``aero_data.solve_tail_incidence``) and its data set records the result.
    solve_tail_incidence: bool = False

    @property
    def aspect_ratio(self) -> float:
        """b²/S (15.6 for the published numbers)."""
        return self.reference_span_m**2 / self.reference_area_m2

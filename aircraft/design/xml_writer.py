"""Write the JSBSim files of the solar UAV from its geometry and its aerodynamic data set.

Pure Python and numpy: the same geometry and ``aero_data.json`` always give the same bytes, which
is what lets a test check that the committed XML is what the generator writes.

Layout (JSBSim conventions; the folder is ``aircraft/<name>``, ``aircraft/solar_uav`` for the paper's)::

    <name>.xml               top file, one include per concern
    Metrics.xml MassBalance.xml GroundReactions.xml Propulsion.xml
    FlightControl.xml Aerodynamics.xml
    Engines/motor.xml Engines/propeller.xml
    Systems/scaling.xml      run-time scale of every coefficient term and of the inertia
    Systems/rotor_speed.xml  speed-commanded electric drive (ESC) of the rotors
    Systems/gust_rates.xml   rotational gust inputs (Dryden p, q, r) for the rate terms
    Systems/wing_leveler.xml roll hold for standalone runscripts (off unless ap/wing-leveler-active)
    reset*.xml               initial conditions
"""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from .. import ENVELOPE_FILE
from ..jsbsim_format import HEADER, INERTIA_SCALE, M_TO_FT, TERMS, fmt, reset_file
from .geometry import AircraftGeometry

# JSBSim takes LIFT, DRAG and SIDE in its wind axes and ROLL, PITCH, YAW in body axes.
AXIS_SYSTEM = {"LIFT": "wind axes", "DRAG": "wind axes", "SIDE": "wind axes",
               "ROLL": "body axes, about the CG", "PITCH": "body axes, about the CG", "YAW": "body axes, about the CG"}
# The factor every moment term carries: the inertia scale, and for roll and pitch the apparent
# inertia of the air when that option is on (scaling_system).
MOMENT_FACTOR = {"ROLL": "aero/scale/roll-moment-factor", "PITCH": "aero/scale/pitch-moment-factor",
                 "YAW": "aero/scale/moment-factor"}
APPARENT_MASS_SWITCH = "aero/apparent-mass-active"
AXIS_REFERENCE = {"LIFT": (), "DRAG": (), "SIDE": (), "ROLL": ("metrics/bw-ft",),
                  "PITCH": ("metrics/cbarw-ft",), "YAW": ("metrics/bw-ft",)}

# Properties the model reads, and the surface-position properties the flight control writes.
SURFACES = {  # name -> (command norm property, limit attribute, sides)
    "aileron": ("fcs/aileron-cmd-norm", "aileron_limit_deg", ("left", "right")),
    "elevator": ("fcs/elevator-cmd-norm", "elevator_limit_deg", ("left", "right")),
    "rudder": ("fcs/rudder-cmd-norm", "rudder_limit_deg", ("",)),
}


def _table_1d(prop: str, xs, ys, indent: str) -> str:
    rows = "\n".join(f"{indent}    {fmt(x):>10} {fmt(y):>12}" for x, y in zip(xs, ys))
    return (f"{indent}<table>\n{indent}  <independentVar lookup=\"row\">{prop}</independentVar>\n"
            f"{indent}  <tableData>\n{rows}\n{indent}  </tableData>\n{indent}</table>")


def _table_2d(row_prop: str, col_prop: str, rows, cols, values, indent: str) -> str:
    values = np.asarray(values)
    head = f"{indent}    {'':>10} " + " ".join(f"{fmt(c):>12}" for c in cols)
    body = "\n".join(f"{indent}    {fmt(r):>10} " + " ".join(f"{fmt(v):>12}" for v in values[i])
                     for i, r in enumerate(rows))
    return (f"{indent}<table>\n{indent}  <independentVar lookup=\"row\">{row_prop}</independentVar>\n"
            f"{indent}  <independentVar lookup=\"column\">{col_prop}</independentVar>\n"
            f"{indent}  <tableData>\n{head}\n{body}\n{indent}  </tableData>\n{indent}</table>")


def _location(tag_name: str, xyz_m, name: str | None = None, indent: str = "    ") -> str:
    attr = f' name="{name}"' if name else ""
    x, y, z = xyz_m
    return (f'{indent}<{tag_name}{attr} unit="M">\n{indent}  <x> {fmt(x)} </x>\n{indent}  <y> {fmt(y)} </y>\n'
            f'{indent}  <z> {fmt(z)} </z>\n{indent}</{tag_name}>')


def top_file(g: AircraftGeometry) -> str:
    return HEADER + f"""<fdm_config name="{g.name}" version="2.0" release="ANALYTICAL">
  <fileheader>
    <author>solar-uav-rl</author>
    <description>{escape(g.description)}
      Aerodynamics from the documented geometry in aircraft/design (AeroSandbox vortex lattice,
      AeroBuildup with NeuralFoil, strip theory for the control surfaces).</description>
    <note>Rigid-body model: the paper's elastic-deformation terms are left out.</note>
    <note>Status ANALYTICAL: every coefficient comes from analysis of the documented geometry and
      mass; none is fitted to flight or wind-tunnel data.</note>
  </fileheader>
  <metrics file="Metrics.xml"/>
  <mass_balance file="MassBalance.xml"/>
  <ground_reactions file="GroundReactions.xml"/>
  <propulsion file="Propulsion.xml"/>
  <system file="scaling"/>
  <system file="rotor_speed"/>
  <system file="gust_rates"/>
  <system file="wing_leveler"/>
  <flight_control file="FlightControl.xml"/>
  <aerodynamics file="Aerodynamics.xml"/>
</fdm_config>
"""


def metrics(g: AircraftGeometry, data: dict) -> str:
    from .analysis import _mac_quarter_chord, _trapezoid_area_m2

    cg = (data["stability"]["cg_x_m"], 0.0, g.cg_z_m)
    ht_arm = _mac_quarter_chord(g.horizontal_tail)[0] - cg[0]
    vt_arm = _mac_quarter_chord(g.vertical_tail)[0] - cg[0]
    return HEADER + f"""<metrics>
  <wingarea unit="M2"> {fmt(g.reference_area_m2)} </wingarea>
  <wingspan unit="M"> {fmt(g.reference_span_m)} </wingspan>
  <chord unit="M"> {fmt(g.reference_chord_m)} </chord>
  <htailarea unit="M2"> {fmt(2 * _trapezoid_area_m2(g.horizontal_tail))} </htailarea>
  <htailarm unit="M"> {fmt(ht_arm)} </htailarm>
  <vtailarea unit="M2"> {fmt(_trapezoid_area_m2(g.vertical_tail))} </vtailarea>
  <vtailarm unit="M"> {fmt(vt_arm)} </vtailarm>
  <!-- Aerodynamic moments are tabulated about the CG, so the reference point is the CG. -->
{_location("location", cg, "AERORP", "  ")}
{_location("location", (-1.5, 0.0, 0.3), "EYEPOINT", "  ")}
{_location("location", (0.0, 0.0, 0.0), "VRP", "  ")}
</metrics>
"""


def mass_balance(g: AircraftGeometry, data: dict) -> str:
    ixx, iyy, izz, ixz = g.inertia_kg_m2
    cg = (data["stability"]["cg_x_m"], 0.0, g.cg_z_m)
    return HEADER + f"""<!-- Mass and inertia: the paper's Table 1. The CG sits {fmt(100 * g.static_margin)} % MAC ahead of the neutral point
     (x = {fmt(data["stability"]["neutral_point_x_m"])} m). ixz is the product of inertia Ixz = integral of x z dm in body
     axes ({fmt(ixz)} kg m2). With negated_crossproduct_inertia="false" JSBSim holds -ixz in its inertia
     tensor, so get_J()[0,2], inertia/ixz-slugs_ft2 and the mass-properties report read {fmt(-ixz)};
     jsbsim_env.sim.Simulation.inertia_kg_m2() returns +Ixz. -->
<mass_balance negated_crossproduct_inertia="false">
  <ixx unit="KG*M2"> {fmt(ixx)} </ixx>
  <iyy unit="KG*M2"> {fmt(iyy)} </iyy>
  <izz unit="KG*M2"> {fmt(izz)} </izz>
  <ixy unit="KG*M2"> 0 </ixy>
  <ixz unit="KG*M2"> {fmt(ixz)} </ixz>
  <iyz unit="KG*M2"> 0 </iyz>
  <emptywt unit="KG"> {fmt(g.mass_kg)} </emptywt>
{_location("location", cg, "CG", "  ")}
</mass_balance>
"""


def ground_reactions(g: AircraftGeometry) -> str:
    parts = []
    for c in g.contacts:
        parts.append(f"""  <contact type="{c.kind}" name="{c.name}">
{_location("location", c.position_m, None, "    ")}
    <static_friction> {fmt(c.static_friction)} </static_friction>
    <dynamic_friction> {fmt(0.8 * c.static_friction)} </dynamic_friction>
    <rolling_friction> 0.05 </rolling_friction>
    <spring_coeff unit="N/M"> {fmt(c.spring_n_per_m)} </spring_coeff>
    <damping_coeff unit="N/M/SEC"> {fmt(c.damping_n_s_per_m)} </damping_coeff>
    <max_steer unit="DEG"> 0 </max_steer>
    <brake_group> NONE </brake_group>
    <retractable> 0 </retractable>
  </contact>""")
    return HEADER + "<!-- Skids and wheels, and STRUCTURE points at the wing tips and tail that report a ground strike. -->\n" \
        "<ground_reactions>\n" + "\n".join(parts) + "\n</ground_reactions>\n"


def propulsion(g: AircraftGeometry) -> str:
    parts = []
    for r in g.rotors:
        parts.append(f"""  <engine file="motor">
    <thruster file="propeller">
      <sense> {r.sense} </sense>
{_location("location", r.position_m, None, "      ")}
      <orient unit="DEG"> <roll> 0 </roll> <pitch> 0 </pitch> <yaw> 0 </yaw> </orient>
    </thruster>
  </engine>""")
    return HEADER + "<!-- Four electric motors with fixed-pitch propellers; outboard and inboard pairs counter-rotate. -->\n" \
        "<propulsion>\n" + "\n".join(parts) + "\n</propulsion>\n"


def motor(g: AircraftGeometry) -> str:
    return HEADER + f"""<!-- Brushless motor: JSBSim's electric engine delivers throttle-pos x max power to the propeller
     shaft. The throttle position is written by the speed controller in Systems/rotor_speed.xml. -->
<electric_engine name="motor">
  <power unit="WATTS"> {fmt(g.motor_max_power_w)} </power>
</electric_engine>
"""


def propeller(g: AircraftGeometry, data: dict) -> str:
    p = g.propeller
    prop = data["propeller"]
    ct = "\n".join(f"      {fmt(j):>8} {fmt(c):>12}" for j, c in zip(prop["J"], prop["CT"]))
    cp = "\n".join(f"      {fmt(j):>8} {fmt(c):>12}" for j, c in zip(prop["J"], prop["CP"]))
    return HEADER + f"""<!-- Fixed-pitch propeller, {p.blade_count} blades, D = {fmt(p.diameter_m)} m, P/D = {fmt(p.pitch_to_diameter)}.
     C_THRUST and C_POWER against advance ratio J = V/(n D) from blade-element momentum theory
     (aircraft/design/propeller.py) with NeuralFoil section polars of the {p.airfoil} airfoil at
     Re {fmt(p.section_reynolds)}. JSBSim applies them at the local air density, so thrust at a
     fixed equivalent airspeed falls with altitude. -->
<propeller name="propeller">
  <ixx unit="KG*M2"> {fmt(g.rotor_inertia_kg_m2)} </ixx>
  <diameter unit="M"> {fmt(p.diameter_m)} </diameter>
  <numblades> {p.blade_count} </numblades>
  <table name="C_THRUST" type="internal">
    <tableData>
{ct}
    </tableData>
  </table>
  <table name="C_POWER" type="internal">
    <tableData>
{cp}
    </tableData>
  </table>
</propeller>
"""


SLUG_FT2_PER_KG_M2 = 1.0 / 1.3558179483314
FT5_PER_M5 = M_TO_FT**5
SLUG_FT3_PER_KG_M3 = 1.0 / 515.378818


def scaling_system(g: AircraftGeometry, data: dict) -> str:
    props = "\n".join(f'  <property value="1" persistent="true">aero/scale/{n}</property>'
                      for n in list(TERMS) + [INERTIA_SCALE])
    ixx, iyy = g.inertia_kg_m2[0], g.inertia_kg_m2[1]
    apparent = data["apparent_mass_per_density"]

    def factor(name: str, apparent_m5: float, inertia_kg_m2: float, axis: str) -> str:
        # JSBSim's density is in slug/ft3: the apparent inertia over the nominal one is rho * this.
        per_density = apparent_m5 * FT5_PER_M5 / (inertia_kg_m2 * SLUG_FT2_PER_KG_M2)
        return f"""    <fcs_function name="aero/scale/{name}">
      <description>1 / (inertia scale + apparent {axis} inertia / nominal): strip theory gives the air
        around the surfaces {fmt(apparent_m5 * 1.225 / inertia_kg_m2)} of the nominal {axis} inertia at sea level,
        {fmt(apparent_m5 * 0.088035 / inertia_kg_m2)} at 20 km.</description>
      <function>
        <quotient>
          <value> 1 </value>
          <sum>
            <property> aero/scale/{INERTIA_SCALE} </property>
            <product> <property> {APPARENT_MASS_SWITCH} </property> <property> atmosphere/rho-slugs_ft3 </property> <value> {fmt(per_density)} </value> </product>
          </sum>
        </quotient>
      </function>
    </fcs_function>"""

    return HEADER + f"""<!-- Run-time scales: every aerodynamic term is multiplied by aero/scale/<term>, and
     aero/scale/{INERTIA_SCALE} scales the whole inertia tensor. They persist across resets, so a row of the
     randomisation table is a set of property writes before an episode.

     A uniform inertia scale s is applied as the exactly equivalent scale 1/s of the aerodynamic
     moments: J = s J0 turns J w' = M - w x (J w) into J0 w' = M/s - w x (J0 w). The propeller
     torques and gyroscopic moments, which cancel pairwise between counter-rotating rotors, are not
     scaled.

     Apparent mass (off unless {APPARENT_MASS_SWITCH} is 1): the air the wing and tail accelerate
     adds to the roll and pitch inertia, in proportion to the density. Added to Ixx and Iyy alone,
     it is applied the same way, as 1/(s + I_apparent/I) on the aerodynamic rolling and pitching
     moments. That is exact for each axis on its own and leaves out its share of the product of
     inertia (Ixz/Ixx = 0.2 %) and of the gyroscopic terms. The apparent mass in heave (0.48 of
     the aircraft's mass at sea level) is not modelled: it would be an alpha-dot lift term (about
     3.1 per alpha-dot c/2V at every density), and JSBSim's alpha-dot comes from the accelerations
     of the step before, so a third of each step's vertical acceleration would return one step
     late at sea level. -->
<system name="scaling">
{props}
  <property value="0" persistent="true">{APPARENT_MASS_SWITCH}</property>
  <channel name="inertia">
    <fcs_function name="aero/scale/moment-factor">
      <function>
        <quotient> <value> 1 </value> <property> aero/scale/{INERTIA_SCALE} </property> </quotient>
      </function>
    </fcs_function>
{factor("roll-moment-factor", apparent["roll_m5"], ixx, "roll")}
{factor("pitch-moment-factor", apparent["pitch_m5"], iyy, "pitch")}
  </channel>
</system>
"""


# Wing leveler gains: aileron command (normalised) per degree of bank error and per rad/s of roll
# rate. A positive aileron rolls left here, so both gains are positive. With the roll rate of about
# -0.25 rad/s per unit command the bank error closes with a time constant near 2.5 s, far faster
# than the spiral divergence (doubling in 6-33 s across the envelope).
WING_LEVELER_GAIN_PER_DEG = 0.03
WING_LEVELER_DAMPING_S_PER_RAD = 0.5


def gust_rates_system() -> str:
    return HEADER + """<!-- Rotational gusts (turbulence angular rates, rad/s, body axes) for the aerodynamic rate
     terms: the rates the air sees are the body rates minus these, as in JSBSim's own turbulence
     (whose p/q/r-turb properties cannot be written), over the share of the aircraft each acts on
     (Aerodynamics.xml). Zero unless a turbulence model writes them;
     the translational gusts go to JSBSim's atmosphere/gust-*-fps. -->
<system name="gust-rates">
  <property value="0">atmosphere/gust-p-rad_sec</property>
  <property value="0">atmosphere/gust-q-rad_sec</property>
  <property value="0">atmosphere/gust-r-rad_sec</property>
</system>
"""


def wing_leveler_system() -> str:
    return HEADER + f"""<!-- Roll-attitude hold for standalone JSBSim runs (the spiral mode is slowly divergent, so
     a minutes-long runscript needs wings held level). Off by default; the environment and the
     controllers never turn it on. Output ap/aileron-cmd-norm is added to the aileron command. -->
<system name="wing-leveler">
  <property value="0">ap/wing-leveler-active</property>
  <property value="0">ap/roll-cmd-deg</property>
  <channel name="wing leveler">
    <fcs_function name="ap/aileron-cmd-norm">
      <function>
        <product>
          <property> ap/wing-leveler-active </property>
          <sum>
            <product> <value> {fmt(WING_LEVELER_GAIN_PER_DEG)} </value> <difference> <property> attitude/phi-deg </property> <property> ap/roll-cmd-deg </property> </difference> </product>
            <product> <value> {fmt(WING_LEVELER_DAMPING_S_PER_RAD)} </value> <property> velocities/p-rad_sec </property> </product>
          </sum>
        </product>
      </function>
      <clipto> <min> -0.5 </min> <max> 0.5 </max> </clipto>
    </fcs_function>
  </channel>
</system>
"""


# Density breakpoints (kg/m³) of the full-throttle rotor speed: from above 22 km to below sea level.
THROTTLE_DENSITY_KG_M3 = (0.05, 0.06, 0.07, 0.08, 0.09, 0.1, 0.12, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.65, 0.8,
                          1.0, 1.15, 1.3)


def full_throttle_speed_rpm(g: AircraftGeometry, data: dict) -> np.ndarray:
    """Rotor speed of full throttle at each of ``THROTTLE_DENSITY_KG_M3``: where the motors deliver
    full power at the reference equivalent airspeed, capped at the tip-speed limit."""
    from .propeller import full_power_speed_rpm

    prop = data["propeller"]
    speeds = [full_power_speed_rpm(np.asarray(prop["J"]), np.asarray(prop["CP"]), g.propeller.diameter_m,
                                   g.motor_max_power_w, rho, g.throttle_reference_eas_mps * np.sqrt(1.225 / rho))
              for rho in THROTTLE_DENSITY_KG_M3]
    return np.minimum(speeds, g.max_rotor_speed_rpm)


def rotor_speed_system(g: AircraftGeometry, data: dict) -> str:
    rpm_to_rad = 2.0 * np.pi / 60.0
    ixx_slug_ft2 = g.rotor_inertia_kg_m2 * M_TO_FT**2 / 14.5939
    # Power (ft lbf/s) to add per rpm of speed error, per rad/s of rotor speed, for a closed-loop
    # time constant tau: I w dw/dt = dP  =>  dP = I w (rpm_to_rad e) / tau.
    gain = ixx_slug_ft2 * rpm_to_rad / g.esc_time_constant_s
    # Below 1 rad/s JSBSim's propeller turns power into torque as if at 1 rad/s; holding the gain
    # there keeps the loop's time constant when the drive spins up from rest.
    min_gain_rpm = 60.0 / (2.0 * np.pi)
    max_power_ftlbs = g.motor_max_power_w / 1.35582
    escs = []
    for i in range(len(g.rotors)):
        escs.append(f"""    <fcs_function name="fcs/esc-{i}-power-norm">
      <function>
        <quotient>
          <sum>
            <property> propulsion/engine[{i}]/propeller-power-ftlbps </property>
            <product>
              <value> {fmt(gain * rpm_to_rad)} </value>
              <max>
                <property> propulsion/engine[{i}]/propeller-rpm </property>
                <value> {fmt(min_gain_rpm)} </value>
              </max>
              <difference>
                <property> fcs/rotor-speed-ref-rpm </property>
                <property> propulsion/engine[{i}]/propeller-rpm </property>
              </difference>
            </product>
          </sum>
          <value> {fmt(max_power_ftlbs)} </value>
        </quotient>
      </function>
      <clipto> <min> 0 </min> <max> 1 </max> </clipto>
      <output> fcs/throttle-pos-norm[{i}] </output>
    </fcs_function>""")
    full = _table_1d("atmosphere/rho-slugs_ft3", [rho * SLUG_FT3_PER_KG_M3 for rho in THROTTLE_DENSITY_KG_M3],
                     full_throttle_speed_rpm(g, data), "        ")
    return HEADER + f"""<!-- Speed-commanded electric drive. The throttle command sets a rotor-speed reference,
     throttle x the full-throttle speed, that follows a first-order lag of {fmt(g.rotor_time_constant_s)} s with a
     {fmt(g.rotor_rate_limit_rpm_per_s)} rpm/s rate limit (the paper's Section 2 and Table 1). Each motor's speed controller (ESC) delivers the
     propeller's absorbed power plus a correction proportional to the speed error, closing the
     rotor-speed loop with a {fmt(g.esc_time_constant_s)} s time constant, up to the motor's
     {fmt(g.motor_max_power_w)} W. All rotors share the one command.

     The full-throttle speed is where the propellers absorb the motors' full power at EAS
     {fmt(g.throttle_reference_eas_mps)} m/s and the present air density (blade-element tables), capped at
     {fmt(g.max_rotor_speed_rpm)} rpm: a fixed maximum would leave most of the throttle range without effect near
     sea level, where full power is reached at less than half the speed it takes at 20 km. -->
<system name="rotor_speed">
  <!-- The reference's lag (1/s) and rate limit (rpm/s) are properties only so that a simulation
       can be initialised quickly (jsbsim_env.sim.Simulation.settle_actuators); flight uses these values. -->
  <property value="{fmt(1.0 / g.rotor_time_constant_s)}">fcs/rotor-lag-per-s</property>
  <property value="{fmt(g.rotor_rate_limit_rpm_per_s)}">fcs/rotor-rate-limit-rpm_s</property>
  <channel name="rotor speed reference">
    <fcs_function name="fcs/rotor-speed-full-rpm">
      <function>
{full}
      </function>
    </fcs_function>
    <fcs_function name="fcs/rotor-speed-cmd-rpm">
      <function>
        <product> <property> fcs/throttle-cmd-norm[0] </property> <property> fcs/rotor-speed-full-rpm </property> </product>
      </function>
      <clipto> <min> 0 </min> <max> {fmt(g.max_rotor_speed_rpm)} </max> </clipto>
    </fcs_function>
    <actuator name="fcs/rotor-speed-ref-rpm">
      <input> fcs/rotor-speed-cmd-rpm </input>
      <lag> fcs/rotor-lag-per-s </lag>
      <rate_limit> fcs/rotor-rate-limit-rpm_s </rate_limit>
      <clipto> <min> 0 </min> <max> {fmt(g.max_rotor_speed_rpm)} </max> </clipto>
    </actuator>
    <!-- The throttle position the controllers observe: the reference over the full-throttle speed. -->
    <fcs_function name="fcs/throttle-ref-norm">
      <function>
        <quotient> <property> fcs/rotor-speed-ref-rpm </property> <property> fcs/rotor-speed-full-rpm </property> </quotient>
      </function>
    </fcs_function>
  </channel>
  <channel name="speed controllers">
{chr(10).join(escs)}
  </channel>
</system>
"""


def flight_control(g: AircraftGeometry) -> str:
    channels = []
    lag = fmt(1.0 / g.surface_time_constant_s)
    rate = fmt(g.surface_rate_limit_deg_per_s)
    for surface, (cmd, limit_attr, sides) in SURFACES.items():
        limit = getattr(g, limit_attr)
        trim = {"aileron": "fcs/roll-trim-cmd-norm", "elevator": "fcs/pitch-trim-cmd-norm",
                "rudder": "fcs/yaw-trim-cmd-norm"}[surface]
        autopilot = "\n      <input> ap/aileron-cmd-norm </input>" if surface == "aileron" else ""
        parts = [f"""    <summer name="fcs/{surface}-cmd-sum-norm">
      <input> {cmd} </input>
      <input> {trim} </input>{autopilot}
      <clipto> <min> -1 </min> <max> 1 </max> </clipto>
    </summer>
    <pure_gain name="fcs/{surface}-cmd-deg">
      <input> fcs/{surface}-cmd-sum-norm </input>
      <gain> {fmt(limit)} </gain>
    </pure_gain>"""]
        for side in sides:
            name = f"{side}-{surface}" if side else surface
            parts.append(f"""    <!-- Backlash (play) ahead of the servo: the output follows the input only once the input has
         crossed half the play width; width fcs/backlash-width-deg, settable at run time. -->
    <fcs_function name="fcs/{name}-backlash-deg">
      <function>
        <max>
          <difference> <property> fcs/{surface}-cmd-deg </property> <product> <value> 0.5 </value> <property> fcs/backlash-width-deg </property> </product> </difference>
          <min>
            <property> fcs/{name}-backlash-deg </property>
            <sum> <property> fcs/{surface}-cmd-deg </property> <product> <value> 0.5 </value> <property> fcs/backlash-width-deg </property> </product> </sum>
          </min>
        </max>
      </function>
    </fcs_function>
    <actuator name="fcs/{name}-pos-deg">
      <input> fcs/{name}-backlash-deg </input>
      <lag> {lag} </lag>
      <rate_limit> fcs/surface-rate-limit-deg_s </rate_limit>
      <clipto> <min> {fmt(-limit)} </min> <max> {fmt(limit)} </max> </clipto>
    </actuator>""")
        channels.append(f'  <channel name="{surface}">\n' + "\n".join(parts) + "\n  </channel>")
    readouts = """  <channel name="read-outs">
    <!-- Mean deflections in the sign conventions of the controller interface, and the left
         aileron as a downward deflection for the aerodynamic tables. -->
    <fcs_function name="fcs/aileron-pos-deg">
      <function> <product> <value> 0.5 </value> <sum> <property> fcs/left-aileron-pos-deg </property> <property> fcs/right-aileron-pos-deg </property> </sum> </product> </function>
    </fcs_function>
    <fcs_function name="fcs/elevator-pos-deg">
      <function> <product> <value> 0.5 </value> <sum> <property> fcs/left-elevator-pos-deg </property> <property> fcs/right-elevator-pos-deg </property> </sum> </product> </function>
    </fcs_function>
    <pure_gain name="fcs/left-aileron-down-deg">
      <input> fcs/left-aileron-pos-deg </input>
      <gain> -1 </gain>
    </pure_gain>
  </channel>"""
    return HEADER + f"""<!-- Control surfaces (the paper's Section 2 and Table 1): command (normalised, JSBSim trim inputs added) -> degrees
     -> backlash -> servo (first-order lag T = {fmt(g.surface_time_constant_s)} s, rate limit {rate} deg/s, travel limits).
     Signs: elevator trailing edge down positive; rudder trailing edge left positive; aileron
     command positive puts the right aileron down and the left aileron up (each side's position
     is positive in its own sense: right down, left up). -->
<flight_control name="{g.name}">
  <property value="0" persistent="true">fcs/backlash-width-deg</property>
  <!-- Every servo's rate limit, settable at run time (robustness sweeps). -->
  <property value="{rate}">fcs/surface-rate-limit-deg_s</property>
{chr(10).join(channels)}
{readouts}
</flight_control>
"""


# Which model property drives each control term, per side.
_DEFLECTION_PROPS = {
    "aileron": ("fcs/right-aileron-pos-deg", "fcs/left-aileron-down-deg"),
    "elevator": ("fcs/right-elevator-pos-deg", "fcs/left-elevator-pos-deg"),
    "rudder": ("fcs/rudder-pos-deg",),
}
# Sign of each side's contribution: the left aileron is the mirror image of the right one.
_MIRROR_SIGN = {"CL": 1, "CD": 1, "Cm": 1, "CY": -1, "Cl": -1, "Cn": -1}


def _deflection_sum(surface: str, key: str, data: dict, indent: str) -> str:
    """Sum over a surface's sides of the table ``data["controls"][key]`` against each side's
    deflection; ``key`` is ``<coef>_<surface>``. The aileron's yawing moment also carries the
    induced part, times the clean aircraft's lift coefficient."""
    grids, ctl = data["grids"], data["controls"]
    coef = key.split("_")[0]
    pieces = []
    for k, prop in enumerate(_DEFLECTION_PROPS[surface]):
        sign = _MIRROR_SIGN[coef] if (surface == "aileron" and k == 1) else 1
        table = _table_2d(prop, "aero/Re", grids["deflection_deg"], grids["reynolds"], ctl[key], indent + "    ")
        if sign < 0:
            pieces.append(f"{indent}  <product>\n{indent}    <value> -1 </value>\n{table}\n{indent}  </product>")
        else:
            pieces.append(table)
        if key == "Cn_aileron":
            induced = _table_2d(prop, "aero/Re", grids["deflection_deg"], grids["reynolds"],
                                ctl["Cn_aileron_induced"], indent + "      ")
            pieces.append(f"{indent}  <product>\n{indent}    <value> {sign} </value>\n"
                          f"{indent}    <property> aero/function/CL-static </property>\n{induced}\n{indent}  </product>")
    if len(pieces) == 1:
        return pieces[0]
    return f"{indent}<sum>\n" + "\n".join(pieces) + f"\n{indent}</sum>"


# The aileron's moments from stability to body axes: term -> (its own stability-axis moment, the
# other one, the sign of the other's sin(alpha) share); the own one enters with cos(alpha).
_AILERON_BODY_AXES = {
    "Clda": ("aero/function/aileron-Cl-stability", "aero/function/aileron-Cn-stability", -1),
    "Cnda": ("aero/function/aileron-Cn-stability", "aero/function/aileron-Cl-stability", 1),
}
_VLM_TERMS = ("CYbeta", "Clbeta", "Cnbeta", "CYp", "Clp", "Cnp", "CLq", "Cmq", "CYq", "Cnq", "CYr", "Clr", "Cnr")


def _rate_term(rate_var: str, alpha_deg, values, profile, reynolds, indent: str) -> str:
    """``rate_var`` times a table against alpha, plus ``profile`` against Re where given."""
    if profile is not None:  # the viscous part the lattice cannot see
        table = (f"{indent}  <sum>\n{_table_1d('aero/alpha-deg', alpha_deg, values, indent + '    ')}\n"
                 f"{_table_1d('aero/Re', reynolds, profile, indent + '    ')}\n{indent}  </sum>")
    else:
        table = _table_1d("aero/alpha-deg", alpha_deg, values, indent + "  ")
    return f"{indent}<product>\n{indent}  <property> {rate_var} </property>\n{table}\n{indent}</product>"


def _term_body(name: str, data: dict, indent: str) -> str:
    """The coefficient expression (without qbar S and scales) of one term."""
    grids = data["grids"]
    alpha, re = grids["alpha_deg"], grids["reynolds"]
    polar, vlm, side, ctl = data["polar"], data["vlm"], data["sideslip"], data["controls"]
    i0 = alpha.index(0)
    coef = name[:2]  # CL, CD, CY, Cl, Cm or Cn
    if name in ("CL0", "CD0", "Cm0"):
        return _table_1d("aero/Re", re, polar[coef][i0], indent)
    if name in ("CLalpha", "CDalpha", "Cmalpha"):
        values = np.asarray(polar[coef]) - np.asarray(polar[coef][i0])[None, :]
        return _table_2d("aero/alpha-deg", "aero/Re", alpha, re, values, indent)
    if name in ("CLbeta", "CDbeta", "Cmbeta"):
        beta = grids["beta_deg"]
        inc = side[f"{coef}beta"]
        xs = [-b for b in beta[:0:-1]] + list(beta)
        ys = list(inc[:0:-1]) + list(inc)
        return _table_1d("aero/beta-deg", xs, ys, indent)
    if name in ("CLadot", "Cmadot"):
        # The wing's angle of attack against the air changes with the body's motion (JSBSim's
        # alpha-dot, from the accelerations) and with a vertical gust: d/dt (-w_g/V) is the pitch
        # gust q_g the turbulence writes.
        return (f"{indent}<product>\n"
                f"{indent}  <sum> <property> aero/alphadot-rad_sec </property> "
                f"<property> atmosphere/gust-q-rad_sec </property> </sum>\n"
                f"{indent}  <property> aero/ci2vel </property>\n"
                f"{indent}  <value> {fmt(data['downwash_lag'][name])} </value>\n{indent}</product>")
    if name in _VLM_TERMS:
        key = name.replace("beta", "b")
        rate_var = {"b": "aero/function/beta-effective-rad", "p": "aero/function/p-hat",
                    "q": "aero/function/q-hat", "r": "aero/function/r-hat"}[key[-1]]
        profile = data["profile"].get(name)
        if key[-1] not in "pr":
            return _rate_term(rate_var, grids["vlm_alpha_deg"], vlm[key], profile, re, indent)
        # The roll gust (a spanwise gradient of w) acts on the wing's share, the yaw gust (v varying
        # along x) on the tails' share; the body rates act on the whole.
        tails = np.asarray(vlm[f"{key}_tails"])
        gust_share = np.asarray(vlm[key]) - tails if key[-1] == "p" else tails
        whole = _rate_term(rate_var, grids["vlm_alpha_deg"], vlm[key], profile, re, indent + "  ")
        gust = _rate_term(f"aero/function/{key[-1]}-gust-hat", grids["vlm_alpha_deg"], gust_share, None, re,
                          indent + "  ")
        return f"{indent}<difference>\n{whole}\n{gust}\n{indent}</difference>"
    if name in _AILERON_BODY_AXES:
        own, other, sign = _AILERON_BODY_AXES[name]
        return (f"{indent}<sum>\n"
                f"{indent}  <product> <cos> <property> aero/alpha-rad </property> </cos> <property> {own} </property> </product>\n"
                f"{indent}  <product> <value> {sign} </value> <sin> <property> aero/alpha-rad </property> </sin> "
                f"<property> {other} </property> </product>\n{indent}</sum>")
    surface = {"a": "aileron", "e": "elevator", "r": "rudder"}[name[-1]]
    key = f"{coef}_{surface}"
    if key not in ctl:  # no mechanism gives this force for this surface (documented in TERMS)
        return f"{indent}<value> 0 </value>"
    return _deflection_sum(surface, key, data, indent)


def aerodynamics(g: AircraftGeometry, data: dict) -> str:
    grids, polar = data["grids"], data["polar"]
    pre = f"""  <!-- Helper functions evaluated before the axes. -->
  <function name="aero/function/beta-effective-rad">
    <description>Sideslip for the linear sideslip terms: beta for small angles, bounded and back to
      zero broadside, like the side force of a flat plate (0.5 sin 2 beta).</description>
    <product> <value> 0.5 </value> <sin> <product> <value> 2 </value> <property> aero/beta-rad </property> </product> </sin> </product>
  </function>
  <!-- Non-dimensional rates. A rotational gust is a rate of the air: the aircraft sees its body
       rate minus it. The pitch gust (w varying along x) acts on the whole aircraft like a pitch
       rate; the roll gust only on the wing's share and the yaw gust only on the tails' share of
       their derivatives, so those two are separate. -->
  <function name="aero/function/p-hat">
    <product> <property> velocities/p-aero-rad_sec </property> <property> aero/bi2vel </property> </product>
  </function>
  <function name="aero/function/p-gust-hat">
    <product> <property> atmosphere/gust-p-rad_sec </property> <property> aero/bi2vel </property> </product>
  </function>
  <function name="aero/function/q-hat">
    <product> <difference> <property> velocities/q-aero-rad_sec </property> <property> atmosphere/gust-q-rad_sec </property> </difference> <property> aero/ci2vel </property> </product>
  </function>
  <function name="aero/function/r-hat">
    <product> <property> velocities/r-aero-rad_sec </property> <property> aero/bi2vel </property> </product>
  </function>
  <function name="aero/function/r-gust-hat">
    <product> <property> atmosphere/gust-r-rad_sec </property> <property> aero/bi2vel </property> </product>
  </function>
  <function name="aero/function/CL-static">
    <description>Lift coefficient of the clean aircraft, for the induced adverse yaw of the ailerons.</description>
{_table_2d("aero/alpha-deg", "aero/Re", grids["alpha_deg"], grids["reynolds"], polar["CL"], "    ")}
  </function>
  <function name="aero/function/aileron-Cl-stability">
    <description>Rolling moment of both ailerons in stability axes (strip theory: their lift acts across
      the airflow); Clda rotates it to body axes.</description>
{_deflection_sum("aileron", "Cl_aileron", data, "    ")}
  </function>
  <function name="aero/function/aileron-Cn-stability">
    <description>Yawing moment of both ailerons in stability axes: profile-drag asymmetry (drag acts
      along the airflow) and induced yaw; Cnda rotates it to body axes.</description>
{_deflection_sum("aileron", "Cn_aileron", data, "    ")}
  </function>"""
    axes = []
    for axis in ("DRAG", "SIDE", "LIFT", "ROLL", "PITCH", "YAW"):
        funcs = []
        for name, (ax, note) in TERMS.items():
            if ax != axis:
                continue
            refs = "".join(f"\n        <property> {r} </property>" for r in AXIS_REFERENCE[axis])
            moment = f"\n        <property> {MOMENT_FACTOR[axis]} </property>" if axis in MOMENT_FACTOR else ""
            funcs.append(f"""    <function name="aero/coefficient/{name}">
      <description>{name} ({AXIS_SYSTEM[axis]}): {note}</description>
      <product>
        <property> aero/qbar-psf </property>
        <property> metrics/Sw-sqft </property>{refs}
        <property> aero/scale/{name} </property>{moment}
{_term_body(name, data, "        ")}
      </product>
    </function>""")
        axes.append(f'  <axis name="{axis}">\n' + "\n".join(funcs) + "\n  </axis>")
    st = data["stability"]
    return HEADER + f"""<!-- Coefficient build-up after Beard and McLain: each term a function of its own, tabulated
     against angle of attack and Reynolds number where it varies, times aero/scale/<term>.
     CG x = {fmt(st["cg_x_m"])} m, neutral point x = {fmt(st["neutral_point_x_m"])} m (static margin {fmt(st["static_margin"])} MAC).
     Deflections in degrees, rates non-dimensional (p b/2V, q c/2V, r b/2V, alpha-dot c/2V), angles per
     radian. Axes: LIFT, DRAG and SIDE in JSBSim's wind axes; ROLL, PITCH and YAW in body axes about the
     CG (the aerodynamic reference point is the CG); each term's description names its axes. -->
<aerodynamics>
{pre}
{chr(10).join(axes)}
</aerodynamics>
"""


def reset_points(g: AircraftGeometry) -> tuple[tuple[float, float], ...]:
    """Where the initial conditions shipped with the model start: altitude (m) and true airspeed
    (m/s, to 0.1) at the envelope's reference EAS, at its sample altitudes (near its floor, its
    middle, its ceiling). For the paper's aircraft: 1, 10 and 20 km at 10.5, 17.2 and 37.1 m/s
    (10 m/s EAS)."""
    eas = g.envelope.reference_eas_mps
    return tuple((h, round(eas * (_SEA_LEVEL_DENSITY_KG_M3 / isa_density_kg_m3(h)) ** 0.5, 1))
                 for h in g.envelope.sample_altitudes_m)


_SEA_LEVEL_DENSITY_KG_M3 = 1.225


def isa_density_kg_m3(altitude_m: float) -> float:
    """Air density of the 1976 standard atmosphere at a geometric altitude (its troposphere and
    isothermal layer, to 20 km geopotential)."""
    t0, p0, lapse, r, g0, earth_radius_m = 288.15, 101325.0, 0.0065, 287.053, 9.80665, 6356766.0
    geopotential_m = earth_radius_m * altitude_m / (earth_radius_m + altitude_m)
    h = min(geopotential_m, 11000.0)
    t = t0 - lapse * h
    p = p0 * (t / t0) ** (g0 / (r * lapse))
    if geopotential_m > 11000.0:
        p *= np.exp(-g0 * (geopotential_m - 11000.0) / (r * t))
    return float(p / (r * t))


def envelope_file(g: AircraftGeometry) -> str:
    """Where the aircraft flies, for the run-time code (``aircraft.Aircraft``), which reads no
    description: the envelope, where training starts, and the surfaces' travel."""
    e, r = g.envelope, g.randomisation
    record = {"about": "where this aircraft flies, written by aircraft.design.build from its description",
              "name": g.name, "altitude_range_m": list(e.altitude_range_m), "eas_range_mps": list(e.eas_range_mps),
              "reference_eas_mps": e.reference_eas_mps, "start_altitude_range_m": list(r.start_altitude_range_m),
              "start_eas_range_mps": list(r.start_eas_range_mps),
              "surface_limits_deg": {"aileron": g.aileron_limit_deg, "elevator": g.elevator_limit_deg,
                                     "rudder": g.rudder_limit_deg}}
    return json.dumps(record, indent=2) + "\n"


def aircraft_files(g: AircraftGeometry, data: dict) -> dict[str, str]:
    """Every file of the aircraft folder, relative path -> text."""
    return {
        ENVELOPE_FILE: envelope_file(g),
        f"{g.name}.xml": top_file(g),
        "Metrics.xml": metrics(g, data),
        "MassBalance.xml": mass_balance(g, data),
        "GroundReactions.xml": ground_reactions(g),
        "Propulsion.xml": propulsion(g),
        "Engines/motor.xml": motor(g),
        "Engines/propeller.xml": propeller(g, data),
        "Systems/scaling.xml": scaling_system(g, data),
        "Systems/rotor_speed.xml": rotor_speed_system(g, data),
        "Systems/gust_rates.xml": gust_rates_system(),
        "Systems/wing_leveler.xml": wing_leveler_system(),
        "FlightControl.xml": flight_control(g),
        "Aerodynamics.xml": aerodynamics(g, data),
        **{f"reset{i:02d}.xml": reset_file(h, tas, data["stability"]["cruise_alpha_deg"])
           for i, (h, tas) in enumerate(reset_points(g))},
    }


def write(files: dict[str, str], folder: Path) -> None:
    """Write ``files`` under ``folder``."""
    for rel, text in files.items():
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)

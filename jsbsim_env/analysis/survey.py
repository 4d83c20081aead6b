"""A built aircraft's envelope survey: trims across its envelope and its linear modes at cruise,
as the build report (``scripts/build_aircraft.py``) gives them.

The survey flies the model JSBSim loads (not the analysis's tables), so it checks the whole chain:
at each of the envelope's three sample altitudes (near the floor, 5 % up the range; the middle; the
ceiling) and three equivalent airspeeds (the envelope's lowest, the reference, its highest) it
trims the aircraft, measures its static margin (-Cmα / CLα through JSBSim,
``jsbsim_env.analysis.derivatives``) and names its linear modes (``jsbsim_env.analysis.modes``).
A point without a trim is reported with the reason, not dropped. A low-Reynolds polar's Cm(α) is
not linear, so the margin and the modes move across the EAS range: each point is flagged where
they fall outside ``LIMITS`` (a flag asks for a look; the build does not refuse the aircraft).

``trim_grid`` trims every point of the grid the run-time trim table interpolates
(``jsbsim_env.sim.trim_table.grid``), so that a build shows where episodes can start before any
flight needs it.
"""

from __future__ import annotations

from pathlib import Path

from aircraft import Aircraft
from jsbsim_env.analysis import derivatives
from jsbsim_env.analysis.modes import LinearisationError, linear_modes
from jsbsim_env.sim.simulation import Simulation, TrimError
from jsbsim_env.sim.trim_table import grid

# What a survey point is flagged against: a static margin of at least 5 % of the mean chord (below
# it the aircraft is close to neutral, and the margin moves with the CG and the model's error), and
# the flying qualities of MIL-F-8785C, Level 1, Class I (small aircraft), flight phase Category B
# (cruise): short-period damping 0.30-2.0, phugoid damping at least 0.04, Dutch roll damping at
# least 0.08 at 0.4 rad/s or more, roll-mode time constant at most 1.4 s, an unstable spiral
# doubling in no less than 20 s. Each: (what, the row's value or None where it does not apply,
# lowest, highest, the value as text).
LIMITS = (
    ("static margin", lambda r: r.get("static_margin"), 0.05, None, lambda v: f"{100 * v:.1f} % of the mean chord"),
    ("short-period damping", lambda r: _mode(r, "short_period", "damping_ratio"), 0.30, 2.0, lambda v: f"ζ {v:.2f}"),
    ("phugoid damping", lambda r: _mode(r, "phugoid", "damping_ratio"), 0.04, None, lambda v: f"ζ {v:.3f}"),
    ("Dutch-roll damping", lambda r: _mode(r, "dutch_roll", "damping_ratio"), 0.08, None, lambda v: f"ζ {v:.2f}"),
    ("Dutch-roll frequency", lambda r: _mode(r, "dutch_roll", "natural_frequency_radps"), 0.4, None,
     lambda v: f"{v:.2f} rad/s"),
    ("roll-mode time constant", lambda r: _mode(r, "roll", "time_constant_s"), None, 1.4, lambda v: f"{v:.2f} s"),
    ("spiral time to double", lambda r: _mode(r, "spiral", "time_to_double_s"), 20.0, None, lambda v: f"{v:.1f} s"),
)


def _mode(row: dict, name: str, key: str) -> float | None:
    return row.get("modes", {}).get(name, {}).get(key)


def flags(row: dict) -> list[str]:
    """What of a survey row lies outside ``LIMITS``, one text each ("static margin 3.4 % of the mean
    chord, below 5 % of the mean chord")."""
    out = []
    for what, value_of, low, high, text in LIMITS:
        value = value_of(row)
        if value is None:
            continue
        if low is not None and value < low:
            out.append(f"{what} {text(value)}, below {text(low)}")
        elif high is not None and value > high:
            out.append(f"{what} {text(value)}, above {text(high)}")
    return out


def survey_points(aircraft: Aircraft) -> list[tuple[float, float]]:
    """(altitude m, EAS m/s) of the survey, altitudes outer."""
    low, high = aircraft.eas_range_mps
    return [(h, v) for h in aircraft.sample_altitudes_m for v in (low, aircraft.reference_eas_mps, high)]


def envelope_survey(aircraft: Aircraft | Path | str) -> list[dict]:
    """One row per survey point of ``aircraft`` (``aircraft.load_aircraft``): the trim
    (``TrimResult.as_dict``), its ``static_margin`` (fraction of the mean chord) and ``modes``, and
    ``flags`` (``flags``); or ``error``."""
    sim = Simulation(aircraft)
    rows = []
    for altitude_m, eas_mps in survey_points(sim.aircraft):
        row: dict = {"altitude_m": altitude_m, "airspeed_eas_mps": eas_mps}
        try:
            trim = sim.trim(altitude_m, eas_mps, check_envelope=False)
            row.update(trim.as_dict(), shaft_power_w=sim.shaft_power_w(), modes=linear_modes(sim, trim))
            measured = derivatives.measure(sim, altitude_m, eas_mps)  # trims again, then perturbs
            row["static_margin"] = -measured["Cma"] / measured["CLa"]
            row["flags"] = flags(row)
        except (TrimError, LinearisationError) as err:
            row["error"] = str(err)
        rows.append(row)
    return rows


def trim_grid(aircraft: Aircraft | Path | str) -> tuple[list[float], list[float], dict]:
    """The trim table's altitudes (m) and EAS (m/s) for ``aircraft``, and each point's trim
    (``TrimResult``) or error text, keyed by (altitude, EAS)."""
    sim = Simulation(aircraft)
    altitudes, speeds = (list(map(float, axis)) for axis in grid(sim.aircraft.altitude_range_m,
                                                                    sim.aircraft.eas_range_mps))
    cells: dict = {}
    for h in altitudes:
        for v in speeds:
            try:
                cells[h, v] = sim.trim(h, v)
            except TrimError as err:
                cells[h, v] = str(err)
    return altitudes, speeds, cells


def render_trim_grid(altitudes: list[float], speeds: list[float], cells: dict) -> list[str]:
    """Markdown lines: one row per altitude, one column per EAS, each cell α / elevator (deg) /
    throttle, or "no trim"; then the count of points without one."""
    lines = ["| altitude, m | " + " | ".join(f"{v:g} m/s" for v in speeds) + " |", "|---:|" + "---|" * len(speeds)]
    for h in altitudes:
        row = ["no trim" if isinstance(cell, str) else f"{cell.alpha_deg:.1f} / {cell.elevator_deg:.1f} / {cell.throttle:.2f}"
               for cell in (cells[h, v] for v in speeds)]
        lines.append(f"| {h:.0f} | " + " | ".join(row) + " |")
    missing = [f"{h:g} m, {v:g} m/s: {cells[h, v]}" for h in altitudes for v in speeds if isinstance(cells[h, v], str)]
    lines += ["", f"{len(altitudes) * len(speeds) - len(missing)} of {len(altitudes) * len(speeds)} points trimmed."]
    lines += [f"- {m}" for m in missing]
    return lines


def _mode_text(mode: dict) -> str:
    if "damping_ratio" in mode:
        return f"{mode['natural_frequency_radps']:.2f} rad/s, ζ {mode['damping_ratio']:.2f}"
    if "time_constant_s" in mode:
        return f"τ {mode['time_constant_s']:.2f} s"
    if "time_to_double_s" in mode:
        return f"doubles in {mode['time_to_double_s']:.1f} s"
    return "neutral"


def render_survey(rows: list[dict], motor_efficiency: float | None = None) -> list[str]:
    """Markdown lines: the trim table (with the electric power of all motors at ``motor_efficiency``,
    shaft power over electric, where given), then the margins and modes, then the flags."""
    power = f" electric power at {motor_efficiency:g} motor efficiency, W |" if motor_efficiency else ""
    lines = ["| altitude, m | EAS, m/s | α, deg | elevator, deg | throttle | rotor, rpm | thrust, N | shaft power, W |"
             + power, "|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|" if power else "")]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['altitude_m']:.0f} | {r['airspeed_eas_mps']:.1f} | no trim: {r['error']} | | | | | |"
                         + (" |" if power else ""))
        else:
            lines.append(f"| {r['altitude_m']:.0f} | {r['airspeed_eas_mps']:.1f} | {r['alpha_deg']:.2f} | "
                         f"{r['elevator_deg']:.2f} | {r['throttle']:.3f} | {r['rotor_rpm']:.0f} | {r['thrust_n']:.2f} | "
                         f"{r['shaft_power_w']:.1f} |" + (f" {r['shaft_power_w'] / motor_efficiency:.1f} |" if power else ""))
    moded = [r for r in rows if "modes" in r]
    if moded:
        names = list(moded[0]["modes"])
        lines += ["", "| altitude, m | EAS, m/s | static margin | " + " | ".join(names) + " |",
                  "|---:|---:|---:|" + "---|" * len(names)]
        for r in moded:
            lines.append(f"| {r['altitude_m']:.0f} | {r['airspeed_eas_mps']:.1f} | {100 * r['static_margin']:.1f} % | "
                         + " | ".join(_mode_text(r["modes"][n]) for n in names) + " |")
    flagged = [(r, f) for r in moded for f in r["flags"]]
    limits = "; ".join(f"{what} {'' if low is None else f'at least {text(low)}'}"
                       f"{'' if low is None or high is None else ', '}{'' if high is None else f'at most {text(high)}'}"
                       for what, _, low, high, text in LIMITS)
    lines += ["", f"Flagged against a 5 % static margin and MIL-F-8785C Level 1, Class I, Category B ({limits}): "
              + ("nothing." if not flagged else f"{len(flagged)} finding(s), each worth a look (not a failure):"), ""]
    lines += [f"- {r['altitude_m']:.0f} m, {r['airspeed_eas_mps']:g} m/s: {f}" for r, f in flagged]
    return lines


__all__ = ["LIMITS", "envelope_survey", "flags", "render_survey", "render_trim_grid", "survey_points", "trim_grid"]

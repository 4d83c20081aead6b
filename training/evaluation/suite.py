"""Fixed evaluation suite of an attitude controller (the paper's Section 5 and training-style
episodes): the trained policy, or any controller of the shared interface (the PID baseline), on
identical episodes.

1. Doublets (Fig. 9) at 500 m, 5,000 m and 15,000 m, EAS 10 m/s, no delay, noise, turbulence or
   parameter change, from a slightly perturbed trimmed start. The references, one channel at a time:

   | time, s | roll_cmd | pitch_cmd | EAS_cmd |
   |---|---|---|---|
   | 0-5 | 0 | 0 | 10 |
   | 5-15 / 15-25 | +5 / -5 deg | 0 | 10 |
   | 30-40 / 40-50 | 0 | +5 / -5 deg | 10 |
   | 50-60 / 60-70 | 0 | 0 | 11 / 9 m/s |
   | to 80 | 0 | 0 | 10 |

   Per channel: RMSE, the steady-state error after each step (mean absolute error over the last
   2 s before the next change) and the 90 % settling time (from the step until the error stays
   within 10 % of the step size); the sideslip RMSE; Sm of each actuator.
2. ``episodes`` seeded training-style episodes with every disturbance on: mean normalised return,
   episodes that ended early and why, RMSE per channel and Sm per actuator.

Another aircraft (``aircraft``) flies the doublets at the same fractions of its envelope
(``Aircraft.altitude_like_m``) and about its reference EAS (the EAS doublet to +-1 m/s of it).
Its pitch goals are about its level-flight pitch at that EAS (``level_pitch_deg``; the paper's
goals are about 0 deg, its aircraft's trim pitch being -1.0 deg), where a goal of 0 deg would hold
an aircraft that trims at 6 deg in a 6 deg dive; and its pitch doublet is +-5 deg or its steepest
steady descent at that EAS if shallower (``pitch_doublet_deg``): an aircraft that glides flatter
than 5 deg dives far over its speed at -5 deg even at zero throttle, and the EAS steps that follow
never settle.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from aircraft import load_aircraft
from jsbsim_env.control.base import AttitudeController
from jsbsim_env.control.observation import action_to_command, command_to_action
from jsbsim_env.sim.core import CoreConfig, termination_reason
from jsbsim_env.sim.simulation import LBF_TO_N, Simulation
from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
from jsbsim_env.task.metrics import EpisodeRecorder

DOUBLET_ALTITUDES_M = (500.0, 5000.0, 15000.0)
DOUBLET_END_S = 80.0
# (channel, start time s, value); channels 0 roll (rad), 1 pitch (rad), 2 EAS (m/s).
_D = math.radians
DOUBLET_STEPS = ((0, 5.0, _D(5)), (0, 15.0, _D(-5)), (0, 25.0, 0.0), (1, 30.0, _D(5)), (1, 40.0, _D(-5)),
                 (1, 50.0, 0.0), (2, 50.0, 11.0), (2, 60.0, 9.0), (2, 70.0, 10.0))
EVAL_EPISODE_SEED = 777


DOUBLET_EAS_MPS = 10.0  # the EAS of DOUBLET_STEPS: another reference EAS shifts its EAS steps alike
DOUBLET_PITCH_DEG = 5.0  # the pitch steps' size in DOUBLET_STEPS: another amplitude scales them alike


@functools.cache
def _reference_flight(spec: str) -> tuple[float, float]:
    """The level-flight pitch (deg) and the steepest steady descent (deg) of the aircraft ``spec``
    (``Aircraft.spec``), from its trim at its reference EAS and the middle doublet altitude: level flight's
    drag is its thrust, and asin(thrust / weight) the descent that drag holds (a windmilling rotor
    adds drag at zero throttle, so the angle it can hold is steeper: this is conservative)."""
    flown = load_aircraft(spec)
    sim = Simulation(flown)
    trim = sim.trim(flown.altitude_like_m(DOUBLET_ALTITUDES_M[1]), flown.reference_eas_mps)
    glide_deg = math.degrees(math.asin(min(1.0, trim.thrust_n / (sim["inertia/weight-lbs"] * LBF_TO_N))))
    return trim.pitch_deg, glide_deg


def pitch_doublet_deg(aircraft=None) -> float:
    """The pitch doublet's amplitude (deg) on ``aircraft`` (the paper's by default): the paper's
    +-5 deg on its aircraft, as published; on another the smaller of 5 deg and its steepest steady
    descent at its reference EAS (``_reference_flight``), rounded down to 0.1 deg (at least 0.1 deg)."""
    flown = load_aircraft(aircraft)
    if flown.papers:
        return DOUBLET_PITCH_DEG
    glide_deg = _reference_flight(flown.spec)[1]
    return max(0.1, math.floor(10.0 * min(DOUBLET_PITCH_DEG, glide_deg)) / 10.0)


def level_pitch_deg(aircraft=None) -> float:
    """The pitch (deg) the scripted goals of ``aircraft`` (the paper's by default) hold between their
    pitch steps: 0 on the paper's aircraft, as published; on another its level-flight pitch at its
    reference EAS (``_reference_flight``), rounded to 0.1 deg."""
    flown = load_aircraft(aircraft)
    if flown.papers:
        return 0.0
    return round(_reference_flight(flown.spec)[0], 1)


@functools.cache  # read by the goal every control step
def doublet_steps(eas_mps: float = DOUBLET_EAS_MPS, *, pitch_deg: float = DOUBLET_PITCH_DEG,
                  level_pitch_deg: float = 0.0) -> tuple:
    """``DOUBLET_STEPS`` about a reference EAS of ``eas_mps`` (itself at 10 m/s), the pitch steps
    ``pitch_deg`` (itself at 5 deg) each way about ``level_pitch_deg`` (itself at 0)."""
    level = math.radians(level_pitch_deg)

    def value(channel: int, v: float) -> float:
        if channel == 2:
            return v + eas_mps - DOUBLET_EAS_MPS
        if channel == 1:  # the table's own values at 5 deg about 0
            return level + (math.copysign(math.radians(pitch_deg), v) if v != 0.0 else 0.0)
        return v

    return tuple((c, t, value(c, v)) for c, t, v in DOUBLET_STEPS)


def doublet_goal(time_s: float, eas_mps: float = DOUBLET_EAS_MPS, *,
                 pitch_deg: float = DOUBLET_PITCH_DEG, level_pitch_deg: float = 0.0) -> np.ndarray:
    """The scripted goal (roll rad, pitch rad, EAS m/s) at ``time_s`` (``doublet_steps``)."""
    goal = np.array([0.0, math.radians(level_pitch_deg), eas_mps])
    for channel, start, value in doublet_steps(eas_mps, pitch_deg=pitch_deg, level_pitch_deg=level_pitch_deg):
        if time_s >= start:
            goal[channel] = value
    return goal


def fly(controller: AttitudeController, batch: AttitudeTaskBatch, seed: int, steps: int, goal_fn=None,
        **overrides) -> tuple[EpisodeRecorder, dict]:
    """One episode of aircraft 0 of ``batch`` under ``controller``, which sees only the measured
    state and the goal; ``goal_fn(time_s)`` scripts the goal."""
    controller.reset()
    batch.reset_one(0, seed, **overrides)
    core = batch.cores[0]
    rec = EpisodeRecorder()
    total, end = 0.0, {"terminated": False, "truncated": False, "reason": "", "steps": 0}
    for k in range(steps):
        if goal_fn is not None:
            batch.set_goal(0, goal_fn(core.time_s))
        goal = batch.goals[0].copy()
        # The controller is told the episode's control interval, as a flight computer knows its loop rate.
        command = controller.update(core.setup.control_interval_s, batch.measurements()[0], goal)
        action = np.clip(command_to_action(command, batch.action_scale), -1.0, 1.0)
        _, terms, terminated, truncated, codes = batch.step(action[None])
        total += terms[0, 4]
        rec.record(core.time_s, batch.states[0], goal, action_to_command(action, batch.action_scale), terms[0, :4])
        end["steps"] = k + 1
        if terminated[0] or truncated[0]:
            end.update(terminated=bool(terminated[0]), truncated=bool(truncated[0]),
                       reason=termination_reason(int(codes[0]), core.ends) or "")
            break
    end["return"] = total
    return rec, end


def step_response_metrics(rec: EpisodeRecorder, eas_mps: float = DOUBLET_EAS_MPS, *,
                          pitch_deg: float = DOUBLET_PITCH_DEG, level_pitch_deg: float = 0.0) -> dict:
    """Steady-state error and 90 % settling time of each scripted step (see the module docstring),
    about a reference EAS of ``eas_mps``, the pitch steps ``pitch_deg`` each way about ``level_pitch_deg``."""
    steps = doublet_steps(eas_mps, pitch_deg=pitch_deg, level_pitch_deg=level_pitch_deg)
    start_values = {0: 0.0, 1: math.radians(level_pitch_deg), 2: eas_mps}
    a = rec.arrays()
    t, s = a["time_s"], a["true_state"]
    signals = {0: np.degrees(s[:, 1]), 1: np.degrees(s[:, 2]), 2: s[:, 6]}
    scale = {0: math.degrees(1.0), 1: math.degrees(1.0), 2: 1.0}
    names = {0: "roll_deg", 1: "pitch_deg", 2: "airspeed_eas_mps"}
    out: dict[str, list] = {f"steady_state_error_{n}": [] for n in names.values()}
    out.update({f"settling_time_90_s_{n}": [] for n in names.values()})
    for idx, (channel, start, value) in enumerate(steps):
        later = [st for ch, st, _ in steps[idx + 1:] if ch == channel]
        stop = later[0] if later else DOUBLET_END_S
        previous = [v for ch, st, v in steps[:idx] if ch == channel]
        before = previous[-1] if previous else start_values[channel]
        size = abs(value - before) * scale[channel]
        target = value * scale[channel]
        window = (t > start) & (t <= stop)
        err = np.abs(signals[channel][window] - target)
        tail = (t > stop - 2.0) & (t <= stop)
        tail_err = np.abs(signals[channel][tail] - target)
        out[f"steady_state_error_{names[channel]}"].append(float(tail_err.mean()) if tail_err.size else math.nan)
        outside = np.flatnonzero(err > 0.1 * size)
        if err.size == 0:
            settle = math.nan  # the episode ended before this step
        elif outside.size == 0:
            settle = 0.0
        elif outside[-1] == err.size - 1:
            settle = math.nan  # still outside the band when the next step comes
        else:
            settle = float(t[window][outside[-1] + 1] - start)
        out[f"settling_time_90_s_{names[channel]}"].append(settle)
    return out


def doublet_runs(controller: AttitudeController, altitudes_m=None, plot_dir: Path | None = None,
                 prefix: str = "doublets", aircraft=None) -> dict:
    """The paper's Section 5: the scripted doublets from a slightly perturbed start at each altitude
    (``DOUBLET_ALTITUDES_M`` moved into the envelope of ``aircraft``, the paper's by default, when
    None), no delay, noise or perturbation of the aircraft; the pitch steps ``pitch_doublet_deg``
    each way about ``level_pitch_deg``. Returns metrics per altitude (with both); writes the
    Fig. 9 plots and time histories to ``plot_dir``."""
    flown = load_aircraft(aircraft)
    eas = flown.reference_eas_mps  # the paper's aircraft's: 10 m/s
    pitch, level = pitch_doublet_deg(flown), level_pitch_deg(flown)  # the paper's aircraft's: 5 and 0 deg
    if altitudes_m is None:
        altitudes_m = tuple(flown.altitude_like_m(h) for h in DOUBLET_ALTITUDES_M)
    results = {}
    ideal = CoreConfig.ideal(aircraft=flown.spec, perturb_attitude_deg=2.0, perturb_rate_degps=1.0,
                             perturb_eas_mps=0.5, max_steps=int(DOUBLET_END_S / 0.05) + 1)
    batch = AttitudeTaskBatch(1, TaskConfig(core=ideal))
    steps = int(DOUBLET_END_S / 0.05)
    for altitude in altitudes_m:
        rec, end = fly(controller, batch, seed=int(altitude), steps=steps,
                       goal_fn=lambda t: doublet_goal(t, eas, pitch_deg=pitch, level_pitch_deg=level), altitude_m=altitude,
                       airspeed_eas_mps=eas)
        metrics = step_response_metrics(rec, eas, pitch_deg=pitch, level_pitch_deg=level)
        results[f"{altitude:.0f}m"] = {**rec.tracking_metrics(), **metrics, "ended_early": end["terminated"],
                                       "termination": end["reason"], "pitch_doublet_deg": pitch,
                                       "level_pitch_deg": level}
        if plot_dir is not None:
            Path(plot_dir).mkdir(parents=True, exist_ok=True)
            rec.plot(Path(plot_dir) / f"{prefix}_{altitude:.0f}m.png",
                     f"Doublets at {altitude:.0f} m, EAS {eas:g} m/s, pitch {level:g} ±{pitch:g} deg")
            rec.save(Path(plot_dir) / f"{prefix}_{altitude:.0f}m.npz")
    return results


def evaluate(controller: AttitudeController, episodes: int = 50, plot_dir: Path | None = None,
             progress: bool = False, aircraft=None) -> dict:
    """Run the whole suite on ``aircraft`` (the paper's by default); returns the metrics (and writes
    the Fig. 9 plots to ``plot_dir``)."""
    return {"doublets": doublet_runs(controller, None, plot_dir, aircraft=aircraft),
            "episodes": suite_episodes(controller, episodes, progress, aircraft)}


def suite_episodes(controller: AttitudeController, episodes: int = 50, progress: bool = False,
                   aircraft=None) -> dict:
    """The suite's seeded training-style episodes alone, on ``aircraft`` (the paper's by default):
    mean metrics and return, early ends."""
    from training.evaluation.seeds import check_not_test_seed

    check_not_test_seed(range(EVAL_EPISODE_SEED, EVAL_EPISODE_SEED + episodes), "evaluation suite")
    batch = AttitudeTaskBatch(1, TaskConfig(core=CoreConfig(aircraft=load_aircraft(aircraft).spec)))
    rows, early, reasons = [], 0, []
    iterator = range(episodes)
    if progress:
        from tqdm import tqdm

        iterator = tqdm(iterator, desc="episodes")
    for k in iterator:
        rec, end = fly(controller, batch, seed=EVAL_EPISODE_SEED + k, steps=batch.config.core.max_steps)
        rows.append({**rec.tracking_metrics(), "return_norm": end["return"] / batch.config.core.max_steps,
                     "length": end["steps"]})
        if end["terminated"]:
            early += 1
            reasons.append(end["reason"])
    return {
        "count": episodes, "ended_early": early, "reasons": sorted(set(reasons)),
        **{f"mean_{k}": float(np.mean([r[k] for r in rows])) for k in rows[0]},
    }


__all__ = [
    "DOUBLET_ALTITUDES_M",
    "DOUBLET_EAS_MPS",
    "DOUBLET_PITCH_DEG",
    "doublet_goal",
    "doublet_runs",
    "doublet_steps",
    "evaluate",
    "fly",
    "level_pitch_deg",
    "pitch_doublet_deg",
    "step_response_metrics",
    "suite_episodes",
]

"""The fair benchmark: controllers of the shared interface on the frozen test set, paired.

Every flight family is scored on a window that measures one thing, and every realisation ``k``
(seed ``TEST_SEEDS[k]``, ``training.evaluation.seeds``: the turbulence, the sensor noise, the start
and, where drawn, the aircraft) is flown by every controller, so that two controllers differ on
each realisation only by themselves (``training.evaluation.stats``). The validation split flies
the same families on ``VALIDATION_SEEDS``, for choices made with the benchmark's measures.

| family | flight | window | scores |
|---|---|---|---|
| ``turbulence`` | route at 1, 10, 20 km, turbulence on the first leg | 20-300 s of the first leg: no corner | RMSE roll, pitch, sideslip |
| ``steps`` | +5 deg roll or pitch step at 10 s, 5,000 and 15,000 m, calm, sensor noise | 10-30 s: the step alone | rise time, overshoot, settling time, ITAE |
| ``calm`` | route at 1, 10, 20 km, calm air | 60-300 s of the first leg | mean absolute roll, pitch error |
| ``table9`` | 10 km route, calm, the paper's Table 9 positive and negative aircraft | 20-300 s of the first leg | RMSE roll, pitch, sideslip |
| ``robustness`` | the ``turbulence`` flight at 10 km with one sweep axis stressed | 20-300 s of the first leg | RMSE roll, pitch, sideslip |
| ``corner`` | route at 1 and 10 km, calm air | 60 s from the first leg change | RMSE roll, pitch, sideslip |

A route flight starts trimmed on its first leg, heading along it; in the straight-leg families it
ends at the window's end, before the first turn: their first leg is 9 km long (the report's is
6 km), so that at 10 km its corner comes at about 500 s in still air, well after the window ends
even for a flight the turbulence or a stressed aircraft carries along faster (on the 6 km leg, a
few such flights reached the corner at 280 s). ``corner_free`` checks on the flight itself that
every sample of the window is on the first leg; a flight that leaves it inside the window counts as
not having flown the condition. The
``corner`` family scores the first turn itself, from the leg change found on each flight.

One job is one controller x one realisation x one condition of one family; it depends only on
them (each job starts from an empty trim table), so the local processes and Ray give identical
numbers (``training.evaluation.sweep.run_local`` and ``run_ray``).

Another aircraft (``BenchJob.aircraft``) flies the same families where its own envelope puts them
(``family_conditions``): each altitude at the same fraction of its altitude range as on the
paper's 0-20 km (``Aircraft.altitude_like_m``; 1, 10, 20 km: 5 %, half, the ceiling), at its
reference EAS instead of 10 m/s.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from aircraft import AIRCRAFT_NAME, Aircraft, load_aircraft
from jsbsim_env.missions import MissionResult, RouteConfig
from jsbsim_env.sim import disturbances as dist
from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.metrics import ATTITUDE_RMSE_KEYS
from training.evaluation import selection
from training.evaluation.seeds import SPLITS
from training.evaluation.stats import LOWER_IS_BETTER, VERDICTS, paired_difference
from training.evaluation.sweep import AXES, AXIS_UNITS


@dataclass(frozen=True)
class BenchmarkPlan:
    """Windows (s) and step size (deg); ``quick`` shrinks them for checks."""

    leg_window_s: tuple[float, float] = (20.0, 300.0)
    calm_window_s: tuple[float, float] = (60.0, 300.0)
    step_start_s: float = 10.0
    step_window_s: float = 20.0
    step_deg: float = 5.0
    settle_band: float = 0.05  # settling: the response stays within 5 % of the step
    corner_window_s: float = 60.0  # the corner family: from the first leg change on
    straight_leg_north_m: float = 9_000.0  # the straight-leg families' first leg (the report's route: 6 km)
    quick_square_m: float | None = None  # quick: a square route of this side, its first corner in seconds

    @classmethod
    def quick(cls) -> BenchmarkPlan:
        return cls(leg_window_s=(5.0, 25.0), calm_window_s=(10.0, 25.0), step_start_s=2.0, step_window_s=8.0,
                   corner_window_s=15.0, quick_square_m=1200.0)


ROUTE_METRICS = dict.fromkeys(ATTITUDE_RMSE_KEYS, LOWER_IS_BETTER)
STEP_METRICS = {"rise_time_s": LOWER_IS_BETTER, "overshoot_pct": LOWER_IS_BETTER, "settling_time_s": LOWER_IS_BETTER,
                "itae_deg_s2": LOWER_IS_BETTER}
# The corner's path is L1's (the cross-track error at the leg change is the turn radius, the same for
# every controller): scored is how the attitude follows the turn's demands.
CORNER_METRICS = {"rmse_roll_deg": LOWER_IS_BETTER, "rmse_pitch_deg": LOWER_IS_BETTER, "rmse_beta_deg": LOWER_IS_BETTER}
# Calm air: the steady error, and the surfaces' activity (Sm of each command; lower is smoother).
CALM_METRICS = {"mae_roll_deg": LOWER_IS_BETTER, "mae_pitch_deg": LOWER_IS_BETTER,
                **{f"smoothness_{s}": LOWER_IS_BETTER for s in ("aileron", "elevator", "rudder")}}
# The sweeps' axes at one stressed value each (the training setting: delay 80-120 ms, servo 100 deg/s,
# Table 3 noise, Table 4 spread). At 10 deg/s the servo limit shows (the PID's roll RMSE 0.164 ->
# 0.167 deg on realisation 0); at 5 deg/s the PID ends that flight early (pitch limit).
STRESSED = {"delay_ms": 200.0, "servo_rate_limit_degps": 10.0, "noise_scale": 4.0, "parameter_strength": 2.0}


@dataclass(frozen=True)
class Family:
    name: str
    what: str
    window: str  # "leg", "calm" (BenchmarkPlan's route windows) or "step"
    conditions: tuple[dict, ...]
    metrics: dict = field(default_factory=dict)  # metric -> direction


FAMILIES: dict[str, Family] = {f.name: f for f in (
    Family("turbulence", "turbulence rejection on a straight leg (Dryden 0.5 m/s on each axis)", "leg", tuple({"altitude_m": h} for h in (1000.0, 10000.0, 20000.0)),
           ROUTE_METRICS),
    Family("steps", "a +5 deg step of roll or pitch from level flight (roll 0, pitch the aircraft's level-flight "
                    "pitch: 0 on the paper's), calm air, sensor noise",
           "step", tuple({"channel": c, "altitude_m": h}
                                                                 for c in ("roll", "pitch") for h in (5000.0, 15000.0)),
           STEP_METRICS),
    Family("calm", "steady-state error in calm air on a straight leg", "calm",
           tuple({"altitude_m": h} for h in (1000.0, 10000.0, 20000.0)), CALM_METRICS),
    Family("table9", "the paper's Table 9 aircraft, calm air, on a straight leg at {route_altitude}",
           "leg", tuple({"parameters": p} for p in ("positive", "negative")),
           ROUTE_METRICS),
    Family("robustness", "the turbulence flight at {route_altitude} with one sweep axis at a stressed value",
           "leg", tuple({"axis": a, "value": v} for a, v in STRESSED.items()),
           ROUTE_METRICS),
    Family("corner", "the route's first corner (L1's roll demand to its limit and back), calm air, sensor noise",
           "corner", tuple({"altitude_m": h} for h in (1000.0, 10000.0)), CORNER_METRICS),
)}


PAPER_ROUTE_ALTITUDE_M = 10_000.0  # the table9 and robustness families' altitude on the paper's aircraft


def family_conditions(family: str, aircraft: Aircraft | str | None = None) -> tuple[dict, ...]:
    """``FAMILIES[family].conditions`` as ``aircraft`` (the paper's by default) flies them: each
    altitude moved into its envelope (``Aircraft.altitude_like_m``)."""
    found = load_aircraft(aircraft)
    return tuple({k: found.altitude_like_m(v) if k == "altitude_m" else v for k, v in c.items()}
                 for c in FAMILIES[family].conditions)


def family_what(family: str, aircraft: Aircraft | str | None = None) -> str:
    """What ``family`` flies, as ``aircraft`` (the paper's by default) flies it: the paper's 10 km
    route altitude moved into its envelope."""
    route_m = load_aircraft(aircraft).altitude_like_m(PAPER_ROUTE_ALTITUDE_M)
    return FAMILIES[family].what.format(route_altitude=f"{route_m / 1000:g} km")


def condition_label(condition: dict) -> str:
    if "axis" in condition:
        return f"{condition['axis']}={condition['value']:g} {AXIS_UNITS[condition['axis']]}"
    parts = []
    for k, v in condition.items():
        parts.append(f"{v / 1000:g} km" if k == "altitude_m" else str(v))
    return " ".join(parts)


@dataclass(frozen=True)
class StressedRoute(RouteConfig):
    """A route whose flight core has sweep axes applied (``training.evaluation.sweep.AXES``)."""

    stress: tuple[tuple[str, float], ...] = ()

    def core_config(self) -> CoreConfig:
        core = super().core_config()
        for name, value in self.stress:
            core = AXES[name](core, float(value))
        return core


@dataclass(frozen=True)
class BenchJob:
    """One controller x one realisation x one condition of one family."""

    family: str
    condition: dict
    controller: str
    realisation: int
    quick: bool = False
    split: str = "test"  # the seed range (``seeds.SPLITS``): the frozen test set, or validation for choices
    policy_path: str | None = None  # a "policy" flown from this file instead of the run's --policy
    label: str | None = None  # its name in the rows and tables (the controller's name when None)
    network_alone: bool = False  # a policy flown without its classical stages (``PolicyRuntime``)
    aircraft: str = AIRCRAFT_NAME  # the aircraft flown (``aircraft.load_aircraft``)
    transfer: bool = False  # fly a policy on an aircraft it was not trained on (a transfer experiment)


def seed_of(realisation: int, split: str = "test") -> int:
    return SPLITS[split][realisation]


def route_config(job: BenchJob, plan: BenchmarkPlan) -> RouteConfig:
    """The route flight of a route family's job: it ends at the window's end, on the first leg."""
    c, seed = job.condition, seed_of(job.realisation, job.split)
    end = (plan.calm_window_s if job.family == "calm" else plan.leg_window_s)[1]
    leg = plan.straight_leg_north_m
    flown = load_aircraft(job.aircraft)
    on = {"aircraft": job.aircraft, "eas_mps": flown.reference_eas_mps}  # the paper's aircraft's: 10 m/s
    middle_m = flown.altitude_like_m(PAPER_ROUTE_ALTITUDE_M)
    if job.family in ("turbulence", "calm"):
        return RouteConfig(altitude_m=c["altitude_m"], leg_north_m=leg, duration_s=end, seed=seed,
                           turbulence_legs=(0,) if job.family == "turbulence" else (), **on)
    if job.family == "table9":
        return RouteConfig(altitude_m=middle_m, leg_north_m=leg, duration_s=end, seed=seed, parameters=c["parameters"],
                           **on)
    if job.family == "robustness":
        parameters = dist.RANDOMISED if c["axis"] == "parameter_strength" else "nominal"
        return StressedRoute(altitude_m=middle_m, leg_north_m=leg, duration_s=end, seed=seed, turbulence_legs=(0,),
                             parameters=parameters, stress=((c["axis"], float(c["value"])),), **on)
    if job.family == "corner":
        base = RouteConfig(altitude_m=c["altitude_m"], seed=seed, **on)
        if plan.quick_square_m:
            side = plan.quick_square_m
            base = replace(base, waypoints_ne_m=((0.0, 0.0), (side, 0.0), (side, side), (0.0, side)))
        return replace(base, duration_s=float(math.ceil(first_corner_s(base) + plan.corner_window_s + 30.0)))
    raise ValueError(f"{job.family} is not a route family")


def first_corner_s(config: RouteConfig) -> float:
    """When the first leg ends in still air (s): the next leg begins one turn radius at the roll
    limit before the first leg's end (``jsbsim_env.missions.RouteFlight.demand``), flown at the true
    airspeed of the route's EAS in the standard atmosphere."""
    from jsbsim_env.control.l1 import G_MPS2
    from jsbsim_env.missions import standard_density_kg_m3

    wp = config.waypoints()
    tas = config.eas_mps * math.sqrt(1.225 / standard_density_kg_m3(config.altitude_m))
    radius = tas ** 2 / (G_MPS2 * math.tan(config.l1.roll_limit_rad))
    return float((np.hypot(*(wp[1] - wp[0])) - radius) / tas)


def corner_window(result: MissionResult, length_s: float) -> tuple[float, float] | None:
    """The corner family's window: from the first leg change for ``length_s``; None where the flight
    has no leg change, ends before the window does, or changes leg twice in it."""
    t, leg = result.arrays["time_s"], result.arrays["leg"]
    changes = np.flatnonzero(np.diff(leg) != 0)
    if changes.size == 0:
        return None
    start = float(t[changes[0] + 1])
    end = start + length_s
    inside = result.window(start, end)
    if t[-1] + 1.0 / result.config.control_rate_hz < end or np.unique(leg[inside]).size != 1:
        return None
    return start, end


def corner_free(result: MissionResult, start_s: float, end_s: float) -> bool:
    """Whether every sample of the window is on the route's first leg, which the flight starts on,
    heading along it: no turn, and no leg change, falls in the window."""
    legs = result.arrays["leg"][result.window(start_s, end_s)]
    return bool(legs.size) and bool(np.all(legs == 0))


def step_metrics(time_s: np.ndarray, response_deg: np.ndarray, step_start_s: float, step_deg: float,
                 band: float = 0.05, window_s: float | None = None) -> dict[str, float]:
    """Rise time (10 % to 90 % of the step), overshoot (% of the step), settling time (from the step
    until the response stays within ``band`` of the step; the window's length where it never does)
    and ITAE (integral of time since the step x absolute error, deg s^2) of a step from 0 to
    ``step_deg`` at ``step_start_s``, over the samples from the step on."""
    m = time_s >= step_start_s
    t, y = time_s[m] - step_start_s, response_deg[m]
    if t.size < 2:
        return dict.fromkeys(STEP_METRICS, math.nan)
    r = y / step_deg
    above10, above90 = np.flatnonzero(r >= 0.1), np.flatnonzero(r >= 0.9)
    rise = float(t[above90[0]] - t[above10[0]]) if above90.size and above10.size else math.nan
    overshoot = float(max(0.0, r.max() - 1.0) * 100.0)
    outside = np.flatnonzero(np.abs(r - 1.0) > band)
    length = window_s if window_s is not None else float(t[-1])
    if outside.size == 0:
        settle = 0.0
    elif outside[-1] == t.size - 1:
        settle = length  # never settled in the window: censored at its length
    else:
        settle = float(t[outside[-1] + 1])
    e = np.abs(y - step_deg)
    dt = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
    return {"rise_time_s": rise, "overshoot_pct": overshoot, "settling_time_s": settle,
            "itae_deg_s2": float(np.sum(t * e * dt))}


def _fly_step(controller, job: BenchJob, plan: BenchmarkPlan) -> tuple[dict, str]:
    from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
    from training.evaluation.suite import fly, level_pitch_deg

    interval = 0.04
    end_s = plan.step_start_s + plan.step_window_s
    eas_mps = load_aircraft(job.aircraft).reference_eas_mps  # the paper's aircraft's: 10 m/s
    core = CoreConfig(aircraft=job.aircraft, control_interval_s=(interval, interval), delay_s=(interval, interval), sensor_noise=True,
                      noise_reversion_per_s=1.0, parameters="nominal", turbulence=False, perturb_attitude_deg=1.0,
                      perturb_rate_degps=0.5, perturb_eas_mps=0.3, max_steps=math.ceil(end_s / interval) + 2)
    batch = AttitudeTaskBatch(1, TaskConfig(core=core))
    channel = 0 if job.condition["channel"] == "roll" else 1
    step = math.radians(plan.step_deg)
    # Pitch held at the aircraft's level-flight pitch (0 on the paper's aircraft, as its Fig. 9),
    # the step measured from there.
    level_deg = level_pitch_deg(job.aircraft)

    def goal(time_s: float) -> np.ndarray:
        g = np.array([0.0, math.radians(level_deg), eas_mps])
        if time_s >= plan.step_start_s:
            g[channel] += step
        return g

    rec, end = fly(controller, batch, seed=seed_of(job.realisation, job.split), steps=math.ceil(end_s / interval), goal_fn=goal,
                   altitude_m=job.condition["altitude_m"], airspeed_eas_mps=eas_mps)
    a = rec.arrays()
    if end["terminated"]:
        return dict.fromkeys(STEP_METRICS, math.nan), end["reason"] or "ended early"
    response = np.degrees(a["true_state"][:, 1 + channel]) - (level_deg if channel == 1 else 0.0)
    return step_metrics(a["time_s"], response, plan.step_start_s, plan.step_deg, plan.settle_band,
                        plan.step_window_s), ""


def run_benchmark_job(job: BenchJob, policy: str | None = None) -> list[dict]:
    """Fly one job; one row: the family, condition, controller, realisation and seed, whether the
    flight ended early, and the family's metrics (NaN where it ended before the window's end, or
    left the straight leg inside the window: such a flight did not fly the condition, and counts as
    an early end)."""
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.missions import fly_route
    from jsbsim_env.sim.trim_table import TrimTable

    TrimTable.forget_shared()  # the job's numbers must not depend on what this process flew before
    plan = BenchmarkPlan.quick() if job.quick else BenchmarkPlan()
    family = FAMILIES[job.family]
    controller = make_controller(job.controller, job.policy_path or policy, network_alone=job.network_alone,
                                 aircraft=job.aircraft, transfer=job.transfer)
    row = {"family": job.family, "condition": condition_label(job.condition), "controller": job.label or job.controller,
           "realisation": job.realisation, "seed": seed_of(job.realisation, job.split)}
    if job.family == "steps":
        metrics, ended = _fly_step(controller, job, plan)
        return [{**row, "ended_early": ended, "corner_free": True, **metrics}]
    config = route_config(job, plan)
    start, end = plan.calm_window_s if job.family == "calm" else plan.leg_window_s
    result = fly_route(controller, config)
    ended = result.ended_early or ""
    if ended:
        return [{**row, "ended_early": ended, "corner_free": job.family != "corner",
                 **dict.fromkeys(family.metrics, math.nan)}]
    if job.family == "corner":
        window = corner_window(result, plan.corner_window_s)
        if window is None:
            raise RuntimeError(f"corner {row['condition']}: the flight did not fly its first corner and "
                               f"{plan.corner_window_s:g} s after it")
        metrics = result.metrics(*window)
        return [{**row, "ended_early": "", "corner_free": False, "window_start_s": window[0],
                 **{k: float(metrics[k]) for k in family.metrics}}]
    if not corner_free(result, start, end):  # it flew the leg too fast: it did not hold the condition
        change_s = float(result.arrays["time_s"][np.argmax(result.arrays["leg"] != result.arrays["leg"][0])])
        return [{**row, "ended_early": f"left the first leg at {change_s:.1f} s, inside the window", "corner_free": True,
                 **dict.fromkeys(family.metrics, math.nan)}]
    metrics = result.metrics(start, end)
    return [{**row, "ended_early": "", "corner_free": True, **{k: float(metrics[k]) for k in family.metrics}}]


NETWORK_ALONE = "{} (network alone)"  # the label of a policy flown without its classical stages


def jobs_for(families: list[str], controllers: list[str], episodes: int, quick: bool = False,
             split: str = "test", policies: dict[str, str] | None = None, network_alone=(),
             policy: str | None = None, aircraft: str = AIRCRAFT_NAME, transfer: bool = False) -> list[BenchJob]:
    """Every job: family x condition x realisation x controller (the controllers of one realisation
    next to each other), on the seeds of ``split`` ("test" or "validation"). ``policies`` adds, after
    ``controllers``, a policy file per label (``--compare``); ``network_alone`` then adds the policies
    it names ("policy": the "policy" controller, flying ``policy``; a label of ``policies``) without
    their classical stages, labelled ``NETWORK_ALONE``. Every job flies ``aircraft``
    (``family_conditions``); ``transfer`` lets a policy fly it that was trained on another."""
    if split not in SPLITS:
        raise ValueError(f"split must be one of {', '.join(SPLITS)}, got {split!r}")
    if not 1 <= episodes <= len(SPLITS[split]):
        raise ValueError(f"episodes must be 1 to {len(SPLITS[split])} (the {split} set's size), got {episodes}")
    flown = [(c, None, None, False) for c in controllers] + [("policy", str(p), label, False)
                                                             for label, p in (policies or {}).items()]
    flown += [("policy", path if label else policy, NETWORK_ALONE.format(label or ctl), True)
              for ctl, path, label, _ in flown if ctl == "policy" and (label or ctl) in network_alone]
    return [BenchJob(f, dict(c), ctl, k, quick, split, path, label, alone, str(aircraft), transfer) for f in families
            for c in family_conditions(f, aircraft) for k in range(episodes) for ctl, path, label, alone in flown]


def flown_labels(jobs: list[BenchJob]) -> list[str]:
    """The controllers' names in the rows, in the order they are flown."""
    return list(dict.fromkeys(j.label or j.controller for j in jobs))


def summarise(rows: list[dict], controllers: list[str], method: str = "t") -> dict:
    """Per family and condition: each controller's mean, standard deviation and count per metric,
    its early ends, and per pair of controllers (a, b) the paired difference a - b with its 95 %
    interval and verdict."""
    out: dict = {}
    for name, family in FAMILIES.items():
        mine = [r for r in rows if r["family"] == name]
        if not mine:
            continue
        per_condition = {}
        for cond in dict.fromkeys(r["condition"] for r in mine):
            here = [r for r in mine if r["condition"] == cond]
            values = {c: {r["realisation"]: r for r in here if r["controller"] == c} for c in controllers}
            realisations = sorted(set.intersection(*(set(v) for v in values.values())))
            entry: dict = {"controllers": {}, "pairs": {}}
            for c in controllers:
                stats = {}
                for metric in family.metrics:
                    x = np.array([values[c][k][metric] for k in realisations], float)
                    ok = x[np.isfinite(x)]
                    stats[metric] = {"mean": float(ok.mean()) if ok.size else math.nan,
                                     "std": float(ok.std(ddof=1)) if ok.size > 1 else math.nan, "n": int(ok.size)}
                entry["controllers"][c] = {"metrics": stats,
                                           "ended_early": sum(bool(values[c][k]["ended_early"]) for k in realisations)}
            for a, b in itertools.combinations(controllers, 2):
                entry["pairs"][f"{a} - {b}"] = {
                    metric: paired_difference([values[a][k][metric] for k in realisations],
                                              [values[b][k][metric] for k in realisations], direction,
                                              method).as_dict()
                    for metric, direction in family.metrics.items()}
            per_condition[cond] = entry
        out[name] = per_condition
    return out


def check_seed_labels(labels: list[str], known) -> None:
    """``ValueError`` unless ``labels`` are two or more different controllers among ``known``: the
    seeds a mean of seeds (``mean_of_seeds``) is taken over."""
    unknown = [label for label in labels if label not in known]
    if len(labels) < 2 or len(set(labels)) != len(labels) or unknown:
        raise ValueError(f"a mean of seeds needs two or more different controllers among {', '.join(known) or 'none'}, "
                         f"got {','.join(labels)}")


def mean_of_seeds(rows: list[dict], labels: list[str]) -> tuple[str, list[dict]]:
    """The seeds ``labels`` of one recipe as one candidate, ``mean(a,b,...)``, and its rows: on each
    family's condition and realisation, each metric the mean of theirs (NaN where any is missing),
    ended early where any of them did. Paired with the others on the same realisations, it asks
    whether the recipe, rather than one of its seeds, is better."""
    check_seed_labels(labels, list(dict.fromkeys(r["controller"] for r in rows)))
    name = f"mean({','.join(labels)})"
    groups: dict[tuple, dict[str, dict]] = {}
    for r in rows:
        if r["controller"] in labels:
            groups.setdefault((r["family"], r["condition"], r["realisation"]), {})[r["controller"]] = r
    out = []
    for (family, condition, realisation), by_label in groups.items():
        if len(by_label) != len(labels):
            continue  # a realisation some seed did not fly: not paired
        first = by_label[labels[0]]
        row = {"family": family, "condition": condition, "controller": name, "realisation": realisation,
               "seed": first["seed"],
               "ended_early": "; ".join(f"{k}: {r['ended_early']}" for k, r in by_label.items() if r["ended_early"]),
               "corner_free": all(r["corner_free"] for r in by_label.values())}
        for metric in FAMILIES[family].metrics:
            values = np.array([by_label[k][metric] for k in labels], float)
            row[metric] = float(values.mean()) if np.all(np.isfinite(values)) else math.nan
        out.append(row)
    return name, out


def verdict_counts(summary: dict, family: str, a: str, b: str) -> dict[str, int]:
    """How many of ``family``'s metrics (each condition's each score) the pair ``a - b`` finds
    better, worse and not different at 95 % for ``a``."""
    counts = dict.fromkeys(VERDICTS, 0)
    for entry in summary[family].values():
        for d in entry["pairs"][f"{a} - {b}"].values():
            counts[d["verdict"]] += 1
    return counts


def window_text(window: str, plan: BenchmarkPlan) -> str:
    if window == "corner":
        return (f"{plan.corner_window_s:g} s from the first leg change (the turn onto the second leg), found on "
                "each flight (it must hold no second leg change)")
    if window == "step":
        return (f"{plan.step_start_s:g}-{plan.step_start_s + plan.step_window_s:g} s, from the {plan.step_deg:g} deg "
                "step on (no other change of the demands)")
    start, end = plan.calm_window_s if window == "calm" else plan.leg_window_s
    return f"{start:g}-{end:g} s on the route's first leg; the flight ends at {end:g} s, before the first corner"


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.2e}" if x != 0.0 and abs(x) < 1e-2 else f"{x:.3f}"


def render_markdown(summary: dict, controllers: list[str], plan: BenchmarkPlan, episodes: int, command: str,
                    method: str, split: str = "test", aircraft: Aircraft | str | None = None) -> str:
    seeds = SPLITS[split]
    what = "the frozen test set" if split == "test" else "the validation set (for choices; not the test set)"
    lines = ["# Benchmark" + ("" if split == "test" else " (validation seeds)"), "", f"`{command}`", "",
             (f"{episodes} realisation(s) per condition, seeds {seeds.start} to {seeds.start + episodes - 1} "
             f"of {what}; paired differences with their 95 % interval ({method}); the verdict is for the "
             "first controller of the pair, lower being better for every metric here. Cells: mean ± standard "
             "deviation over the realisations."), "",
             (f"Windows: route families {plan.leg_window_s[0]:g}-{plan.leg_window_s[1]:g} s of the first leg "
             f"(calm: {plan.calm_window_s[0]:g}-{plan.calm_window_s[1]:g} s); steps {plan.step_deg:g} deg at "
             f"{plan.step_start_s:g} s, scored for {plan.step_window_s:g} s."), ""]
    pairs = [f"{a} - {b}" for a, b in itertools.combinations(controllers, 2)]
    if len(controllers) > 1:
        first, others = controllers[0], controllers[1:]
        lines += [f"## {first} against each other controller", "",
                  (f"Counts of the metrics (one per condition and score) where {first} is better, worse, or "
                   "not different at 95 %, per family:"), "",
                  "| family | " + " | ".join(others) + " |", "|" + "---|" * (1 + len(others))]
        for name in summary:
            cells = []
            for other in others:
                n = verdict_counts(summary, name, first, other)
                cells.append(f"{n['better']} better, {n['worse']} worse, {n['no difference']} =")
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        lines += ["",
                  (f"The paired difference {first} − other and its verdict for {first}: better, worse, or = (no "
                   "difference at 95 %). Every pair's interval is in the families' tables below."), "",
                  "| family | condition | metric | " + " | ".join(others) + " |", "|" + "---|" * (3 + len(others))]
        for name, per_condition in summary.items():
            for cond, entry in per_condition.items():
                for metric in FAMILIES[name].metrics:
                    cells = [name, cond, metric]
                    for other in others:
                        d = entry["pairs"][f"{first} - {other}"][metric]
                        verdict = "=" if d["verdict"] == "no difference" else d["verdict"]
                        cells.append(f"{verdict} ({_fmt(d['mean'])})")
                    lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    lines += selection.render(summary, controllers, _fmt)
    for name, per_condition in summary.items():
        family = FAMILIES[name]
        metrics = list(family.metrics)
        lines += [f"## {name}: {family_what(name, aircraft)}", "", f"Window: {window_text(family.window, plan)}.", ""]
        head = ["condition", "metric", *controllers]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for cond, entry in per_condition.items():
            for metric in metrics:
                cells = [cond, metric]
                for c in controllers:
                    s = entry["controllers"][c]["metrics"][metric]
                    early = entry["controllers"][c]["ended_early"]
                    cells.append(f"{_fmt(s['mean'])} ± {_fmt(s['std'])}" + (f" ({early} ended early)" if early else ""))
                lines.append("| " + " | ".join(cells) + " |")
        if pairs:
            head = ["condition", "pair", *(f"{m}: difference [95 %], verdict" for m in metrics)]
            lines += ["", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            for cond, entry in per_condition.items():
                for p in pairs:
                    cells = [cond, p]
                    for metric in metrics:
                        d = entry["pairs"][p][metric]
                        cells.append(f"{_fmt(d['mean'])} [{_fmt(d['low'])}, {_fmt(d['high'])}] {d['verdict']}")
                    lines.append("| " + " | ".join(cells) + " |")
        lines += ["", f"![{name}]({name}.png)", ""]
    return "\n".join(lines)


def plot_family(rows: list[dict], name: str, controllers: list[str], path,
                aircraft: Aircraft | str | None = None) -> None:
    """One figure per family: a panel per metric, each condition's controllers side by side, every
    realisation a dot and the mean a bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    family = FAMILIES[name]
    mine = [r for r in rows if r["family"] == name]
    conditions = list(dict.fromkeys(r["condition"] for r in mine))
    metrics = list(family.metrics)
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.6), squeeze=False)
    width = 0.8 / max(len(controllers), 1)
    for ax, metric in zip(axes[0], metrics):
        for j, c in enumerate(controllers):
            for i, cond in enumerate(conditions):
                x = np.array([r[metric] for r in mine if r["condition"] == cond and r["controller"] == c], float)
                x = x[np.isfinite(x)]
                pos = i - 0.4 + width * (j + 0.5)
                if x.size:
                    ax.bar(pos, x.mean(), width * 0.9, color=f"C{j}", alpha=0.35, label=c if i == 0 else None)
                    ax.plot(np.full(x.size, pos), x, ".", color=f"C{j}", ms=4)
        ax.set_xticks(range(len(conditions)), conditions, rotation=20, fontsize=8)
        ax.set_title(metric, fontsize=9)
        ax.grid(alpha=0.3, axis="y")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{name}: {family_what(name, aircraft)}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plan_dict(quick: bool) -> dict:
    return asdict(BenchmarkPlan.quick() if quick else BenchmarkPlan())


__all__ = ["FAMILIES", "BenchJob", "BenchmarkPlan", "StressedRoute", "check_seed_labels", "condition_label", "corner_free", "corner_window",
           "first_corner_s", "jobs_for", "mean_of_seeds",
           "plan_dict", "render_markdown", "route_config", "run_benchmark_job", "seed_of", "step_metrics", "summarise",
           "verdict_counts"]

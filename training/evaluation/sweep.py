"""Robustness sweeps: controllers flown over a grid of conditions on identical seeded episodes.

Each axis changes one setting of the flight core from the training setting (the paper's Sections 2-3,
every disturbance on); a grid is every combination of the axes' values. Every controller flies
the same ``episodes`` seeded training-style episodes (random goals, start perturbation) under
each condition, so the rows differ only by the controller. The work is cut into the same jobs
whatever the backend, and each job starts from an empty trim table, so the numbers do not
depend on how the jobs are spread over processes.

| axis | unit | what it sets |
|---|---|---|
| delay_ms | ms | control delay, fixed |
| control_interval_ms | ms | control interval, fixed |
| noise_scale | x Table 3 | sensor-noise sigmas |
| parameter_strength | x Table 4 | distance of each coefficient draw from 1 (0: nominal aircraft) |
| turbulence_sigma_mps | m/s | Dryden intensity on each axis (0: calm) |
| backlash_deg | deg | servo backlash |
| servo_rate_limit_degps | deg/s | every surface servo's rate limit (the paper: 100) |
| altitude_m | m | start altitude, fixed |
| eas_mps | m/s | start EAS, fixed |

Each axis takes values in a range (``AXIS_RANGES``, with the reason for each bound); a value
outside it, NaN or infinity, the same value twice on one axis, or one axis given twice is refused
(``parse_axis``, ``parse_axes``) before anything is flown.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

import numpy as np

from aircraft import AIRCRAFT_NAME, load_aircraft
from jsbsim_env.sim.core import COMMAND_HIGH, CoreConfig
from jsbsim_env.sim.disturbances import RANDOMISATION_GROUPS
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS
from jsbsim_env.task.attitude import AttitudeTaskBatch, TaskConfig
from training.evaluation.seeds import check_not_test_seed
from training.ray_session import ray_session

SWEEP_EPISODE_SEED = 31_000  # episode k of every condition uses seed SWEEP_EPISODE_SEED + k


def _fixed(name: str, scale: float = 1.0) -> Callable[[CoreConfig, float], CoreConfig]:
    return lambda core, v: replace(core, **{name: (v * scale, v * scale)})


AXES: dict[str, Callable[[CoreConfig, float], CoreConfig]] = {
    "delay_ms": _fixed("delay_s", 1e-3),
    "control_interval_ms": _fixed("control_interval_s", 1e-3),
    "noise_scale": lambda core, v: replace(core, noise_scale=v, sensor_noise=v > 0.0),
    "parameter_strength": lambda core, v: replace(core, parameter_strength=v),
    "turbulence_sigma_mps": lambda core, v: replace(core, turbulence=v > 0.0, turbulence_sigma_mps=max(v, 1e-9)),
    "backlash_deg": lambda core, v: replace(core, backlash_deg=v),
    "servo_rate_limit_degps": lambda core, v: replace(core, servo_rate_limit_degps=v),
    "altitude_m": _fixed("altitude_range_m"),
    "eas_mps": _fixed("eas_range_mps"),
}
AXIS_UNITS = {"delay_ms": "ms", "control_interval_ms": "ms", "noise_scale": "x Table 3",
              "parameter_strength": "x Table 4", "turbulence_sigma_mps": "m/s", "backlash_deg": "deg",
              "servo_rate_limit_degps": "deg/s", "altitude_m": "m", "eas_mps": "m/s"}


@dataclass(frozen=True)
class AxisRange:
    """The values an axis takes: ``low`` to ``high``, each bound itself allowed unless open."""

    low: float
    high: float
    why: str
    low_open: bool = False
    high_open: bool = False

    def allows(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return math.isfinite(value) and above and below

    def text(self, unit: str) -> str:
        # 15 significant digits: a bound such as one simulation step (8.333... ms) reads as itself
        return (f"{'(' if self.low_open else '['}{self.low:.15g}, {self.high:.15g}{')' if self.high_open else ']'}"
                f" {unit}")


_SIM_STEP_MS = 1000.0 / CoreConfig().sim_rate_hz
# A coefficient of Table 4 drawn at (1 - d) reaches zero at parameter_strength 1 / d.
_STRENGTH_LIMIT = round(1.0 / max(1.0 - lo for _, (lo, _) in RANDOMISATION_GROUPS.values()), 6)
_SMALLEST_SURFACE_TRAVEL_DEG = float(min(COMMAND_HIGH[:3]))
# Where each axis means something; a value outside is refused before any flight.
AXIS_RANGES: dict[str, AxisRange] = {
    "delay_ms": AxisRange(0.0, 1000.0, "past a second, 8 times the training's longest delay, every controller "
                                       "flies blind"),
    "control_interval_ms": AxisRange(_SIM_STEP_MS, 1000.0, "one simulation step at 120 Hz to a second"),
    "noise_scale": AxisRange(0.0, 100.0, "0 is no sensor noise; at 100 times Table 3 the measurements say "
                                         "nothing"),
    "parameter_strength": AxisRange(0.0, _STRENGTH_LIMIT, f"at {_STRENGTH_LIMIT:g} a coefficient drawn 20 % low "
                                                          "reaches zero", high_open=True),
    "turbulence_sigma_mps": AxisRange(0.0, 10.0, "0 is calm air; 10 m/s is the aircraft's own airspeed"),
    "backlash_deg": AxisRange(0.0, _SMALLEST_SURFACE_TRAVEL_DEG, "at most the smallest surface travel, the rudder's"),
    "servo_rate_limit_degps": AxisRange(0.0, 1000.0, "a servo that cannot move flies nothing; 1000 deg/s is as "
                                                     "good as no limit", low_open=True),
    "altitude_m": AxisRange(*ALTITUDE_RANGE_M, "the flight envelope, where a start is trimmed "
                                               "(jsbsim_env.sim.simulation.ALTITUDE_RANGE_M)"),
    "eas_mps": AxisRange(*EAS_RANGE_MPS, "the flight envelope, where a start is trimmed "
                                         "(jsbsim_env.sim.simulation.EAS_RANGE_MPS)"),
}


def axis_ranges(aircraft=None) -> dict[str, AxisRange]:
    """``AXIS_RANGES`` for ``aircraft`` (the paper's by default): its own envelope on the altitude
    and EAS axes, its own smallest surface travel on the backlash axis."""
    flown = load_aircraft(aircraft)
    why = f"{flown.name}'s flight envelope, where a start is trimmed (its envelope.json)"
    return {**AXIS_RANGES, "altitude_m": AxisRange(*flown.altitude_range_m, why),
            "eas_mps": AxisRange(*flown.eas_range_mps, why),
            "backlash_deg": AxisRange(0.0, min(flown.surface_limits_deg), f"at most {flown.name}'s smallest surface "
                                                                          "travel")}


def parse_axis(text: str, aircraft=None) -> tuple[str, list[float]]:
    """``"delay_ms=0,100,200"`` -> ("delay_ms", [0.0, 100.0, 200.0]). Refuses (``ValueError``, one
    line naming the axis, the value and the range) an unknown axis, a value that is not a number,
    outside the axis's range (``axis_ranges(aircraft)``; NaN and infinity are outside every range),
    or given twice."""
    name, _, values = text.partition("=")
    name = name.strip()
    if name not in AXES:
        raise ValueError(f"unknown axis {name!r}: choose from {', '.join(AXES)}")
    try:
        parsed = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"axis {name}: values must be numbers separated by commas, got {values!r}") from None
    if not parsed:
        raise ValueError(f"axis {name} needs at least one finite value, got {values!r}")
    allowed = (AXIS_RANGES if aircraft is None else axis_ranges(aircraft))[name]
    for v in parsed:
        if not allowed.allows(v):
            raise ValueError(f"axis {name}: {v:.15g} is outside its range {allowed.text(AXIS_UNITS[name])}: "
                             f"{allowed.why}")
    repeated = sorted({v for v in parsed if parsed.count(v) > 1})
    if repeated:
        raise ValueError(f"axis {name}: {', '.join(f'{v:g}' for v in repeated)} given more than once (each value "
                         "is a condition; twice would fly its episodes twice)")
    return name, parsed


def parse_axes(texts: Iterable[str], aircraft=None) -> dict[str, list[float]]:
    """Several ``--axis`` texts as {axis: values}, in the order given, in ``aircraft``'s ranges; an
    axis given twice is refused (the later one would otherwise replace the first)."""
    axes: dict[str, list[float]] = {}
    for text in texts:
        name, values = parse_axis(text, aircraft)
        if name in axes:
            raise ValueError(f"axis {name} given twice: give all its values in one --axis {name}=V1,V2,...")
        axes[name] = values
    return axes


def grid(axes: dict[str, list[float]]) -> list[dict[str, float]]:
    """Every combination of the axes' values, in the order given (the last axis varies fastest)."""
    names = list(axes)
    return [dict(zip(names, combo)) for combo in itertools.product(*(axes[n] for n in names))]


def condition_config(condition: dict[str, float], base: CoreConfig | None = None, aircraft: str | None = None) -> TaskConfig:
    """The task of one condition: the training setting (on ``aircraft``, the paper's by default)
    with each axis applied."""
    core = base or CoreConfig(aircraft=aircraft or AIRCRAFT_NAME)
    for name, value in condition.items():
        core = AXES[name](core, float(value))
    return TaskConfig(core=core)


@dataclass(frozen=True)
class Job:
    """Episodes ``first .. first + count - 1`` of one controller under one condition."""

    controller: str
    condition: dict
    first: int
    count: int
    aircraft: str = AIRCRAFT_NAME  # the aircraft flown (``aircraft.load_aircraft``)
    transfer: bool = False  # fly a policy on an aircraft it was not trained on


def run_job(job: Job, policy: str | None = None) -> list[dict]:
    """Fly a job's episodes; one row per episode (the table's schema: ``ROW_FIELDS``)."""
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.sim.trim_table import TrimTable
    from training.evaluation.suite import fly

    TrimTable.forget_shared()  # the job's numbers must not depend on what this process flew before
    controller = make_controller(job.controller, policy, aircraft=job.aircraft, transfer=job.transfer)
    batch = AttitudeTaskBatch(1, condition_config(job.condition, aircraft=job.aircraft))
    rows = []
    for k in range(job.first, job.first + job.count):
        rec, end = fly(controller, batch, seed=SWEEP_EPISODE_SEED + k, steps=batch.config.core.max_steps)
        metrics = rec.tracking_metrics()
        a = rec.arrays()
        tail = a["time_s"] >= a["time_s"][-1] - 2.0  # the episode's last 2 s
        err = np.degrees(np.abs(a["true_state"][tail][:, 1:3] - a["goal"][tail][:, :2]))
        rows.append({
            "controller": job.controller, **{f"axis_{n}": v for n, v in job.condition.items()}, "episode": k,
            "return_norm": end["return"] / batch.config.core.max_steps, "ended_early": bool(end["terminated"]),
            "end_reason": end["reason"], "steps": end["steps"],
            **{k2: metrics[k2] for k2 in ("rmse_roll_deg", "rmse_pitch_deg", "rmse_airspeed_eas_mps", "rmse_beta_deg")},
            "final_error_roll_deg": float(err[:, 0].mean()), "final_error_pitch_deg": float(err[:, 1].mean()),
            **{k2: metrics[k2] for k2 in metrics if k2.startswith("smoothness_")},
        })
    return rows


def jobs_for(controllers: Iterable[str], conditions: list[dict], episodes: int, chunk: int = 5,
             aircraft: str = AIRCRAFT_NAME, transfer: bool = False) -> list[Job]:
    """The work on ``aircraft``, cut into jobs of at most ``chunk`` episodes. Refuses (``ValueError``)
    episodes whose seeds reach into the benchmark's frozen test set (``training.evaluation.seeds``)."""
    check_not_test_seed(range(SWEEP_EPISODE_SEED, SWEEP_EPISODE_SEED + episodes), "sweep")
    return [Job(c, cond, first, min(chunk, episodes - first), str(aircraft), transfer)
            for c in controllers for cond in conditions for first in range(0, episodes, chunk)]


def run_local(jobs: list, policy: str | None = None, workers: int = 1, progress=None,
              run: Callable[..., list[dict]] = run_job) -> list[dict]:
    """Run ``jobs`` in ``workers`` processes (1: in this one; more: fresh processes of one torch
    thread each, stopped on Ctrl-C, ``training.workers``); rows in job order. ``run(job, policy)``
    flies one job (a module-level function, so that it pickles): ``run_job`` for the sweep's. The
    processes are at most the jobs and the cores (``training.workers.pool_size``)."""
    from training.workers import pool_size, process_pool

    if pool_size(workers, len(jobs)) <= 1:
        out = []
        for job in jobs:
            out += run(job, policy)
            if progress is not None:
                progress(1)
        return out
    from concurrent.futures import as_completed

    results: list[list[dict]] = [[] for _ in jobs]
    with process_pool(workers, jobs=len(jobs)) as pool:
        futures = {pool.submit(run, job, policy): i for i, job in enumerate(jobs)}
        for future in as_completed(futures):
            results[futures[future]] = future.result()
            if progress is not None:
                progress(1)
    return [row for rows in results for row in rows]


def run_ray(jobs: list, policy: str | None = None, address: str | None = None, progress=None,
            info: dict | None = None, run: Callable[..., list[dict]] = run_job) -> list[dict]:
    """Run ``jobs`` as Ray tasks: a local Ray instance (started and shut down here) unless
    ``address`` names a cluster (``"auto"``: the one this machine belongs to). ``info``, where
    given, receives the cluster's CPUs (``"cpus"``). ``run``: as for ``run_local``."""
    with ray_session(address) as ray:
        if info is not None:
            info["cpus"] = float(ray.cluster_resources().get("CPU", 1.0))
        task = ray.remote(num_cpus=1)(run)
        refs = [task.remote(job, policy) for job in jobs]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[list[dict]] = [[] for _ in jobs]
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            results[index[done[0]]] = ray.get(done[0])
            if progress is not None:
                progress(1)
        return [row for rows in results for row in rows]


def breaking_points(rows: list[dict], axis: str) -> dict[str, float | None]:
    """Per controller, the smallest value of ``axis`` at which an episode ended early (None: never)."""
    out: dict[str, float | None] = {}
    for row in rows:
        out.setdefault(row["controller"], None)
    for row in rows:
        if row["ended_early"]:
            v, c = row[f"axis_{axis}"], row["controller"]
            out[c] = v if out[c] is None else min(out[c], v)
    return out


__all__ = ["AXES", "AXIS_RANGES", "AXIS_UNITS", "AxisRange", "Job", "breaking_points", "condition_config", "grid",
           "jobs_for", "parse_axes", "parse_axis", "run_job", "run_local", "run_ray"]

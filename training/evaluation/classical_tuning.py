"""Tuning the classical controllers on nonlinear flights, with the budget stated: CMA-ES (the ``cma``
package, ``pip install '.[tune]'``) over a few multipliers of the PID's gains or of the LQI's
Bryson weights, scored by the held-out flights' score, the one the learned policy's selection uses.

| controller | parameters (x = 0: the shipped design) |
|---|---|
| PID (``pid_gains.json``) | log multipliers of the gain groups pitch, pitch integral, roll, roll integral, yaw damper, sideslip; rate damping (pitch rate, roll rate) added as ``RATE_TAU_S`` max(x, 0) seconds of the attitude gain, so it may grow from the shipped ~0 |
| LQI (``lqi_gains.json``'s weights) | log multipliers of Bryson's acceptable sizes: pitch, pitch rate, speed and alpha, the longitudinal integrators, the longitudinal inputs, roll, roll and yaw rates, sideslip, the lateral integrators, the lateral inputs; the gains redesigned (``lqi.gain_table``) for every candidate |

A multiplier moves its gains (or sizes) alike at every design altitude, so the schedule keeps its
altitude shape; the PID's speed loop and trims (which TECS and the training task read) are kept.

The score of a candidate is ``heldout.relative_score`` of its ``heldout.heldout_scores`` on the
held-out flights (``heldout.heldout_flights``: turbulence at 5 km, the paper's Table 9 aircraft at
3 km, calm at 15 km; the nonlinear simulation with its one control step of delay and sensor noise)
against the shipped PID's, flown once per tuning: the geometric mean of the candidate's errors over
the PID's, infinite where a flight ends early or a surface chatters. A candidate whose design fails
the linear robustness cases (``tuning``: stable with every gain doubled and with two more steps of
delay, at every design altitude) scores infinite without flying. CMA-ES is told a large finite
penalty in place of infinity.

The budget is counted in evaluations: one evaluation flies the held-out flights once (four flights
of ``heldout`` duration each). Beside the ``budget`` candidates, each tuning flies the shipped PID
once (the reference) and the start point once; the gain file records all of them, the flights,
the wall-clock time and the cores (``budget_record``).

The flights' seeds are ``heldout.SEEDS``; every tuning checks them against the frozen test set
(``seeds.check_not_test_seed``) before it flies, so no gain is ever chosen on the benchmark's flights.

With ``flights="robust"``, the flights are the robust ones (``heldout.heldout_flights``: the same
four in conditions drawn from the training episodes' distribution, on seeds of their own): the
classical controller then has the information the policy trains on. The tuned tables are flown as
``pid_robust`` and ``lqi_robust``; the nominal-tuned ones stay. With ``flights="stressed"`` (the
LQI's only), the held-out four and the turbulent one again at the benchmark's stressed delay and
servo rate: a candidate that ends either early is rejected, so the LQI keeps the margin a slow
control loop asks for (flown as ``lqi_stressed``, the base of ``SolarUAVAttitude-v9``'s residual).

Another aircraft is tuned the same way from its own tables (``gain_files``: the PID's and the LQI's
that its build designed), on the held-out flights moved into its envelope.
"""

from __future__ import annotations

import copy
import json
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from aircraft import load_aircraft
from jsbsim_env.control import gain_files, lqi, tuning
from jsbsim_env.control.pid import GainSchedule, PIDAttitudeController
from training.evaluation import heldout
from training.evaluation.seeds import check_not_test_seed
from training.runtime import available_cores
from training.workers import optional_pool

TOOL = "tune_classical"
CONTROLLERS = ("pid", "lqi")
LOG_BOUND = 3.0  # multipliers within e^-3 to e^3 (1/20 to 20)
RATE_TAU_S = 0.5  # added rate damping per unit of its parameter: seconds of the attitude gain
RATE_BOUNDS = (-1.0, 4.0)  # so up to 2 s of rate damping; below 0, none added
SIGMA0 = 0.5  # CMA-ES's first step size, in the parameters' units
STABLE_RADIUS = lqi.STABLE_RADIUS  # the robustness cases' bound on the spectral radius (as tuning.tune's)
PENALTY = 1e6  # what CMA-ES is told of an infinite score (with the worst radius added, below)


class NotRobust(ValueError):
    """A candidate whose design fails the linear robustness cases; ``radius``: its worst spectral
    radius where known (1 otherwise)."""

    def __init__(self, message: str, radius: float = 1.0):
        super().__init__(message)
        self.radius = radius if math.isfinite(radius) else 10.0


@dataclass(frozen=True)
class Parameter:
    """One coordinate of the search: a log multiplier of ``targets`` (PID gains or Bryson sizes by
    index), or with ``rate_of`` the added rate damping in units of ``RATE_TAU_S`` of that gain."""

    name: str
    targets: tuple
    low: float = -LOG_BOUND
    high: float = LOG_BOUND
    rate_of: str | None = None
    block: str = ""  # LQI: "long" or "lat"
    kind: str = ""  # LQI: "state" or "input"


PID_PARAMETERS = (
    Parameter("pitch", ("k_pitch",)),
    Parameter("pitch_rate", ("k_q",), *RATE_BOUNDS, rate_of="k_pitch"),
    Parameter("pitch_integral", ("k_pitch_i",)),
    Parameter("roll", ("k_roll",)),
    Parameter("roll_rate", ("k_p",), *RATE_BOUNDS, rate_of="k_roll"),
    Parameter("roll_integral", ("k_roll_i",)),
    Parameter("yaw_damper", ("k_r",)),
    Parameter("sideslip", ("k_beta",)),
)
# Indices into lqi's LONG_MAX_STATE / LAT_MAX_STATE and the MAX_INPUTs (its docstring lists them).
LQI_PARAMETERS = (
    Parameter("pitch", (2,), block="long", kind="state"),
    Parameter("pitch_rate", (3,), block="long", kind="state"),
    Parameter("speed_alpha", (0, 1), block="long", kind="state"),
    Parameter("long_integrators", (8, 9), block="long", kind="state"),
    Parameter("long_inputs", (0, 1), block="long", kind="input"),
    Parameter("roll", (1,), block="lat", kind="state"),
    Parameter("lateral_rates", (2, 3), block="lat", kind="state"),
    Parameter("sideslip", (0,), block="lat", kind="state"),
    Parameter("lat_integrators", (8, 9), block="lat", kind="state"),
    Parameter("lat_inputs", (0, 1), block="lat", kind="input"),
)


# ---------------------------------------------------------------------------------- the flights and their seeds
def refuse_test_seeds(seeds, tool: str = TOOL) -> None:
    """``seeds.check_not_test_seed`` for the tuning: a seed in the frozen test set raises
    ``ValueError`` naming ``tool``."""
    check_not_test_seed(seeds, tool)


def tuning_flights(quick: bool = False, aircraft=None, flights: str = "heldout") -> dict:
    """The held-out flights (``heldout.heldout_flights``, the set ``flights``) the tuning
    scores on, their seeds checked against the frozen test set; a test seed raises ``ValueError``
    naming the tool."""
    try:
        chosen = heldout.heldout_flights(quick, aircraft, flights)
    except ValueError as err:
        raise ValueError(f"{TOOL}: {err}") from None
    refuse_test_seeds([config.seed for config in chosen.values()])
    return chosen


# ---------------------------------------------------------------------------------- candidates
def _check_x(parameters: Sequence[Parameter], x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.shape != (len(parameters),) or not np.all(np.isfinite(x)):
        raise ValueError(f"{TOOL}: a candidate needs {len(parameters)} finite parameters, got {x.tolist()}")
    return x


def pid_table(base: dict, x) -> dict:
    """The PID gain table of parameters ``x`` (``PID_PARAMETERS``) on ``base`` (a
    ``pid_gains.json`` table): x = 0 gives ``base``'s gains exactly."""
    x = _check_x(PID_PARAMETERS, x)
    table = copy.deepcopy(base)
    for point, base_point in zip(table["points"], base["points"]):
        for p, value in zip(PID_PARAMETERS, x):
            for gain in p.targets:
                if p.rate_of is not None:
                    point[gain] = base_point[gain] + RATE_TAU_S * max(float(value), 0.0) * base_point[p.rate_of]
                else:
                    point[gain] = base_point[gain] * math.exp(value)
    return table


def pid_robustness(table: dict, plants: dict) -> float:
    """The largest spectral radius of the PID table's gains over the robustness cases
    (``tuning.LoopDesign.worst_spectral_radius``) at every design altitude's plant."""
    worst = 0.0
    for point in table["points"]:
        plant = plants[point["altitude_m"]]
        for lateral, names in ((False, tuning.LONG_GAIN_NAMES), (True, tuning.LAT_GAIN_NAMES)):
            gains = np.array([point[n] for n in names], dtype=float)
            worst = max(worst, tuning.LoopDesign(plant, lateral).worst_spectral_radius(gains))
    return worst


def lqi_sizes(x) -> dict:
    """Bryson's acceptable sizes of parameters ``x`` (``LQI_PARAMETERS``): the shipped ones
    (``lqi.bryson_sizes``) times exp(x) per group."""
    x = _check_x(LQI_PARAMETERS, x)
    sizes = {k: list(v) for k, v in lqi.bryson_sizes().items()}
    for p, value in zip(LQI_PARAMETERS, x):
        key = f"{p.block}_max_{p.kind}"
        for i in p.targets:
            sizes[key][i] = sizes[key][i] * math.exp(value)
    return {k: tuple(v) for k, v in sizes.items()}


def lqi_robustness(table: dict) -> float:
    """The largest spectral radius an LQI table records over its blocks and robustness cases."""
    return max(v for point in table["points"] for block in point["margins"].values()
               for k, v in block.items() if k != "r_factor")


class Problem:
    """One controller's search: its parameters, its design from a parameter vector (``design``:
    the gain table, or ``NotRobust``), and the controller a table flies as; on ``aircraft`` (the
    paper's by default), from its designed tables (``gain_files``)."""

    def __init__(self, controller: str, aircraft=None):
        if controller not in CONTROLLERS:
            raise ValueError(f"{TOOL}: controller must be one of {', '.join(CONTROLLERS)}, got {controller!r}")
        from jsbsim_env.sim.simulation import Simulation

        self.controller = controller
        self.parameters = PID_PARAMETERS if controller == "pid" else LQI_PARAMETERS
        self.sim = Simulation(aircraft)
        if controller == "pid":
            self.base = json.loads(gain_files.gain_file("pid", aircraft).read_text())
            self.plants = {p["altitude_m"]: tuning.LinearPlant.at(self.sim, p["altitude_m"], self.base["design_eas_mps"])
                           for p in self.base["points"]}
            self.altitudes_m = tuple(self.plants)
        else:
            designed = json.loads(gain_files.gain_file("lqi", aircraft).read_text())
            self.altitudes_m = tuple(float(p["altitude_m"]) for p in designed["points"])
            self.design_eas_mps = float(designed.get("design_eas_mps", lqi.DESIGN_EAS_MPS))

    @property
    def x0(self) -> np.ndarray:
        return np.zeros(len(self.parameters))

    @property
    def bounds(self) -> tuple[list[float], list[float]]:
        return [p.low for p in self.parameters], [p.high for p in self.parameters]

    def design(self, x) -> dict:
        """The gain table of ``x`` with its worst robustness radius (``"robustness_radius"``);
        ``NotRobust`` where the robustness cases fail."""
        if self.controller == "pid":
            table = pid_table(self.base, x)
            radius = pid_robustness(table, self.plants)
            if not radius < STABLE_RADIUS:
                raise NotRobust(f"worst spectral radius {radius:.4f} (gain x2, +2 delay steps) is not below "
                                f"{STABLE_RADIUS}", radius)
            table["method"] = "training.evaluation.classical_tuning (CMA-ES on the held-out flights) from pid_gains.json"
        else:
            try:
                table = lqi.gain_table(self.sim, self.altitudes_m, sizes=lqi_sizes(x), detune=False,
                                       eas_mps=self.design_eas_mps)
            except lqi.RobustnessError as err:
                raise NotRobust(str(err)) from None
            radius = lqi_robustness(table)
            table["method"] = ("training.evaluation.classical_tuning (CMA-ES on the held-out flights), "
                               "jsbsim_env.control.lqi's design")
        table["robustness_radius"] = radius
        return table


def controller_from_table(controller: str, table: dict, aircraft=None):
    """A fresh PID or LQI that flies the gain table ``table`` on ``aircraft`` (its command range)."""
    if controller == "pid":
        return PIDAttitudeController(GainSchedule.from_table(table, "(candidate)"), aircraft=aircraft)
    return lqi.LQIAttitudeController(lqi.LQIGainSchedule.from_table(table, "(candidate)"), aircraft=aircraft)


def fly_table(controller: str, table: dict, quick: bool, aircraft=None, flights: str = "heldout") -> dict:
    """``heldout.heldout_scores`` of the controller with ``table`` (a process pool's task)."""
    return heldout.heldout_scores(partial(controller_from_table, controller, table, aircraft=aircraft), quick,
                                  aircraft, flights)


def reference_scores(quick: bool, aircraft=None, flights: str = "heldout") -> dict:
    """The designed PID's held-out scores (the shipped one on the paper's aircraft): what every
    candidate's score is relative to."""
    return heldout.heldout_scores(partial(PIDAttitudeController, aircraft=aircraft), quick, aircraft, flights)


@dataclass
class Evaluation:
    x: list[float]
    score: float  # relative_score; inf for a candidate that fails
    reason: str | None  # why it is infinite (robustness, ended early or chatter), None otherwise
    scores: dict | None = None  # heldout_scores, None where not flown
    table: dict | None = None
    penalty: float = PENALTY  # what CMA-ES is told where the score is infinite

    @property
    def told(self) -> float:
        return self.score if math.isfinite(self.score) else self.penalty


class _Runner:
    """Flies tables in this process (``pool`` None) or in a pool of processes (``training.workers``)."""

    def __init__(self, pool: ProcessPoolExecutor | None = None):
        self.pool = pool

    def map(self, fn: Callable, items: list) -> list:
        if self.pool is None:
            return [fn(*item) for item in items]
        return list(self.pool.map(fn, *zip(*items))) if items else []


def evaluate_candidates(problem: Problem, xs: Sequence, reference: dict, quick: bool = False,
                        runner: _Runner | None = None, aircraft=None, flights: str = "heldout") -> list[Evaluation]:
    """Each candidate's score: its design checked for robustness (infinite, unflown, where it fails),
    then the held-out flights, relative to ``reference`` (the PID's scores)."""
    runner = runner or _Runner()
    out: list[Evaluation] = []
    to_fly = []
    for x in xs:
        x = [float(v) for v in x]
        try:
            table = problem.design(x)
        except NotRobust as err:
            out.append(Evaluation(x, math.inf, f"not robust: {err}", penalty=PENALTY * (1.0 + err.radius)))
            continue
        out.append(Evaluation(x, math.nan, None, table=table))
        to_fly.append(len(out) - 1)
    flown = runner.map(fly_table, [(problem.controller, out[i].table, quick, aircraft, flights) for i in to_fly])
    for i, scores in zip(to_fly, flown):
        ev = out[i]
        ev.scores = scores
        ev.score = heldout.relative_score(scores, reference)
        if not math.isfinite(ev.score):
            chatter = heldout.chattering_surfaces(scores, reference)
            ev.reason = "ended a flight early" if scores["ended_early"] else f"surfaces chatter: {chatter}"
            ev.penalty = PENALTY / 10.0
    return out


# ---------------------------------------------------------------------------------- the search
def default_popsize(n: int) -> int:
    """CMA-ES's default population for ``n`` parameters."""
    return 4 + int(3 * math.log(n))


def tune(controller: str, budget: int, seed: int = 0, workers: int = 1, quick: bool = False,
         progress: Callable[[str], None] | None = None, aircraft: str | None = None, flights: str = "heldout") -> dict:
    """CMA-ES over ``controller``'s parameters with ``budget`` candidate evaluations (generations of
    ``min(default_popsize, budget)`` candidates: up to ``budget``, none beyond), from the shipped
    design; returns the best candidate's gain table with its ``"tuning"`` record (the budget used,
    the scores, every evaluation's score). ``seed`` seeds CMA-ES (as ``seed + 1``: cma reads 0 as
    "from the clock"). ``aircraft``: a packaged aircraft's name or a built aircraft's folder (the
    paper's by default). ``flights``: the set flown (``heldout.FLIGHT_SETS``, module docstring). Refuses flights on the
    frozen test set before any work."""
    flown_flights = tuning_flights(quick, aircraft, flights)  # before anything else, even the optimiser's import
    import cma

    if budget < 2:
        raise ValueError(f"{TOOL}: the budget must be at least 2 evaluations (one CMA-ES generation), got {budget}")
    if workers < 1:
        raise ValueError(f"{TOOL}: workers must be at least 1, got {workers}")
    say = progress or (lambda text: None)
    started = time.perf_counter()
    problem = Problem(controller, aircraft)
    n = len(problem.parameters)
    popsize = max(2, min(default_popsize(n), budget))
    generations = budget // popsize
    unspent = budget - generations * popsize
    say(f"budget {budget}: {generations} CMA-ES generation{'s' if generations != 1 else ''} of {popsize} candidates, "
        f"{generations * popsize} in all" + (f" ({unspent} left unspent: CMA-ES flies whole generations)" if unspent
                                             else ""))
    with optional_pool(workers) as pool:
        runner = _Runner(pool)
        reference = reference_scores(quick, aircraft, flights)
        say(f"reference (the shipped PID) flown: {time.perf_counter() - started:.1f} s")
        start = evaluate_candidates(problem, [problem.x0], reference, quick, runner, aircraft, flights)[0]
        if not math.isfinite(start.score):
            raise RuntimeError(f"{TOOL}: the shipped {controller.upper()} design scores infinite ({start.reason})")
        say(f"start (the shipped {controller.upper()}): score {start.score:.4f}")
        lows, highs = problem.bounds
        es = cma.CMAEvolutionStrategy(problem.x0.tolist(), SIGMA0, {
            "bounds": [lows, highs], "popsize": popsize, "seed": seed + 1, "maxfevals": budget,
            "verbose": -9, "verb_disp": 0, "verb_log": 0, "tolflatfitness": budget})
        history: list[Evaluation] = []
        best = start
        stop_reason = None
        for g in range(generations):
            xs = es.ask()
            evals = evaluate_candidates(problem, xs, reference, quick, runner, aircraft, flights)
            es.tell(xs, [e.told for e in evals])
            history.extend(evals)
            for e in evals:
                if e.score < best.score:
                    best = e
            failed = sum(not math.isfinite(e.score) for e in evals)
            say(f"generation {g + 1}/{generations}: best of generation {min(e.score for e in evals):.4f}, "
                f"best so far {best.score:.4f}, {failed} of {len(evals)} infinite, "
                f"{time.perf_counter() - started:.0f} s")
            if es.stop():
                stop_reason = {k: (v if isinstance(v, (int, float, str)) else str(v)) for k, v in es.stop().items()}
                break
    wall_s = time.perf_counter() - started
    table = {k: v for k, v in best.table.items()}
    flight_s = sum(c.duration_s for c in flown_flights.values())
    flown = load_aircraft(aircraft)
    table["tuning"] = {
        "controller": controller,
        "aircraft": flown.name, "aircraft_model": flown.fingerprint,
        "optimiser": f"CMA-ES (cma {cma.__version__}), sigma0 {SIGMA0}, population {popsize}, bounds as parameters",
        "seed": seed,
        "parameters": {p.name: {"value": v, "low": p.low, "high": p.high,
                                "meaning": ("added rate damping, RATE_TAU_S max(x, 0) s of " + p.rate_of
                                            if p.rate_of else "log multiplier")}
                       for p, v in zip(problem.parameters, best.x)},
        "rate_tau_s": RATE_TAU_S,
        "score": best.score, "start_score": start.score,
        "best_is_start": best is start,
        "flights": flights,
        "score_definition": ("training.evaluation.heldout.relative_score against the shipped PID (pid_gains.json)"
                             + (f", on the {flights} flights (heldout.heldout_flights(flights={flights!r}))"
                                if flights != "heldout" else "")),
        "scores": best.scores, "start_scores": start.scores, "reference_scores": reference,
        "budget": budget_record(budget, history, generations, popsize, flown_flights, flight_s, wall_s, workers,
                                quick, stop_reason),
        "history": [{"x": e.x, "score": e.score, "reason": e.reason} for e in history],
    }
    return table


def budget_record(budget: int, history: list[Evaluation], generations: int, popsize: int, flights: dict,
                  flight_s: float, wall_s: float, workers: int, quick: bool, stop_reason: dict | None) -> dict:
    """The tuning's budget as spent, for the gain file: candidates asked for (``candidate_evaluations``,
    what ``--budget`` bounds) and flown (those that pass the robustness cases), and the two more
    evaluations every tuning flies."""
    flown = sum(e.scores is not None for e in history) + 2
    return {
        "budget_evaluations": budget,
        "candidate_evaluations": len(history),
        "candidates_not_robust": sum(e.scores is None for e in history),
        "extra_evaluations": {"reference (shipped PID)": 1, "start point": 1},
        "evaluations_flown": flown,
        "generations": generations, "population": popsize,
        "flights_per_evaluation": len(flights),
        "flights": {name: {"altitude_m": c.altitude_m, "seed": c.seed, "duration_s": c.duration_s,
                           "parameters": c.parameters, "turbulence_legs": list(c.turbulence_legs),
                           "delay_s": c.delay_s, **({"stress": dict(c.stress)} if getattr(c, "stress", ()) else {})}
                    for name, c in flights.items()},
        "simulated_s_per_evaluation": flight_s,
        "quick": quick,
        "wall_clock_s": round(wall_s, 1),
        "wall_clock_s_per_evaluation_flown": round(wall_s / flown, 2),
        "workers": workers, "cores_available": available_cores(),
        "stopped_early": stop_reason,
    }


def write_tuned_table(table: dict, path: Path | str) -> Path:
    """Write a tuned gain table as JSON (through a temporary file); refuses the shipped tables,
    which stay as they are."""
    path = Path(path)
    shipped = {gain_files.gain_file_path(kind).resolve() for kind in ("pid", "lqi")}
    if path.resolve() in shipped:
        raise ValueError(f"{TOOL}: {path} is a shipped gain table, which tuning never replaces: give another file")
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(table, indent=1))  # inf as Infinity, which json reads back
    tmp.replace(path)
    return path


__all__ = ["CONTROLLERS", "LQI_PARAMETERS", "PID_PARAMETERS", "NotRobust", "Problem", "controller_from_table",
           "evaluate_candidates", "lqi_sizes", "pid_table", "refuse_test_seeds", "tune", "tuning_flights",
           "write_tuned_table"]

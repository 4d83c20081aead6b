"""The paper's experiments (the paper's Section 5) as one report: ``report.md``, a PNG per
figure and ``metrics.json``.

| item | experiment | figures |
|---|---|---|
| 2 | doublets at 500, 5,000 and 15,000 m, no delay or perturbation (trained policy) | Fig. 9 |
| 3 | actuator effectiveness against altitude at EAS 10 m/s | Fig. 10 |
| 4 | 10 km rectangular route, TECS + L1 feeding the policy, turbulence on one leg | Figs. 11-13 |
| 5 | the same route with the gain-scheduled PID; Table 8 on the turbulent leg, same seeds | Fig. 14, Table 8 |
| 6 | the route with the Table 9 "positive" and "negative" aircraft, no retraining | Figs. 15-16 |
| 7 | the route at 1 km and 20 km (calm air), steady-state errors | Figs. 17-18 |
| 8 | the route with an ideal servo and with 0.3 deg of backlash | Figs. 19-20 |

Every flight goes through the same flight core with fixed seeds, so two runs of the report give
the same numbers. Without a trained policy (none shipped and no ``policy_path``) the PID parts
run and the policy's rows say so.

Another aircraft (``aircraft``) flies the same experiments where its envelope puts them: each
altitude at the same fraction of its altitude range (``Aircraft.altitude_like_m``: 10 km is the
middle), at its reference EAS, with turbulence on the leg it flies at the same share of the route's
time as the paper's ninth leg; the tables then leave out the paper's figures, which are its
aircraft's, and keep the paper's experiment names ("1km" is 5 % up the envelope).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np

import aircraft
from jsbsim_env.analysis.effectiveness import effectiveness, plot_effectiveness
from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.missions import MissionResult, RouteConfig, fly_route

REPORT_SEED = 2023
EXPERIMENTS = ("doublets", "effectiveness", "route_10km", "perturbation", "altitudes", "backlash")
CONTROLLERS = ("PID", "RL")  # flown by default
EXTRA_CONTROLLERS = ("LQI", "PID_tuned", "LQI_tuned", "PID_robust", "LQI_robust", "LQI_stressed")  # flown when named (factory: lower case)
ROUTE_SEED = 11

# The paper's figures (the paper's Section 5), for the tables.
PAPER_TABLE8 = {
    "PID": {"rmse_roll_deg": 0.125, "rmse_pitch_deg": 0.193, "rmse_airspeed_eas_mps": 0.393, "rmse_beta_deg": 2.915,
            "smoothness_aileron": 9.50e-5, "smoothness_elevator": 4.48e-5, "smoothness_rudder": 0.0,
            "smoothness_throttle": 1.12e-5},
    "RL": {"rmse_roll_deg": 0.073, "rmse_pitch_deg": 0.084, "rmse_airspeed_eas_mps": 0.448, "rmse_beta_deg": 0.956,
           "smoothness_aileron": 3.03e-5, "smoothness_elevator": 6.63e-5, "smoothness_rudder": 1.05e-5,
           "smoothness_throttle": 1.27e-5},
}
PAPER_LEVEL_MAE = {"mae_roll_deg": 0.046, "mae_pitch_deg": 0.053, "mae_beta_deg": 0.3}
PAPER_STEADY_STATE = {"1km": {"roll_deg": 0.03, "pitch_deg": 0.02}, "20km": {"roll_deg": 0.04, "pitch_deg": 0.03}}


@dataclass(frozen=True)
class ReportPlan:
    """Durations and windows of the experiments (s); ``quick`` shrinks them for tests."""

    route_10km_s: float = 2400.0
    turbulence_leg: int = 8  # at 10 km the ninth leg spans about 1930-2250 s (the paper: 1900-2300 s)
    level_window_s: tuple[float, float] = (1000.0, 1500.0)
    route_other_s: float = 1200.0
    perturbation_s: float = 1200.0
    backlash_s: float = 900.0
    backlash_window_s: tuple[float, float] = (100.0, 300.0)
    doublet_altitudes_m: tuple[float, ...] = (500.0, 5000.0, 15000.0)
    effectiveness_altitudes_m: tuple[float, ...] = tuple(float(h) for h in range(0, 20001, 2000))
    steady_after_leg_change_s: float = 60.0

    @classmethod
    def quick(cls) -> ReportPlan:
        return cls(route_10km_s=40.0, turbulence_leg=0, level_window_s=(10.0, 40.0), route_other_s=20.0,
                   perturbation_s=20.0, backlash_s=20.0, backlash_window_s=(5.0, 20.0), doublet_altitudes_m=(5000.0,),
                   effectiveness_altitudes_m=(0.0, 20000.0), steady_after_leg_change_s=5.0)


def _controllers(policy_path, aircraft=None, transfer: bool = False) -> tuple[dict[str, Callable[[], object]], Path | None]:
    """Factories of the attitude controllers to compare on ``aircraft``, the policy only when one is
    available; and the policy file (None without one)."""
    from jsbsim_env.control.factory import make_controller

    makers: dict[str, Callable[[], object]] = {"PID": partial(PIDAttitudeController, aircraft=aircraft)}
    # Each extra controller is the factory's of the same name in lower case ("LQI_tuned": "lqi_tuned").
    makers.update({name: partial(make_controller, name.lower(), aircraft=aircraft) for name in EXTRA_CONTROLLERS})
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    path = Path(policy_path) if policy_path is not None else shipped_policy_path()
    if path.exists():
        makers["RL"] = lambda: make_controller("policy", path, aircraft=aircraft, transfer=transfer)
        return makers, path
    if policy_path is not None:
        raise PolicyFileError(f"policy file {path} does not exist")
    return makers, None


def policy_provenance(path: Path, flown: aircraft.Aircraft | None = None) -> dict[str, str | None]:
    """The policy file, the aircraft model it was trained on and the one the report flies
    (``aircraft.model_fingerprint``; the paper's aircraft's when ``flown`` is None)."""
    from jsbsim_env.control.policy import load_policy
    from training.provenance import trained_aircraft_model

    trained = load_policy(path)[1].get("aircraft_model") or trained_aircraft_model(path)
    return {"path": str(path), "trained_on_aircraft_model": trained,
            "flown_aircraft_model": (flown or aircraft.load_aircraft()).fingerprint}


def leg_in_progress(config: RouteConfig, time_s: float) -> int:
    """The leg (0: the first flown) a route flight is on at ``time_s`` in still air, flown at the
    true airspeed of its EAS in the standard atmosphere, the turns ignored."""
    from jsbsim_env.missions import standard_density_kg_m3

    wp = config.waypoints()
    tas = config.eas_mps * math.sqrt(1.225 / standard_density_kg_m3(config.altitude_m))
    lengths = np.hypot(*(np.roll(wp, -1, axis=0) - wp).T)
    elapsed, leg = 0.0, 0
    while elapsed + lengths[leg % len(wp)] / tas <= time_s:
        elapsed += lengths[leg % len(wp)] / tas
        leg += 1
    return leg


def _provenance_line(policy: dict) -> str:
    trained, flown = policy["trained_on_aircraft_model"], policy["flown_aircraft_model"]
    start = f"The RL rows fly `{policy['path']}`"
    if trained is None:
        return f"{start}, whose record names no aircraft model; this report flies aircraft model `{flown[:12]}`."
    if trained == flown:
        return f"{start}, trained on the aircraft model this report flies (`{flown[:12]}`)."
    return (f"{start}, trained on aircraft model `{trained[:12]}`, not on the one this report flies "
            f"(`{flown[:12]}`): its rows show it on an aircraft it was not trained on.")


def steady_mask(result: MissionResult, after_s: float) -> np.ndarray:
    """Samples on a leg at least ``after_s`` after the leg began (out of the corners); where the
    route's rectangle has grown with the turn radius (``RouteConfig.rectangle_scale``, above
    10 km), that much later as the turns take longer: their time goes with the true airspeed,
    the square root of the scale (at 20 km 2.2 times, a 90 deg turn at the roll limit 68 s)."""
    after_s *= math.sqrt(result.config.rectangle_scale())
    a = result.arrays
    t, leg = a["time_s"], a["leg"]
    starts = np.zeros_like(t)
    for k in range(1, t.size):
        starts[k] = t[k] if leg[k] != leg[k - 1] else starts[k - 1]
    return (t - starts) >= after_s


def turbulence_span(result: MissionResult) -> tuple[float, float] | None:
    """First and last time (s) the flight spent in turbulence; None where it never met any."""
    t = result.arrays["time_s"][result.arrays["turbulence"] > 0]
    return (float(t[0]), float(t[-1])) if t.size else None


def turbulent_metrics(result: MissionResult) -> dict[str, float] | None:
    """``result.metrics`` from the first to the last turbulent sample (the corners between
    turbulent legs included); None where the flight met no turbulence."""
    span = turbulence_span(result)
    return result.metrics(span[0], span[1] + 1e-9) if span else None


def steady_state_errors(result: MissionResult, after_s: float) -> dict[str, float]:
    """Mean absolute roll and pitch error (deg) on the straight parts of the route."""
    a, m = result.arrays, steady_mask(result, after_s)
    if not np.any(m):
        return {"roll_deg": math.nan, "pitch_deg": math.nan}
    return {"roll_deg": float(np.mean(np.abs(np.degrees(a["roll_rad"][m] - a["roll_cmd_rad"][m])))),
            "pitch_deg": float(np.mean(np.abs(np.degrees(a["pitch_rad"][m] - a["pitch_cmd_rad"][m]))))}


def window_metrics(result: MissionResult, start_s: float, end_s: float, only: np.ndarray | None = None) -> dict[str, float]:
    """``result.metrics`` over a window (where ``only``, if given), or the same keys as NaN where the
    flight ended before it: the report must describe a controller that crashes, not stop at it."""
    w = result.window(start_s, end_s)
    if (w if only is None else w & only).any():
        return result.metrics(start_s, end_s, only)
    return dict.fromkeys(result.metrics(), math.nan)


def _summary(result: MissionResult) -> dict:
    return {"ended_early": result.ended_early, "duration_s": float(result.arrays["time_s"][-1]) if
            result.arrays["time_s"].size else 0.0, "whole_route": result.metrics()}


# ---------------------------------------------------------------------------------------------- plots
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_route(result: MissionResult, path: Path, title: str) -> None:
    """Figs. 11 and 17-18: the path, the altitude and the attitude against its demands."""
    plt = _plt()
    a = result.arrays
    t = a["time_s"]
    fig = plt.figure(figsize=(12, 8))
    ax = fig.add_subplot(2, 2, 1)
    ax.plot(a["east_m"] / 1000, a["north_m"] / 1000)
    wp = np.vstack([result.config.waypoints(), result.config.waypoints()[:1]])
    ax.plot(wp[:, 1] / 1000, wp[:, 0] / 1000, "k--", lw=0.8, label="route")
    ax.set_xlabel("east, km")
    ax.set_ylabel("north, km")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax = fig.add_subplot(2, 2, 2)
    ax.plot(t, a["altitude_m"])
    ax.axhline(result.config.altitude_m, color="k", ls="--", lw=0.8)
    ax.set_ylabel("altitude, m")
    for i, (name, cmd, label) in enumerate((("roll_rad", "roll_cmd_rad", "roll, deg"),
                                            ("pitch_rad", "pitch_cmd_rad", "pitch, deg"))):
        ax = fig.add_subplot(4, 2, 6 + 2 * i)
        ax.plot(t, np.degrees(a[name]), label="aircraft")
        ax.plot(t, np.degrees(a[cmd]), "k--", lw=0.8, label="command")
        ax.set_ylabel(label)
        ax.legend(fontsize=7, loc="upper right")
    ax = fig.add_subplot(4, 2, 5)
    ax.plot(t, (np.degrees(a["heading_rad"]) + 180.0) % 360.0 - 180.0, ".", ms=1)
    ax.set_ylabel("heading, deg")
    ax = fig.add_subplot(4, 2, 7)
    ax.plot(t, a["eas_mps"])
    ax.axhline(result.config.eas_mps, color="k", ls="--", lw=0.8)
    ax.set_ylabel("EAS, m/s")
    ax.set_xlabel("time, s")
    for axis in fig.axes:
        axis.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_errors(result: MissionResult, path: Path, title: str, window: tuple[float, float] | None = None) -> None:
    """Figs. 12-16 and 19-20: tracking errors and surface commands (over ``window`` if given)."""
    plt = _plt()
    a = result.arrays
    m = result.window(*window) if window else np.ones(a["time_s"].size, bool)
    t = a["time_s"][m]
    fig, axes = plt.subplots(4, 2, figsize=(12, 8), sharex=True)
    series = (("roll error, deg", np.degrees(a["roll_cmd_rad"] - a["roll_rad"])),
              ("pitch error, deg", np.degrees(a["pitch_cmd_rad"] - a["pitch_rad"])),
              ("EAS error, m/s", a["eas_cmd_mps"] - a["eas_mps"]),
              ("sideslip, deg", np.degrees(a["beta_rad"])))
    for ax, (label, y) in zip(axes[:, 0], series):
        ax.plot(t, y[m])
        ax.set_ylabel(label)
    for j, (ax, label) in enumerate(zip(axes[:, 1], ("aileron, deg", "elevator, deg", "rudder, deg", "throttle"))):
        ax.plot(t, a["command"][m, j], lw=0.8, label="command")
        ax.plot(t, a["actuator"][m, j], lw=0.8, label="position")
        ax.set_ylabel(label)
    axes[0, 1].legend(fontsize=7)
    turbulent = a["turbulence"][m] > 0
    for ax in axes.flat:
        ax.grid(alpha=0.3)
        if turbulent.any() and not turbulent.all():
            ax.fill_between(t, 0, 1, where=turbulent, color="orange", alpha=0.12, transform=ax.get_xaxis_transform())
    for ax in axes[-1]:
        ax.set_xlabel("time, s")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_backlash(results: dict[str, MissionResult], path: Path, window: tuple[float, float]) -> None:
    """Figs. 19-20: pitch and elevator with an ideal servo and with backlash."""
    plt = _plt()
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for label, r in results.items():
        a, m = r.arrays, r.window(*window)
        axes[0].plot(a["time_s"][m], np.degrees(a["pitch_rad"][m]), lw=0.9, label=label)
        axes[1].plot(a["time_s"][m], a["actuator"][m, 1], lw=0.9, label=label)
    a, m = next(iter(results.values())).arrays, next(iter(results.values())).window(*window)
    axes[0].plot(a["time_s"][m], np.degrees(a["pitch_cmd_rad"][m]), "k--", lw=0.8, label="command")
    axes[0].set_ylabel("pitch, deg")
    axes[1].set_ylabel("elevator position, deg")
    axes[1].set_xlabel("time, s")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------- report
def _fmt(x) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if isinstance(x, float) and (abs(x) < 1e-2 and x != 0.0):
        return f"{x:.2e}"
    return f"{x:.3f}" if isinstance(x, float) else str(x)


def run_report(out_dir: Path | str, policy_path: Path | str | None = None, quick: bool = False,
               progress: bool = True, experiments: tuple[str, ...] = EXPERIMENTS,
               controllers: tuple[str, ...] = CONTROLLERS, aircraft_spec: str | None = None,
               transfer: bool = False) -> dict:
    """Run the experiments (all of ``EXPERIMENTS`` unless fewer are named) for the controllers named
    ("PID", "RL" by default; those of ``EXTRA_CONTROLLERS`` when named) on the aircraft
    ``aircraft_spec`` names (the paper's by default; ``transfer`` flies a policy trained on another),
    write ``report.md``, the figures and ``metrics.json``; returns the metrics."""
    known = CONTROLLERS + EXTRA_CONTROLLERS
    unknown = sorted(set(experiments) - set(EXPERIMENTS)) + sorted(set(controllers) - set(known))
    if unknown:
        raise ValueError(f"unknown experiment or controller {unknown}: experiments are {list(EXPERIMENTS)}, "
                         f"controllers {list(known)}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plan = ReportPlan.quick() if quick else ReportPlan()
    flown = aircraft.load_aircraft(aircraft_spec)
    papers = flown.papers  # the paper's figures are its aircraft's
    at = flown.altitude_like_m
    makers, policy_file = _controllers(policy_path, flown.spec, transfer)
    makers = {name: make for name, make in makers.items() if name in controllers}
    names = list(makers)
    base = RouteConfig(aircraft=flown.spec, altitude_m=at(10_000.0), eas_mps=flown.reference_eas_mps,
                       duration_s=plan.route_10km_s, seed=ROUTE_SEED)
    # The paper's ninth leg; another aircraft's leg at the same share of the route's time.
    turbulence_leg = plan.turbulence_leg if papers or quick else leg_in_progress(base, 0.8 * plan.route_10km_s)
    base = replace(base, turbulence_legs=(turbulence_leg,))
    tasks: list[tuple[str, str, Callable[[], None]]] = []  # (experiment, label, task)
    metrics: dict = {"plan": asdict(plan), "controllers": names, "experiments": list(experiments)}
    if papers:
        metrics["paper"] = {"table8": PAPER_TABLE8, "level_mae": PAPER_LEVEL_MAE, "steady_state": PAPER_STEADY_STATE}
    else:
        metrics["aircraft"] = {"name": flown.name, "model": flown.fingerprint, "folder": str(flown.folder),
                               "route_altitude_m": base.altitude_m, "eas_mps": flown.reference_eas_mps,
                               "turbulence_leg": turbulence_leg,
                               "altitudes_m": {"1km": at(1000.0), "20km": at(20000.0)}}
    if policy_file is not None:
        metrics["policy"] = policy_provenance(policy_file, flown)
    routes: dict[tuple[str, str], MissionResult] = {}

    def fly(key: str, name: str, config: RouteConfig) -> MissionResult:
        result = fly_route(makers[name](), config)
        routes[(key, name)] = result
        return result

    # Item 2: doublets (the trained policy).
    def doublets() -> None:
        if "RL" not in makers:
            metrics["doublets"] = "no trained policy"
            return
        from training.evaluation.suite import doublet_runs

        metrics["doublets"] = doublet_runs(makers["RL"](), tuple(at(h) for h in plan.doublet_altitudes_m), out,
                                           prefix="fig09_doublets", aircraft=flown.spec)

    tasks.append(("doublets", "Fig. 9 doublets", doublets))

    def fig10() -> None:
        rows = effectiveness([at(h) for h in plan.effectiveness_altitudes_m], flown.reference_eas_mps, flown.spec)
        plot_effectiveness(rows, out / "fig10_effectiveness.png")
        metrics["effectiveness"] = rows

    tasks.append(("effectiveness", "Fig. 10 effectiveness", fig10))

    # Items 4-5: the 10 km route with turbulence on one leg.
    def route_10km(name: str) -> Callable[[], None]:
        def run() -> None:
            r = fly("route_10km", name, base)
            span = turbulence_span(r)
            entry = _summary(r)
            if span:
                entry["turbulent_leg"] = turbulent_metrics(r)
                # The paper's window holds the turn into the leg; the same leg without it:
                entry["turbulent_leg_straight"] = window_metrics(
                    r, span[0], span[1] + 1e-9, only=steady_mask(r, plan.steady_after_leg_change_s))
            entry["level_window"] = window_metrics(r, *plan.level_window_s)
            # The paper's window is its level flight; on our rectangle a corner falls in it (at
            # about 1344 s), so its straight flight is scored apart, as the steady state is.
            entry["level_flight"] = window_metrics(r, *plan.level_window_s,
                                                   only=steady_mask(r, plan.steady_after_leg_change_s))
            metrics.setdefault("route_10km", {})[name] = entry
            plot_route(r, out / f"fig11_route_10km_{name}.png", f"10 km route, {name}")
            plot_errors(r, out / f"fig12_errors_10km_{name}.png", f"10 km route, {name}: errors and surfaces")
            if span:
                window = (span[0] - 20.0, span[1] + 20.0)
                fig = "fig13" if name == "RL" else "fig14"
                plot_errors(r, out / f"{fig}_turbulence_{name}.png", f"Turbulent leg, {name}", window)

        return run

    for name in names:
        tasks.append(("route_10km", f"10 km route, {name}", route_10km(name)))

    # Item 6: Table 9 aircraft, calm air.
    def perturbation(name: str, parameters: str) -> Callable[[], None]:
        def run() -> None:
            r = fly(f"perturbation_{parameters}", name, replace(base, duration_s=plan.perturbation_s,
                                                                  turbulence_legs=(), parameters=parameters))
            metrics.setdefault("perturbation", {}).setdefault(parameters, {})[name] = _summary(r)
            fig = "fig15" if parameters == "positive" else "fig16"
            plot_errors(r, out / f"{fig}_{parameters}_{name}.png", f"{parameters.capitalize()} aircraft, {name}")

        return run

    for parameters in ("positive", "negative"):
        for name in names:
            tasks.append(("perturbation", f"Table 9 {parameters}, {name}", perturbation(name, parameters)))

    # Item 7: 1 km and 20 km, calm air.
    def altitude_route(name: str, altitude_m: float) -> Callable[[], None]:
        def run() -> None:
            key = f"{altitude_m / 1000:.0f}km"  # the paper's name of the experiment
            r = fly(f"route_{key}", name, replace(base, altitude_m=at(altitude_m), duration_s=plan.route_other_s,
                                                  turbulence_legs=()))
            entry = _summary(r)
            entry["steady_state_error"] = steady_state_errors(r, plan.steady_after_leg_change_s)
            metrics.setdefault("altitudes", {}).setdefault(key, {})[name] = entry
            fig = "fig17" if altitude_m < 10_000 else "fig18"
            plot_route(r, out / f"{fig}_route_{key}_{name}.png", f"{at(altitude_m) / 1000:g} km route, {name}")

        return run

    for altitude_m in (1000.0, 20000.0):
        for name in names:
            tasks.append(("altitudes", f"{altitude_m / 1000:.0f} km route, {name}",
                          altitude_route(name, altitude_m)))

    # Item 8: backlash.
    def backlash(name: str) -> Callable[[], None]:
        def run() -> None:
            pair = {}
            for label, width in (("ideal servo", 0.0), ("backlash 0.3 deg", 0.3)):
                r = fly(f"backlash_{width}", name, replace(base, duration_s=plan.backlash_s, turbulence_legs=(),
                                                            backlash_deg=width))
                pair[label] = r
                w = plan.backlash_window_s
                entry = _summary(r)
                entry["window"] = window_metrics(r, *w)
                m = r.window(*w)
                spread = {"elevator_std_deg": r.arrays["actuator"][m, 1],
                          "pitch_error_std_deg": np.degrees(r.arrays["pitch_rad"][m] - r.arrays["pitch_cmd_rad"][m])}
                for key, values in spread.items():  # NaN where the flight ended before the window
                    entry["window"][key] = float(np.std(values)) if values.size else math.nan
                metrics.setdefault("backlash", {}).setdefault(label, {})[name] = entry
            fig = "fig19" if name == "RL" else "fig20"
            plot_backlash(pair, out / f"{fig}_backlash_{name}.png", plan.backlash_window_s)

        return run

    for name in names:
        tasks.append(("backlash", f"backlash, {name}", backlash(name)))

    tasks = [(label, task) for experiment, label, task in tasks if experiment in experiments]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), desc="report", unit="experiment")
    for label, task in tasks:
        if bar is not None:
            bar.set_postfix_str(label)
        task()
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    (out / "metrics.json").write_text(json.dumps(metrics, indent=1, default=float))
    (out / "report.md").write_text(render_markdown(metrics, out))
    return metrics


def render_markdown(metrics: dict, out: Path) -> str:
    """The report text: tables with the paper's figures beside ours, and the figures."""
    names = metrics["controllers"]
    lines = ["# Solar UAV attitude control: the paper's experiments", ""]
    other = metrics.get("aircraft")
    if other:
        lines += [(f"Flown on `{other['name']}` (`{other['folder']}`, model `{other['model'][:12]}`): the route at "
                   f"{other['route_altitude_m']:g} m and {other['eas_mps']:g} m/s EAS, turbulence on leg "
                   f"{other['turbulence_leg']}; \"1km\" is {other['altitudes_m']['1km']:g} m, \"20km\" "
                   f"{other['altitudes_m']['20km']:g} m. The paper's figures are its aircraft's and are left out."), ""]
    paper8 = PAPER_TABLE8 if not other else {}
    if "RL" not in names:
        lines += ["No trained policy was available: the policy's rows and figures are missing.", ""]
    if "policy" in metrics:
        lines += [_provenance_line(metrics["policy"]), ""]
    figures = sorted(p.name for p in out.glob("fig*.png"))

    lines += ["## Table 8: the turbulent leg of the 10 km route (same seeds)", "",
              ("| controller | source | RMSE roll, deg | RMSE pitch, deg | RMSE EAS, m/s | RMSE sideslip, deg | "
              "Sm aileron | Sm elevator | Sm rudder | Sm throttle |"), "|---|---|---|---|---|---|---|---|---|---|"]
    keys = ("rmse_roll_deg", "rmse_pitch_deg", "rmse_airspeed_eas_mps", "rmse_beta_deg", "smoothness_aileron",
            "smoothness_elevator", "smoothness_rudder", "smoothness_throttle")
    for name in ("PID", "RL", *EXTRA_CONTROLLERS):
        if name in paper8:
            lines.append(f"| {name} | paper | " + " | ".join(_fmt(paper8[name][k]) for k in keys) + " |")
        entry = metrics.get("route_10km", {}).get(name)
        if entry and "turbulent_leg" in entry:
            lines.append(f"| {name} | ours | " + " | ".join(_fmt(entry["turbulent_leg"][k]) for k in keys) + " |")
        if entry and "turbulent_leg_straight" in entry:
            lines.append(f"| {name} | ours, no corner | "
                         + " | ".join(_fmt(entry["turbulent_leg_straight"][k]) for k in keys) + " |")
    after = metrics["plan"]["steady_after_leg_change_s"]
    lines += ["", "Sm is computed on the actuator commands (surfaces in radians, throttle 0..1) at 25 Hz.", "",
              (f"The window is the paper's: the whole turbulent leg, which begins with the turn into it, so its "
               f"roll error is mostly that corner; the \"no corner\" rows leave out the first {after:.0f} s after "
               "each leg change. Both are one turbulence realisation: `scripts/benchmark.py` measures turbulence "
               "rejection over many, paired, on straight legs."), ""]

    mae_keys = ("mae_roll_deg", "mae_pitch_deg", "mae_beta_deg")
    plan = metrics["plan"]
    window, after = plan["level_window_s"], plan["steady_after_leg_change_s"]
    lines += ["## Level flight on the 10 km route: mean absolute error", "",
              (f"In {window[0]:.0f}–{window[1]:.0f} s, the paper's level-flight window. On this route a corner "
               f"falls in it: the straight-flight columns leave out the {after:.0f} s after each leg change, as "
               "the steady-state errors do; the whole window keeps the turn."), "",
              "| controller | source | roll, deg | pitch, deg | sideslip, deg | whole window: roll, pitch, sideslip, deg |",
              "|---|---|---|---|---|---|"]
    if not other:
        lines.append("| RL | paper | " + " | ".join(_fmt(PAPER_LEVEL_MAE[k]) for k in mae_keys) + " | |")
    for name in names:
        entry = metrics.get("route_10km", {}).get(name)
        if entry:
            straight, whole = entry["level_flight"], entry["level_window"]
            lines.append(f"| {name} | ours | " + " | ".join(_fmt(straight[k]) for k in mae_keys) + " | "
                         + " / ".join(_fmt(whole[k]) for k in mae_keys) + " |")
    lines.append("")

    lines += ["## Steady-state error on the straight legs at 1 km and 20 km (calm air)", "",
              "| altitude | controller | source | roll, deg | pitch, deg |", "|---|---|---|---|---|"]
    for key in ("1km", "20km"):
        if not other:
            paper = PAPER_STEADY_STATE[key]
            lines.append(f"| {key} | RL | paper | {_fmt(paper['roll_deg'])} | {_fmt(paper['pitch_deg'])} |")
        for name in names:
            entry = metrics.get("altitudes", {}).get(key, {}).get(name)
            if entry:
                s = entry["steady_state_error"]
                lines.append(f"| {key} | {name} | ours | {_fmt(s['roll_deg'])} | {_fmt(s['pitch_deg'])} |")
    lines.append("")

    lines += ["## Table 9: perturbed aircraft, no retraining (whole route, calm air)", "",
              ("| aircraft | controller | RMSE roll, deg | RMSE pitch, deg | RMSE EAS, m/s | RMSE sideslip, deg | "
              "ended early |"), "|---|---|---|---|---|---|---|"]
    for parameters, per in metrics.get("perturbation", {}).items():
        for name, entry in per.items():
            w = entry["whole_route"]
            lines.append(f"| {parameters} | {name} | {_fmt(w['rmse_roll_deg'])} | {_fmt(w['rmse_pitch_deg'])} | "
                         f"{_fmt(w['rmse_airspeed_eas_mps'])} | {_fmt(w['rmse_beta_deg'])} | "
                         f"{entry['ended_early'] or 'no'} |")
    lines.append("")

    lines += ["## Backlash (0.3 deg ahead of the servo lag)", "",
              "| servo | controller | pitch error std, deg | elevator std, deg | Sm elevator |", "|---|---|---|---|---|"]
    for label, per in metrics.get("backlash", {}).items():
        for name, entry in per.items():
            w = entry["window"]
            lines.append(f"| {label} | {name} | {_fmt(w['pitch_error_std_deg'])} | {_fmt(w['elevator_std_deg'])} | "
                         f"{_fmt(w['smoothness_elevator'])} |")
    lines.append("")

    if isinstance(metrics.get("doublets"), dict):
        lines += ["## Doublets (Fig. 9)", "", ("| altitude | RMSE roll, deg | RMSE pitch, deg | RMSE EAS, m/s | "
                  "RMSE sideslip, deg | ended early |"), "|---|---|---|---|---|---|"]
        for key, d in metrics["doublets"].items():
            lines.append(f"| {key} | {_fmt(d['rmse_roll_deg'])} | {_fmt(d['rmse_pitch_deg'])} | "
                         f"{_fmt(d['rmse_airspeed_eas_mps'])} | {_fmt(d['rmse_beta_deg'])} | {d['ended_early']} |")
        lines.append("")

    lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)


__all__ = ["CONTROLLERS", "EXPERIMENTS", "EXTRA_CONTROLLERS", "PAPER_TABLE8", "ReportPlan", "render_markdown", "run_report", "steady_state_errors"]

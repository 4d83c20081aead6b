"""Score training runs for the ablation table, or print the record of every candidate tried.

    python scripts/ablation.py runs/c2_seed0 runs/c2_seed1 runs/c2_seed2 --markdown
    python scripts/ablation.py runs/*_seed* --pid DIR --json
    python scripts/ablation.py --markdown > docs/ablation.md
    python scripts/ablation.py --method-row runs/method/val_v10 v10

With run folders: each run's best policy, flown as its policy file records it, on the evaluation
suite, the calm 1 km and 20 km routes (steady-state error), the 10 km route (turbulent leg, level
flight) and the calm 10 km route flown by the Table 9 aircraft, with the wall-clock the run took to
reach that policy; then one row per candidate over its seeds. Runs are grouped into candidates by
their folder name without the ``_seedN`` ending. Each run's scores are kept in
``RUN_DIR/scorecard/scorecard.json`` (with the report's figures beside it) and reused while the
policy file is unchanged, so adding a seed costs only that seed's flights; a scorecard written
before a section existed (the Table 9 aircraft) gains only that section's flights. ``--pid`` adds
the PID on the same flights as the reference row.

Without run folders, ``--markdown`` prints docs/ablation.md: every candidate tried so far, from the
figures recorded in ``scripts/ablation_rows.json`` (one row per candidate, the commit that added
it, whether it was kept) and a paragraph on each decision kept; then the learning method's
candidates (residual, distilled, more budget), each judged by the benchmark's selection rule.
``--method-row`` prints the figures of one such row from a benchmark's results.
"""

from __future__ import annotations

import json
import re
import textwrap
from dataclasses import asdict
from pathlib import Path

import numpy as np

# Only numpy and training.runtime (no torch, no simulation) load before the arguments are parsed,
# so that a mistyped option is refused at once; the flights' modules load where they are flown.
from training.output_folders import read_json, write_json_atomic, write_text_atomic
from training.runtime import OutputFolderError, ScriptParser, check_output_folder, episodes_int, run_command

# Scorecard sections (named by the key each adds to the scorecard) and the report experiments
# they are flown with; a cached scorecard that lacks a section gets only that section's flights.
SECTIONS = {"route_10km": ("altitudes", "route_10km"), "table9": ("perturbation",)}
# Part of every scorecard's cache key: raise it when the scoring itself changes (its windows, not
# the route settings, which are in the key). 2: the steady-state window after each corner grows
# with the turn time above 10 km (training.evaluation.report.steady_mask), and the level-flight errors leave
# out the corner in the level window as the steady-state errors do.
SCORING_VERSION = 2
# (column, where it sits in a scorecard); steady-state errors are calm air, the RMSEs the turbulent leg.
COLUMNS = (
    ("suite return", ("suite", "mean_return_norm")),
    ("suite early ends", ("suite", "ended_early")),
    ("1 km roll/pitch SS, deg", ("altitudes", "1km")),
    ("20 km roll/pitch SS, deg", ("altitudes", "20km")),
    ("level MAE roll/pitch, deg", ("route_10km", "level_flight")),
    ("turb. RMSE roll/pitch/β, deg", ("route_10km", "turbulent_leg")),
    ("Table 9 + RMSE roll/pitch/β, deg", ("table9", "positive")),
    ("Table 9 − RMSE roll/pitch/β, deg", ("table9", "negative")),
)


# The record of every candidate tried (``--markdown`` without run folders).
RECORD = Path(__file__).with_name("ablation_rows.json")


def candidate_name(run_dir: Path) -> str:
    return re.sub(r"_seed\d+$", "", run_dir.name)


def score(controller_factory, out_dir: Path, policy: Path | None, episodes: int, quick: bool = False) -> dict:
    """Suite, routes and their figures into ``out_dir``, kept in ``out_dir/scorecard.json`` and
    reused while the scoring version, the controller (the policy file's digest, or the PID), the
    aircraft model, the route settings, the episode count and ``quick`` are the same."""
    import aircraft
    from jsbsim_env.control.policy import policy_digest
    from jsbsim_env.missions import RouteConfig
    from training.evaluation.report import render_markdown, run_report
    from training.evaluation.suite import suite_episodes

    key = {"scoring": SCORING_VERSION, "controller": policy_digest(policy) if policy is not None else "PID",
           "episodes": episodes, "quick": quick, "aircraft_model": aircraft.model_fingerprint(), "route": asdict(RouteConfig())}
    key = json.loads(json.dumps(key))  # as it reads back from the file (tuples become lists)
    path = out_dir / "scorecard.json"
    card = {"key": key}
    if path.exists():
        cached = read_json(path)
        if isinstance(cached, dict) and cached.get("key") == key:
            card = cached
    if "suite" not in card:
        card["suite"] = suite_episodes(controller_factory(), episodes)
    missing = [section for section in SECTIONS if section not in card]
    if not missing:
        return card
    out_dir.mkdir(parents=True, exist_ok=True)
    name = "PID" if policy is None else "RL"
    earlier = read_json(out_dir / "metrics.json") if (out_dir / "metrics.json").exists() else {}
    metrics = run_report(out_dir, policy, quick=quick, progress=False, controllers=(name,),
                         experiments=tuple(e for section in missing for e in SECTIONS[section]))
    if isinstance(earlier, dict) and earlier.get("controllers") == metrics["controllers"]:  # one report of all
        merged = {**earlier, **metrics, "experiments": [*earlier.get("experiments", []), *metrics["experiments"]]}
        write_json_atomic(out_dir / "metrics.json", merged, indent=1, default=float)
        write_text_atomic(out_dir / "report.md", render_markdown(merged, out_dir))
    ended = card.setdefault("ended_early", {})
    if "route_10km" in missing:
        card["altitudes"] = {k: v[name]["steady_state_error"] for k, v in metrics["altitudes"].items()}
        card["route_10km"] = {k: metrics["route_10km"][name][k] for k in ("level_window", "level_flight", "turbulent_leg")}
        ended.update({k: bool(v[name]["ended_early"]) for k, v in
                      [*metrics["altitudes"].items(), ("10km", metrics["route_10km"])]})
    if "table9" in missing:
        card["table9"] = {k: v[name]["whole_route"] for k, v in metrics["perturbation"].items()}
        ended.update({f"table9_{k}": bool(v[name]["ended_early"]) for k, v in metrics["perturbation"].items()})
    write_json_atomic(path, card, indent=1, default=float)  # whole or as it was, even when stopped
    return card


def run_scorecard(run_dir: Path, episodes: int, quick: bool = False) -> dict:
    """The scores of the run's best policy, flown with the control stack its file records, with the
    wall-clock the run took to reach it."""
    from jsbsim_env.control.factory import make_controller
    from jsbsim_env.control.policy import load_policy
    from training.provenance import training_wall_clock

    policy = run_dir / "best_policy.pt"
    card = score(lambda: make_controller("policy", policy, backend="torch"), run_dir / "scorecard", policy, episodes,
                 quick)
    frames = int(load_policy(policy)[1]["frames"])
    return {**card, "run": str(run_dir), "policy_frames": frames, "wall_clock": training_wall_clock(run_dir, frames)}


def _pair(values: dict, keys: tuple[str, ...]) -> list[float]:
    return [float(values[k]) for k in keys]


def cell(cards: list[dict], where: tuple[str, str]) -> str:
    """Mean over seeds, and the range where there is more than one."""
    section, key = where
    if section == "suite":
        values = np.array([[c["suite"][key]] for c in cards], dtype=float)
    elif section == "altitudes":
        values = np.array([_pair(c["altitudes"][key], ("roll_deg", "pitch_deg")) for c in cards])
    elif key == "level_flight":
        values = np.array([_pair(c["route_10km"][key], ("mae_roll_deg", "mae_pitch_deg")) for c in cards])
    else:
        from jsbsim_env.task.metrics import ATTITUDE_RMSE_KEYS

        values = np.array([_pair(c[section][key], ATTITUDE_RMSE_KEYS) for c in cards])
    fmt = "{:.0f}" if key == "ended_early" else "{:.3f}"
    text = " / ".join(fmt.format(v) for v in values.mean(axis=0))
    if len(cards) > 1 and key == "mean_return_norm":
        text += f" ({values.min():.3f}–{values.max():.3f})"
    return text


def markdown(groups: dict[str, list[dict]]) -> str:
    head = ["candidate", "seeds", *(c for c, _ in COLUMNS), "wall-clock to policy, min"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, cards in groups.items():
        walls = [c["wall_clock"]["to_policy_s"] / 60 for c in cards if c.get("wall_clock")]
        wall = f"{np.mean(walls):.0f} ({min(walls):.0f}–{max(walls):.0f})" if walls else "—"
        lines.append("| " + " | ".join([name, str(len(cards)), *(cell(cards, w) for _, w in COLUMNS), wall]) + " |")
    return "\n".join(lines)


def method_row(result: dict, label: str) -> dict:
    """The figures of a learned controller's row in the record's table of the learning method's
    candidates, from a benchmark's ``benchmark.json`` (``result``) in which it flew as ``label``: the
    flights (split, aircraft, families, realisations), the classical controllers it was judged
    against, the selection rule's cells met and ratio (``training.evaluation.selection``, as the
    benchmark recorded them), and at each turbulence altitude its RMSE roll / pitch / sideslip beside
    the best classical controller's of each metric. A ``ValueError`` names what is missing."""
    from jsbsim_env.task.metrics import ATTITUDE_RMSE_KEYS
    from training.evaluation.selection import best_classical, sides

    try:
        chosen = {s["controller"]: s for s in result["selection"]}
        flown = result["controllers"]
        turbulence = result["summary"].get("turbulence", {})
        flights = {k: result[k] for k in ("split", "aircraft", "families", "episodes")}
    except (KeyError, TypeError) as err:
        raise ValueError(f"not a benchmark's benchmark.json with a selection (missing {err})") from None
    if label not in chosen:
        raise ValueError(f"{label!r} was not judged in this benchmark (its candidates: {', '.join(chosen) or 'none'})")
    _, classical = sides(flown)
    metrics = ATTITUDE_RMSE_KEYS  # roll, pitch, sideslip, as the benchmark recorded them

    def rmse(entry: dict, pick) -> str:
        return " / ".join(f"{entry['controllers'][pick(m)]['metrics'][m]['mean']:.3f}" for m in metrics)

    picked = chosen[label]
    return {**flights, "judged_against": classical, "cells_met": f"{picked['met']} of {picked['cells']}",
            "ratio": f"{picked['ratio']:.3f}",
            "turbulence_rmse_deg": {cond: rmse(e, lambda m: label) for cond, e in turbulence.items()},
            "best_classical_turbulence_rmse_deg": {
                cond: rmse(e, lambda m, e=e: best_classical(e, m, [c for c in classical if c in e["controllers"]]))
                for cond, e in turbulence.items()}}


# ---------------------------------------------------------------------- the record (docs/ablation.md)
RECORD_INTRO = """\
# What was tried

Every candidate configuration trained so far, in the order tried, against the gain-scheduled PID
on the same flights; then what each decision kept in the default rests on. This page is written
by `python scripts/ablation.py --markdown > docs/ablation.md` from the figures recorded in
`scripts/ablation_rows.json`; a new candidate is scored with `python scripts/ablation.py
runs/<candidate>_seed0 runs/<candidate>_seed1 ... --pid DIR --markdown` and its row added there.

Each run trained 140,000 environment steps (the state-critic run 200,000) on a 2-core CPU, usually
beside one other run, one torch thread each; its best policy (by the 8 training-time evaluation
episodes) was flown as its policy file records it. The columns:

- *suite return*: normalised return on the 50 disturbed episodes of the evaluation suite, the mean
  over the seeds and, in brackets, their range (no candidate ended a suite episode early);
- *1 km SS*, *20 km SS*: calm-air steady-state error, the mean absolute roll / pitch error on the
  straight legs of the 1 km and 20 km routes from 60 s after each corner (130 s at 20 km);
- *level MAE*: mean absolute roll / pitch error in the paper's level-flight window (1000–1500 s) of
  the 10 km route, on its straight flight;
- *turbulent RMSE*: roll / pitch / sideslip RMSE on the turbulent leg of the 10 km route (the
  paper's Table 8 flight);
- *Table 9 +*, *Table 9 −*: roll / pitch / sideslip RMSE over the whole calm 10 km route flown by
  the paper's Table 9 positive and negative aircraft, without retraining (— where the run was no
  longer there to fly them);
- *wall-clock*: training time to the run's best policy, the mean over the seeds (their range);
- *tried at*: the commit that added the row;
- *kept*: yes, it is in the default (the task version `SolarUAVAttitude-v1` and the training
  defaults of `training/config.py`); no; replaced, the default for a while, replaced by a later
  row; shipped, a single seed that was the shipped policy (then, or now).

Every flight flies the report's fixed seeds, so each figure of a seed is one realisation of its
turbulence and noise; one seed's training-time evaluation return moves by about ±0.03 between
neighbouring evaluations, so rows rank only where they differ by more. "The same" means the row
above; "the default then" the last row kept or replaced above it. The surface trim was called
integral trim when these rows were trained; "flown with surface trim g" is the same policies with
the trim's flight gain changed to g times the PID's integral gains, without retraining.
"""

RECORD_NOTES = """\
\\* Scored on the earlier 20 km route (drawn for 10 km, so that its legs were all turn and its
"steady state" was L1's roll demand switching between its limits) and on the level-flight window
with a corner in it: not comparable with the figures without \\*. The runs were no longer there to
score again.

† The routes gave the attitude controller TECS's EAS demand; in the rows without † it is given its
measured EAS (`RouteConfig.attitude_eas_demand = "measured"`, the default now). The PID's figures
are the same either way.

§ Shared the two cores with a third run or with scoring jobs.

¶ Trained on a less loaded machine (140,000 steps in 826–1047 s, two runs side by side): these
wall-clocks are not comparable with those above them.
"""

METHOD_INTRO = """\
## The learning method's candidates

The rows above change the recipe of a network that flies alone. The candidates below change the
method: a residual on an LQI (task versions v4 to v10), a network distilled from an LQI and then
fine-tuned (`distill.teacher`), and the default recipe at seven times the budget. Each is judged by
the benchmark's selection rule (`training.evaluation.selection`: each cell against the best
classical controller flown beside it; *judged against* names them) on the flights named
(*validation* or *test* seeds, 10 realisations per condition, the families flown), and its row's
figures are what `python scripts/ablation.py --method-row BENCHMARK_DIR LABEL` reads from that
benchmark. The turbulence columns give, at each of the aircraft's three altitudes, its RMSE roll /
pitch / sideslip (°) and, below it, the best classical controller's of each metric; *training* is
the run's wall clock for its 140,000 steps (1,000,000 for the control run), with the machine's load
named where it was not two runs side by side.
"""

PREVIOUS_INTRO = """\
## Before the corrected aircraft model

The algorithm's settings were chosen on the aircraft model before its aerodynamic corrections
([aircraft.md](aircraft.md)), by the training-time evaluation return (8 fixed episodes, every
disturbance on; random actions score 0.12–0.13) against environment steps, one seed each unless
named:
"""

_KEPT_ORDER = ("candidate", "seeds", "suite return", "1 km SS roll / pitch, °", "20 km SS roll / pitch, °",
               "level MAE roll / pitch, °", "turbulent RMSE roll / pitch / β, °", "Table 9 + RMSE roll / pitch / β, °",
               "Table 9 − RMSE roll / pitch / β, °", "wall-clock, min", "tried at", "kept")


def _wrap(text: str) -> str:
    return textwrap.fill(text, width=100, break_long_words=False, break_on_hyphens=False)


def record_markdown(record: dict) -> str:
    """docs/ablation.md from the record (``RECORD``): the table of every candidate, the earlier
    model's table and one paragraph per decision kept."""
    lines = [RECORD_INTRO, "| " + " | ".join(_KEPT_ORDER) + " |", "|" + "---|" * len(_KEPT_ORDER)]
    for row in record["rows"]:
        marks = set(row["marks"])
        old = " \\*" if "old" in marks else ""
        wall = row["wall_clock_min"] or "—"
        wall += " §" if "shared" in marks else ""
        wall += " ¶" if "later" in marks else ""
        name = row["candidate"] + (" †" if "route" in marks else "")
        cells = [name, str(row["seeds"]), row["suite_return"], row["ss_1km_deg"], row["ss_20km_deg"] + old,
                 row["level_mae_deg"] + old, row["turbulent_rmse_deg"], row["table9_positive_rmse_deg"] or "—",
                 row["table9_negative_rmse_deg"] or "—", wall, row["commit"], row["kept"]]
        if "default" in marks:
            cells = [f"**{c}**" for c in cells]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", RECORD_NOTES, METHOD_INTRO]
    head = ("candidate", "aircraft", "flights", "judged against", "cells met", "ratio", "turbulence, lowest",
            "turbulence, middle", "turbulence, highest", "training, s", "tried at", "kept")
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in record.get("method_rows", []):
        best = row["best_classical_turbulence_rmse_deg"]
        turbulence = [f"{cond}: {rmse}<br>{best[cond]}" for cond, rmse in row["turbulence_rmse_deg"].items()]
        turbulence = (turbulence + ["—"] * 3)[:3]  # a benchmark flown without the turbulence family has none
        flights = f"{row['split']}: {', '.join(row['families'])}"
        cells = [row["candidate"], row["aircraft_name"], flights, ", ".join(row["judged_against"]), row["cells_met"],
                 row["ratio"], *turbulence, row["training"], row["commit"], row["kept"]]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", PREVIOUS_INTRO]
    steps = ("20k", "40k", "60k", "100k", "200k")
    head = ("run", "updates per step", *(f"{s} steps" for s in steps), "time to 60k steps", "tried at", "kept")
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in record["previous_model_rows"]:
        cells = [row["run"], row["updates_per_step"], *(row["eval_return_at"].get(s, "") for s in steps),
                 row["time_to_60k"], row["commit"], row["kept"]]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "## The decisions kept", ""]
    for decision in record["decisions"]:
        lines += [_wrap(f"**{decision['title']}** ({decision['settings']}). {decision['text']}"), ""]
    lines.append("[Back to the README](../README.md)")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", type=Path, nargs="*",
                        help="run folders, each with best_policy.pt (none: --markdown prints the record of every "
                             "candidate tried)")
    parser.add_argument("--episodes", type=episodes_int, default=50, help="evaluation-suite episodes per run")
    parser.add_argument("--pid", type=Path, metavar="DIR", help="also score the PID, its flights in DIR")
    output = parser.add_mutually_exclusive_group()
    output.add_argument("--json", action="store_true", help="print every scorecard as JSON (the default)")
    output.add_argument("--markdown", action="store_true",
                        help="print the table as Markdown; without run folders, docs/ablation.md: every candidate "
                             f"tried, from {RECORD.name}")
    parser.add_argument("--quick", action="store_true", help="short routes, for checks")
    parser.add_argument("--method-row", nargs=2, metavar=("BENCHMARK_DIR", "LABEL"),
                        help="print as JSON the figures of the learned controller LABEL in the benchmark written to "
                             f"BENCHMARK_DIR, for its row in {RECORD.name}'s table of the learning method's candidates")
    args = parser.parse_args(argv)
    if args.method_row:
        if args.runs or args.markdown or args.pid:
            parser.error("--method-row reads a benchmark's results: give it alone")
        folder, label = args.method_row
        if not (Path(folder) / "benchmark.json").is_file():
            parser.exit(2, f"ablation: {folder} has no benchmark.json (scripts/benchmark.py --out writes it)\n")
        try:
            print(json.dumps(method_row(read_json(Path(folder) / "benchmark.json"), label), indent=1))
        except (OutputFolderError, ValueError) as err:
            parser.exit(2, f"ablation: {err}\n")
        return 0
    if not args.runs:
        if not args.markdown or args.pid:
            parser.error("give run folders to score, or --markdown alone for the record of every candidate tried")
        print(record_markdown(json.loads(RECORD.read_text(encoding="utf-8"))), end="")
        return 0
    for run in args.runs:
        if not (run / "best_policy.pt").is_file():
            parser.error(f"{run} has no best_policy.pt")
    from training.evaluation.report import ROUTE_SEED
    from training.evaluation.seeds import check_not_test_seed
    from training.evaluation.suite import EVAL_EPISODE_SEED

    try:  # the ablation selects candidates: never on the benchmark's frozen test set
        check_not_test_seed(range(EVAL_EPISODE_SEED, EVAL_EPISODE_SEED + args.episodes), "ablation (suite episodes)")
        check_not_test_seed(ROUTE_SEED, "ablation (report routes)")
    except ValueError as err:
        parser.exit(2, f"ablation: {err}\n")
    try:  # every folder a scorecard goes to, and the scorecards kept there, before the first flight
        for folder in [*(run / "scorecard" for run in args.runs), *([args.pid] if args.pid else [])]:
            check_output_folder(folder)
            for kept in ("scorecard.json", "metrics.json"):
                if (folder / kept).exists():
                    read_json(folder / kept)
    except OutputFolderError as err:
        parser.exit(2, f"ablation: {err}\n")
    import torch

    from jsbsim_env.control.pid import PIDAttitudeController

    torch.set_num_threads(1)
    groups: dict[str, list[dict]] = {}
    if args.pid:
        groups["PID (reference)"] = [score(PIDAttitudeController, args.pid, None, args.episodes, args.quick)]
    for run in args.runs:
        groups.setdefault(candidate_name(run), []).append(run_scorecard(run, args.episodes, args.quick))
    print(markdown(groups) if args.markdown else json.dumps(groups, indent=1, default=float))
    return 0


if __name__ == "__main__":
    run_command(main, __file__)

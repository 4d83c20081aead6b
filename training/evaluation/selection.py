"""The rule that judges a learned controller against the classical ones on the benchmark, fixed in
code before any candidate is scored: the same rule chooses between candidates on the validation
seeds and states the result on the test seeds.

For each cell (family, condition, metric) below, the reference is the best classical controller
there: the one with the lowest mean among those that flew every realisation (fewest early ends
first), so that a candidate is measured against the PID, the LQI or a tuned one, whichever is
strongest on that very metric.

| family | metrics | a candidate meets it when |
|---|---|---|
| turbulence | RMSE roll, pitch, sideslip at 1, 10, 20 km | not worse than the reference at 95 % (the paired interval of the difference does not lie above zero) |
| turbulence | all its cells together | better than the reference at 95 % in at least ``TURBULENCE_BETTER_SHARE`` of them (six of nine) |
| table9 | RMSE roll, pitch, sideslip, both aircraft | not worse than the reference at 95 % |
| steps | settling time, overshoot | not worse than the reference at 95 % |
| robustness | RMSE roll, pitch, sideslip, each stress | not worse than the reference at 95 %, and no early end |
| calm | mean absolute roll, pitch error | within ``CALM_BOUND_DEG`` |
| calm | Sm of the aileron, elevator and rudder commands | at most ``ACTIVITY_FACTOR`` times the reference's mean |

The training's wall clock (at most 15 minutes per seed with two side by side) is judged from the
run's own record, beside this rule. A candidate that ended a flight early in a condition fails
every metric of that condition. Candidates rank by cells met, then by the geometric mean, over the
turbulence and table9 cells, of their mean over the reference's (lower first).
"""

from __future__ import annotations

import math

from jsbsim_env.control.factory import CONTROLLER_NAMES
from jsbsim_env.task.metrics import ATTITUDE_RMSE_KEYS

CLASSICAL = tuple(c for c in CONTROLLER_NAMES if c != "policy")
CALM_BOUND_DEG = 0.05
ACTIVITY_FACTOR = 2.0  # calm-air surface activity: at most twice the best classical controller's
TURBULENCE_BETTER_SHARE = 2.0 / 3.0  # of the turbulence cells, better at 95 % (six of nine)
# family -> ((metrics judged, what meeting a cell asks: "not worse", "within bound" or "within factor"), ...)
CRITERIA = {
    "turbulence": ((ATTITUDE_RMSE_KEYS, "not worse"),),
    "table9": ((ATTITUDE_RMSE_KEYS, "not worse"),),
    "steps": ((("settling_time_s", "overshoot_pct"), "not worse"),),
    "robustness": ((ATTITUDE_RMSE_KEYS, "not worse"),),
    "calm": ((("mae_roll_deg", "mae_pitch_deg"), "within bound"),
             (("smoothness_aileron", "smoothness_elevator", "smoothness_rudder"), "within factor")),
}
RATIO_FAMILIES = ("turbulence", "table9")
BETTER_CELLS = "cells better at 95 %"  # the turbulence family's row of all its cells


def _verdict(entry: dict, candidate: str, reference: str, metric: str) -> str:
    """The paired verdict for ``candidate`` against ``reference`` ("better", "worse", "no difference")."""
    pairs = entry["pairs"]
    if f"{candidate} - {reference}" in pairs:
        return pairs[f"{candidate} - {reference}"][metric]["verdict"]
    flipped = pairs[f"{reference} - {candidate}"][metric]["verdict"]
    return {"better": "worse", "worse": "better"}.get(flipped, flipped)


def best_classical(entry: dict, metric: str, classical) -> str:
    """The classical controller with the fewest early ends, then the lowest mean, in one condition."""
    flown = entry["controllers"]

    def key(c):
        mean = flown[c]["metrics"][metric]["mean"]
        return flown[c]["ended_early"], mean if math.isfinite(mean) else math.inf

    return min(classical, key=key)


def judge(summary: dict, candidate: str, classical=CLASSICAL) -> list[dict]:
    """One row per cell of ``CRITERIA`` found in ``summary`` (``benchmark.summarise``): the cell, the
    reference controller and both means, the paired verdict, and whether the candidate meets it."""
    rows = []
    for family, groups in CRITERIA.items():
        for cond, entry in summary.get(family, {}).items():
            present = [c for c in classical if c in entry["controllers"]]
            if not present or candidate not in entry["controllers"]:
                continue
            ended = entry["controllers"][candidate]["ended_early"]
            for metrics, rule in groups:
                for metric in metrics:
                    if metric not in entry["controllers"][candidate]["metrics"]:
                        continue  # a summary written before this metric was recorded
                    rows.append(_cell(entry, candidate, present, family, cond, metric, rule, ended))
    turbulence = [r for r in rows if r["family"] == "turbulence"]
    if turbulence:
        better = sum(r["verdict"] == "better" and not r["candidate_ended_early"] for r in turbulence)
        needed = math.ceil(TURBULENCE_BETTER_SHARE * len(turbulence) - 1e-9)
        rows.append({"family": "turbulence", "condition": "all", "metric": BETTER_CELLS, "candidate_mean": better,
                     "candidate_ended_early": 0, "reference": None, "reference_mean": needed, "verdict": None,
                     "met": better >= needed})
    return rows


def _cell(entry: dict, candidate: str, present: list[str], family: str, cond: str, metric: str, rule: str,
          ended: int) -> dict:
    """One cell of ``judge``."""
    mean = entry["controllers"][candidate]["metrics"][metric]["mean"]
    row = {"family": family, "condition": cond, "metric": metric, "candidate_mean": mean,
           "candidate_ended_early": ended}
    if rule == "within bound":
        return {**row, "reference": None, "reference_mean": CALM_BOUND_DEG, "verdict": None,
                "met": not ended and mean <= CALM_BOUND_DEG}
    ref = best_classical(entry, metric, present)
    ref_mean = entry["controllers"][ref]["metrics"][metric]["mean"]
    verdict = _verdict(entry, candidate, ref, metric)
    met = not ended and (mean <= ACTIVITY_FACTOR * ref_mean if rule == "within factor" else verdict != "worse")
    return {**row, "reference": ref, "reference_mean": ref_mean, "verdict": verdict, "met": bool(met)}


def score(rows: list[dict]) -> dict:
    """Cells met of all, and the geometric mean ratio candidate / reference over ``RATIO_FAMILIES``."""
    logs = [math.log(r["candidate_mean"] / r["reference_mean"]) for r in rows
            if r["family"] in RATIO_FAMILIES and r["reference"] is not None and r["reference_mean"] > 0 and r["candidate_mean"] > 0
            and math.isfinite(r["candidate_mean"])]
    return {"met": sum(r["met"] for r in rows), "cells": len(rows),
            "ratio": math.exp(sum(logs) / len(logs)) if logs else math.nan,
            "all_met": bool(rows) and all(r["met"] for r in rows)}


def sides(controllers) -> tuple[list[str], list[str]]:
    """``controllers`` split into the learned ones (candidates) and the classical ones."""
    return [c for c in controllers if c not in CLASSICAL], [c for c in CLASSICAL if c in controllers]


def _judged(summary: dict, candidates, classical) -> list[tuple[str, dict, list[dict]]]:
    """Each candidate with its ``score`` and its cells (``judge``), best first: most cells met,
    then the lowest ratio."""
    judged = []
    for c in candidates:
        rows = judge(summary, c, classical)
        judged.append((c, score(rows), rows))
    return sorted(judged, key=lambda j: (-j[1]["met"], j[1]["ratio"] if math.isfinite(j[1]["ratio"]) else math.inf))


def rank(summary: dict, candidates, classical=CLASSICAL) -> list[tuple[str, dict]]:
    """The candidates with their ``score``, best first: most cells met, then the lowest ratio."""
    return [(c, s) for c, s, _ in _judged(summary, candidates, classical)]


def render(summary: dict, controllers: list[str], fmt) -> list[str]:
    """Markdown lines: the ranking of the learned controllers in ``controllers`` and, for each, its
    cells against the best classical controller; nothing when either side is missing."""
    candidates, classical = sides(controllers)
    if not candidates or not classical:
        return []
    lines = ["## Against the best classical controller", "",
             ("The rule of `training.evaluation.selection`, fixed before scoring: in each cell the reference is "
              f"the best of {', '.join(classical)} there; turbulence, Table 9, steps and robustness cells are met "
              "when not worse at 95 % (and no early end), and the turbulence cells together when better at 95 % in "
              f"{TURBULENCE_BETTER_SHARE:.0%} of them; calm errors within {CALM_BOUND_DEG:g} deg, calm surface "
              f"activity (Sm) within {ACTIVITY_FACTOR:g} times the reference's. Ratio: geometric mean of the "
              "candidate's mean over the reference's, turbulence and Table 9."), "",
             "| rank | controller | cells met | ratio | all met |", "|---|---|---|---|---|"]
    judged = _judged(summary, candidates, classical)
    for k, (c, s, _) in enumerate(judged, 1):
        lines.append(f"| {k} | {c} | {s['met']} of {s['cells']} | {fmt(s['ratio'])} | {'yes' if s['all_met'] else 'no'} |")
    for c, _, rows in judged:
        lines += ["", f"### {c}", "", "| family | condition | metric | reference | reference mean | mean | verdict | met |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in rows:
            early = f" ({r['candidate_ended_early']} ended early)" if r["candidate_ended_early"] else ""
            lines.append(f"| {r['family']} | {r['condition']} | {r['metric']} | {r['reference'] or 'bound'} | "
                         f"{fmt(r['reference_mean'])} | {fmt(r['candidate_mean'])}{early} | {r['verdict'] or ''} | "
                         f"{'yes' if r['met'] else 'no'} |")
    lines.append("")
    return lines


__all__ = ["ACTIVITY_FACTOR", "BETTER_CELLS", "CALM_BOUND_DEG", "CLASSICAL", "CRITERIA", "TURBULENCE_BETTER_SHARE", "best_classical", "judge", "rank", "render", "score", "sides"]

"""The rule that judges a learned controller against the best classical controller of each cell
(``training.evaluation.selection``), on benchmark summaries of made-up rows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from training.evaluation.benchmark import FAMILIES, summarise
from training.evaluation.selection import (
    ACTIVITY_FACTOR,
    BETTER_CELLS,
    CALM_BOUND_DEG,
    best_classical,
    judge,
    rank,
    render,
    score,
)

ROUTE = ("rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg")


def _rows(family: str, condition: str, means: dict, ended: dict | None = None, n: int = 8) -> list[dict]:
    """``n`` paired realisations per controller: each metric its mean plus the same small spread
    (so that paired differences are sharp), NaN metrics where the controller ended early."""
    rng = np.random.default_rng(0)
    spread = rng.normal(0.0, 0.01, n)
    rows = []
    for c, by_metric in means.items():
        for k in range(n):
            early = (ended or {}).get(c, 0) > k
            rows.append({"family": family, "condition": condition, "controller": c, "realisation": k,
                         "ended_early": "pitch limit" if early else "",
                         **{m: math.nan if early else v + spread[k] * (1 + 0.1 * j)
                            for j, (m, v) in enumerate(by_metric.items())}})
    return rows


def _turbulence(roll_pid, roll_lqi, roll_cand, **kw):
    return _rows("turbulence", "1 km", {
        "pid": dict(zip(ROUTE, (roll_pid, 0.30, 0.30))),
        "lqi_tuned": dict(zip(ROUTE, (roll_lqi, 0.20, 0.25))),
        "cand": dict(zip(ROUTE, (roll_cand, 0.15, 0.25)))}, **kw)


def test_each_cell_is_judged_against_the_best_classical_controller_of_that_metric():
    rows = _turbulence(0.12, 0.14, 0.10)
    summary = summarise(rows, ["pid", "lqi_tuned", "cand"])
    cells = {r["metric"]: r for r in judge(summary, "cand", ("pid", "lqi_tuned"))}
    assert cells["rmse_roll_deg"]["reference"] == "pid" and cells["rmse_pitch_deg"]["reference"] == "lqi_tuned"
    assert cells["rmse_roll_deg"]["met"] and cells["rmse_pitch_deg"]["met"]
    assert cells["rmse_beta_deg"]["verdict"] == "no difference" and cells["rmse_beta_deg"]["met"]  # not worse
    assert cells[BETTER_CELLS]["candidate_mean"] == 2 and cells[BETTER_CELLS]["met"]  # 2 of 3 better: two thirds
    # The pair's order in the summary does not change the verdict: the candidate flown first.
    flipped = {r["metric"]: r for r in judge(summarise(rows, ["cand", "pid", "lqi_tuned"]), "cand",
                                             ("pid", "lqi_tuned"))}
    assert {m: r["verdict"] for m, r in flipped.items()} == {m: r["verdict"] for m, r in cells.items()}
    s = score(list(cells.values()))
    assert (s["met"], s["cells"], s["all_met"]) == (4, 4, True)
    assert s["ratio"] == pytest.approx((0.10 / 0.12 * 0.15 / 0.20 * 1.0) ** (1 / 3), rel=0.02)


def test_a_classical_controller_that_ended_early_is_no_reference_and_a_candidate_that_did_fails():
    rows = _rows("robustness", "delay_ms 200", {"pid": dict(zip(ROUTE, (0.2, 0.3, 0.3))),
                                               "lqi_tuned": dict(zip(ROUTE, (0.1, 0.1, 0.1))),
                                               "cand": dict(zip(ROUTE, (0.15, 0.25, 0.25)))},
                 ended={"lqi_tuned": 2})
    summary = summarise(rows, ["pid", "lqi_tuned", "cand"])
    entry = summary["robustness"]["delay_ms 200"]
    assert best_classical(entry, "rmse_roll_deg", ("pid", "lqi_tuned")) == "pid"
    assert all(r["met"] and r["reference"] == "pid" for r in judge(summary, "cand", ("pid", "lqi_tuned")))
    ended = summarise(_rows("robustness", "delay_ms 200", {"pid": dict(zip(ROUTE, (0.2, 0.3, 0.3))),
                                                           "cand": dict(zip(ROUTE, (0.1, 0.1, 0.1)))},
                            ended={"cand": 1}), ["pid", "cand"])
    assert not any(r["met"] for r in judge(ended, "cand", ("pid",)))


def test_calm_cells_are_met_within_the_bound_and_steps_when_not_worse():
    activity = {f"smoothness_{s}": 0.5 for s in ("aileron", "elevator", "rudder")}
    calm = _rows("calm", "1 km", {"pid": {"mae_roll_deg": 0.02, "mae_pitch_deg": 0.02, **activity},
                                  "cand": {"mae_roll_deg": CALM_BOUND_DEG - 0.01, "mae_pitch_deg": CALM_BOUND_DEG + 0.01,
                                           **activity}})
    steps = _rows("steps", "roll 5 km", {"pid": {"rise_time_s": 1.0, "overshoot_pct": 5.0, "settling_time_s": 2.0,
                                                 "itae_deg_s2": 1.0},
                                         "cand": {"rise_time_s": 9.0, "overshoot_pct": 5.0, "settling_time_s": 2.5,
                                                  "itae_deg_s2": 9.0}})
    summary = summarise(calm + steps, ["pid", "cand"])
    cells = {(r["family"], r["metric"]): r["met"] for r in judge(summary, "cand", ("pid",))
             if not r["metric"].startswith("smoothness_")}
    assert cells == {("calm", "mae_roll_deg"): True, ("calm", "mae_pitch_deg"): False,
                     ("steps", "overshoot_pct"): True, ("steps", "settling_time_s"): False}
    assert set(FAMILIES["steps"].metrics) >= {"overshoot_pct", "settling_time_s"}


def test_candidates_rank_by_cells_met_then_by_their_ratio_and_render_as_markdown():
    rows = _rows("turbulence", "1 km", {"pid": dict(zip(ROUTE, (0.2, 0.2, 0.2))),
                                        "a": dict(zip(ROUTE, (0.1, 0.1, 0.3))),
                                        "b": dict(zip(ROUTE, (0.15, 0.15, 0.15))),
                                        "c": dict(zip(ROUTE, (0.19, 0.19, 0.19)))})
    summary = summarise(rows, ["pid", "a", "b", "c"])
    assert [c for c, _ in rank(summary, ["a", "b", "c"], ("pid",))] == ["b", "c", "a"]
    lines = render(summary, ["pid", "a", "b", "c"], lambda x: f"{x:.3f}")
    assert lines[0] == "## Against the best classical controller"
    top = lines[lines.index("|---|---|---|---|---|") + 1]
    assert top.startswith("| 1 | b | 4 of 4 | 0.7") and top.endswith("| yes |") and "### a" in lines
    assert render(summary, ["a", "b"], str) == [] and render(summary, ["pid"], str) == []


def test_turbulence_asks_for_no_worse_cell_and_better_at_95_percent_in_two_thirds_of_them():
    # Better in roll only, the same in pitch and sideslip: every cell is met, the family is not.
    rows = _rows("turbulence", "1 km", {"lqi_tuned": dict(zip(ROUTE, (0.2, 0.2, 0.2))),
                                        "cand": dict(zip(ROUTE, (0.1, 0.2, 0.2)))})
    cells = judge(summarise(rows, ["lqi_tuned", "cand"]), "cand", ("lqi_tuned",))
    assert [r["met"] for r in cells if r["metric"] != BETTER_CELLS] == [True, True, True]
    family = next(r for r in cells if r["metric"] == BETTER_CELLS)
    assert (family["candidate_mean"], family["reference_mean"], family["met"]) == (1, 2, False)
    assert not score(cells)["all_met"]


def test_calm_surface_activity_is_met_within_twice_the_best_classical_controllers():
    calm = {"mae_roll_deg": 0.01, "mae_pitch_deg": 0.01}
    rows = _rows("calm", "1 km", {"pid": {**calm, "smoothness_aileron": 0.5, "smoothness_elevator": 0.5,
                                          "smoothness_rudder": 0.5},
                                  "lqi": {**calm, "smoothness_aileron": 0.2, "smoothness_elevator": 0.9,
                                          "smoothness_rudder": 0.5},
                                  "cand": {**calm, "smoothness_aileron": ACTIVITY_FACTOR * 0.2 + 0.05,
                                           "smoothness_elevator": 0.9, "smoothness_rudder": 0.3}})
    cells = {r["metric"]: r for r in judge(summarise(rows, ["pid", "lqi", "cand"]), "cand", ("pid", "lqi"))}
    assert cells["smoothness_aileron"]["reference"] == "lqi" and not cells["smoothness_aileron"]["met"]
    assert cells["smoothness_elevator"]["reference"] == "pid" and cells["smoothness_elevator"]["met"]
    assert cells["smoothness_rudder"]["met"]

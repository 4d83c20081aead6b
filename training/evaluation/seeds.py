"""Seed ranges of the evaluation tools, and the frozen test set that only the benchmark flies.

``TEST_SEEDS`` is declared here once. ``scripts/benchmark.py`` (``training.evaluation.benchmark``)
is the only tool that flies it; every tool that selects something (a trained seed with
``scripts/heldout.py --pick``, a candidate in ``scripts/ablation.py``, a setting from a sweep)
refuses it through ``check_not_test_seed``, so that no choice is ever made on the flights the
benchmark reports. ``VALIDATION_SEEDS`` flies the benchmark's own families on other seeds, for
choices made with the benchmark's measures (``scripts/benchmark.py --split validation``).

| tool | seeds |
|---|---|
| benchmark (the test set) | ``TEST_SEEDS``: 900,000 to 900,999 |
| benchmark, ``--split validation`` | ``VALIDATION_SEEDS``: 800,000 to 800,999 |
| report's routes | ``report.ROUTE_SEED`` 11 |
| report's doublets, suite's doublets | their altitude: 500, 5,000, 15,000 |
| held-out flights (``--pick``, ``--checkpoints``) | ``heldout.SEEDS``: 101, 102, 103 |
| suite's episodes (evaluate, ablation) | ``suite.EVAL_EPISODE_SEED`` 777 + k |
| sweeps | ``sweep.SWEEP_EPISODE_SEED`` 31,000 + k |
| training's evaluation episodes | drawn from the environment's seed ``trainer.EVAL_SEED`` |

The linear-model designs (``scripts/tune_pid.py``, ``scripts/tune_lqi.py``) fly no seeded
episode; the tuning on nonlinear flights (``scripts/tune_classical.py``) flies the held-out
flights' seeds (``heldout.SEEDS``) and refuses the test range.
Training environments draw their episodes' seeds from the run's seed with a random generator:
they are not a range, and are not checked here.
"""

from __future__ import annotations

from collections.abc import Iterable

TEST_SEEDS = range(900_000, 901_000)  # the frozen test set: flown by the benchmark only
VALIDATION_SEEDS = range(800_000, 801_000)  # the benchmark's families for selection
SPLITS = {"test": TEST_SEEDS, "validation": VALIDATION_SEEDS}


def _as_range(seeds: int | range | Iterable[int]) -> range | list[int]:
    if isinstance(seeds, bool):
        raise TypeError("a seed is a whole number, not a bool")
    if isinstance(seeds, int):
        return range(seeds, seeds + 1)
    return seeds if isinstance(seeds, range) else [int(s) for s in seeds]


def overlaps_test_seeds(seeds: int | range | Iterable[int]) -> bool:
    """Whether any of ``seeds`` (one seed, a range or any seeds) is in ``TEST_SEEDS``."""
    seeds = _as_range(seeds)
    if isinstance(seeds, range) and seeds.step == 1:
        return len(seeds) > 0 and seeds.start < TEST_SEEDS.stop and TEST_SEEDS.start < seeds.stop
    return any(s in TEST_SEEDS for s in seeds)


def _describe(seeds: range | list[int]) -> str:
    if isinstance(seeds, range) and seeds.step == 1 and len(seeds) > 1:
        return f"seeds {seeds.start} to {seeds.stop - 1}"
    return "seed " + ", ".join(str(s) for s in list(seeds)[:5]) + (" ..." if len(seeds) > 5 else "")


def check_not_test_seed(seeds: int | range | Iterable[int], tool: str) -> None:
    """Refuse (``ValueError``, one line naming ``tool``, its seeds and the test range) seeds that
    reach into the frozen test set: only the benchmark flies it."""
    as_range = _as_range(seeds)
    if overlaps_test_seeds(as_range):
        raise ValueError(f"{tool}: {_describe(as_range)} reach into the frozen test set (seeds "
                         f"{TEST_SEEDS.start} to {TEST_SEEDS.stop - 1}, training.evaluation.seeds.TEST_SEEDS), "
                         "which only scripts/benchmark.py flies; no selection may see it")


def tool_seed_ranges(episodes: int = 1000) -> dict[str, range]:
    """The seeds each evaluation tool flies (the episode ranges with ``episodes`` episodes), for
    the check that none of them is in the test set."""
    from training.evaluation import heldout, report, suite, sweep

    return {
        "report routes": range(report.ROUTE_SEED, report.ROUTE_SEED + 1),
        "doublets": range(500, 501), "doublets 5000 m": range(5000, 5001), "doublets 15000 m": range(15000, 15001),
        **{f"held-out {k}": range(v, v + 1) for k, v in heldout.SEEDS.items()},
        "suite episodes": range(suite.EVAL_EPISODE_SEED, suite.EVAL_EPISODE_SEED + episodes),
        "sweep episodes": range(sweep.SWEEP_EPISODE_SEED, sweep.SWEEP_EPISODE_SEED + episodes),
        "benchmark validation": VALIDATION_SEEDS,
    }


__all__ = ["SPLITS", "TEST_SEEDS", "VALIDATION_SEEDS", "check_not_test_seed", "overlaps_test_seeds", "tool_seed_ranges"]

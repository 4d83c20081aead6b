"""The frozen test set's refusal and the paired statistics of the benchmark."""

from __future__ import annotations

import numpy as np
import pytest

from training.evaluation.seeds import TEST_SEEDS, check_not_test_seed, overlaps_test_seeds, tool_seed_ranges
from training.evaluation.stats import paired_difference, verdict
from training.runtime import MAX_EPISODES


def test_no_tool_flies_the_test_seeds():
    for tool, seeds in tool_seed_ranges(episodes=10_000).items():
        assert not overlaps_test_seeds(seeds), tool


def test_test_seed_refused_with_the_tool_and_range():
    with pytest.raises(ValueError, match=r"heldout --pick.*900000 to 900999"):
        check_not_test_seed(TEST_SEEDS.start + 3, "heldout --pick")
    with pytest.raises(ValueError, match="sweep"):
        check_not_test_seed(range(TEST_SEEDS.start - 5, TEST_SEEDS.start + 1), "sweep")
    with pytest.raises(ValueError, match="ablation"):
        check_not_test_seed([1, 2, TEST_SEEDS.stop - 1], "ablation")
    check_not_test_seed(range(TEST_SEEDS.start - 10, TEST_SEEDS.start), "sweep")  # next to it: fine
    check_not_test_seed(TEST_SEEDS.stop, "sweep")


def test_tools_refuse_the_test_seeds(monkeypatch):
    from training.evaluation import heldout, suite, sweep

    with pytest.raises(ValueError, match="sweep"):
        sweep.jobs_for(["pid"], [{}], TEST_SEEDS.start - sweep.SWEEP_EPISODE_SEED + 1)
    with pytest.raises(ValueError, match="evaluation suite"):
        suite.suite_episodes(None, TEST_SEEDS.start - suite.EVAL_EPISODE_SEED + 1)
    monkeypatch.setitem(heldout.SEEDS, "calm", TEST_SEEDS.start)
    with pytest.raises(ValueError, match=r"held-out flights \(calm\)"):
        heldout.heldout_flights(quick=True)


def test_sweep_and_ablation_scripts_refuse_the_test_seeds(tmp_path, capsys):
    import importlib.util
    from pathlib import Path

    from training.evaluation.sweep import SWEEP_EPISODE_SEED

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("sweep_script", root / "scripts" / "sweep.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    episodes = TEST_SEEDS.start - SWEEP_EPISODE_SEED + 1
    # The scripts' episode bound (training.runtime.MAX_EPISODES) stops such a count first ...
    with pytest.raises(SystemExit) as stop:
        script.main(["--axis", "delay_ms=0", "--controllers", "pid", "--episodes", str(episodes),
                     "--out", str(tmp_path / "s")])
    assert stop.value.code == 2 and "--episodes must be in [1, 1000]" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()
    # ... and the sweep's and the ablation's own seed checks stand behind it.
    from training.evaluation.sweep import jobs_for

    with pytest.raises(ValueError, match="frozen test set"):
        jobs_for(["pid"], [{}], episodes)
    from training.evaluation.suite import EVAL_EPISODE_SEED

    assert EVAL_EPISODE_SEED + MAX_EPISODES <= TEST_SEEDS.start  # the bound keeps the suite's seeds clear

def test_paired_interval_contains_a_known_shift():
    rng = np.random.default_rng(1)
    common = rng.normal(0.0, 5.0, 200)  # the realisations' own effect, removed by the pairing
    b = 1.0 + common
    a = b - 0.3 + rng.normal(0.0, 0.1, 200)
    for method in ("t", "bootstrap"):
        d = paired_difference(a, b, method=method)
        assert d.low < -0.3 < d.high and d.high - d.low < 0.06, method
        assert d.verdict == "better"  # lower error
        assert paired_difference(a, b, direction="higher", method=method).verdict == "worse"
        assert paired_difference(b, a, method=method).verdict == "worse"


def test_paired_interval_t_half_width():
    d = paired_difference([1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    # mean 2, s = 1, n = 3: t(0.975, 2) = 4.302653
    assert d.mean == pytest.approx(2.0) and d.high - d.mean == pytest.approx(4.302653 / np.sqrt(3), rel=1e-6)
    assert d.verdict == "no difference"


def test_identical_samples_give_zero_width():
    x = np.linspace(0.1, 2.0, 12)
    for method in ("t", "bootstrap"):
        d = paired_difference(x, x.copy(), method=method)
        assert d.mean == 0.0 and d.low == 0.0 and d.high == 0.0 and d.verdict == "no difference"


def test_verdict_directions_and_nonfinite_pairs():
    assert verdict(-2.0, -1.0, "lower") == "better" and verdict(-2.0, -1.0, "higher") == "worse"
    assert verdict(1.0, 2.0, "lower") == "worse" and verdict(-1.0, 1.0, "lower") == "no difference"
    with pytest.raises(ValueError):
        verdict(0.0, 1.0, "sideways")
    d = paired_difference([1.0, np.nan, 2.0, 3.0], [0.0, 1.0, 0.0, np.inf])
    assert d.n == 2

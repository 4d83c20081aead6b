"""Every count a command takes has a stated upper bound: a value beyond it is one line on stderr and
exit status 2, before any work (``training.runtime``: ``MAX_EPISODES``, ``MAX_WORKERS``, ``MAX_ROUNDS``)."""

from __future__ import annotations

import pytest
from conftest import import_script

from training.runtime import MAX_EPISODES, MAX_ROUNDS, MAX_WORKERS

CASES = [
    ("evaluate", ["--episodes", str(MAX_EPISODES + 1)], "--episodes must be in [1, 1000]"),
    ("error_spectrum", ["--episodes", "5000"], "--episodes must be in [1, 1000]"),
    ("sweep", ["--episodes", "100000000", "--axis", "delay_ms=0"], "--episodes must be in [1, 1000]"),
    ("sweep", ["--workers", str(MAX_WORKERS + 1), "--axis", "delay_ms=0"], "--workers must be in [1, 1024]"),
    ("benchmark", ["--workers", "200000"], "--workers must be in [1, 1024]"),
    ("ablation", ["--episodes", "1e23"], "--episodes must be a whole number"),
    ("ship_policy", ["--episodes", "100000", "runs/none"], "--episodes must be in [1, 1000]"),
    ("tune_classical", ["--controller", "pid", "--budget", "1000000"], "--budget must be in [1, 10000]"),
    ("train_torchrl", ["--seeds", "1,2", "--workers", "99999"], "--workers must be in [1, 1024]"),
    ("bench_sim", ["--rounds", str(MAX_ROUNDS + 1)], "--rounds must be in [1, 1000]"),
    ("bench_sim", ["--steps", "100000000"], "--steps must be in [1, 10000000]"),
    ("bench_env", ["--batch", "100000"], "--batch must be in [1, 4096]"),
    ("bench_train", ["--updates", "100000000"], "--updates must be in [1, 1000000]"),
    ("loop_bench", ["--recover-frames", "100000"], "--recover-frames must be in [1, 1000]"),
    ("soak_train", ["--capacity", "1000000000000000"], "--capacity must be in [1, 1000000000]"),
    ("plot_training", ["--final-evals", "5000", "runs/none"], "--final-evals must be in [1, 1000]"),
]


@pytest.mark.parametrize(("script", "argv", "message"), CASES, ids=[f"{s} {a[-2] if len(a) > 1 else a[0]}" for s, a, _ in CASES])
def test_a_count_beyond_its_bound_is_one_line_before_any_work(script, argv, message, capsys):
    with pytest.raises(SystemExit) as exit_:
        import_script(script).main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_error_spectrum_refuses_a_missing_policy_in_one_line_before_flying(capsys):
    assert import_script("error_spectrum").main(["--controllers", "policy", "--policy", "/no/such/policy.pt"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "error_spectrum: no policy file at /no/such/policy.pt"

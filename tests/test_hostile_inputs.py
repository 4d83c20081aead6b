"""Hostile numbers for every numeric option of every command in ``scripts/``: each option found from
the command's own parser is given 0, -1, NaN and infinity, and each value is either accepted as
meaningful (``ACCEPTED`` says which, and why) or refused with one line on stderr and a non-zero
exit code, never a traceback.

Only the argument stage runs: a value is first put through the option's own type (and, for
``train_torchrl``, through ``TrainConfig``, which checks its settings after parsing); a value refused
there is then given to the command's ``main`` in this process, which must refuse it in one line
before any work. An accepted value is never run (it would start a flight or a training run).

What is meaningful:

- NaN and infinity: nowhere (every option is a count, a time, a rate, a size or a range).
- Negative numbers: only ``train_torchrl``'s ``--optim.target_entropy`` (an entropy: SAC v2's is
  minus the action size).
- Zero: a seed (``--seed 0``), a count that may be zero and says what it means in its help
  (``loop_bench --timeout-frames 0``: the PID flies at the first missed answer; ``bench_env
  --processes 0``: no multi-process figure; ``--threads 0``: torch's default), sea level for an
  altitude (``trim``, ``derivatives``, ``milspec_turbulence``: the envelope starts at 0 m), and
  ``train_torchrl``'s weights and fractions that switch a term off. Every other zero is refused.
"""

from __future__ import annotations

import argparse
import functools
import runpy
import sys
from pathlib import Path
from unittest import mock

import pytest
from conftest import import_script

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
HOSTILE = ("0", "-1", "nan", "inf")

# (command, option) -> the hostile values it takes as meaningful (see the module docstring).
ACCEPTED: dict[tuple[str, str], set[str]] = {
    ("loop_bench", "--seed"): {"0"},
    ("loop_bench", "--timeout-frames"): {"0"},
    ("bench_env", "--processes"): {"0"},
    ("bench_train", "--threads"): {"0"},
    ("trim", "--altitude-m"): {"0"},
    ("derivatives", "--altitude-m"): {"0"},
    ("error_spectrum", "--altitude-m"): {"0"},  # sea level
    ("milspec_turbulence", "--altitudes-m"): {"0"},
    ("soak_train", "--seed"): {"0"},
    ("tune_classical", "--seed"): {"0"},  # CMA-ES's seed (given to cma as seed + 1)
    # train_torchrl: TrainConfig's settings (training/config.py decides; these it may accept)
    ("train_torchrl", "--seed"): {"0"},
    ("train_torchrl", "--threads"): {"0"},
    ("train_torchrl", "--collector.init_random_frames"): {"0"},  # no random warm-up
    ("train_torchrl", "--buffer.relabel_fraction"): {"0"},  # no relabelled goals
    ("train_torchrl", "--optim.gamma"): {"0"},  # a discount of 0: each step's reward alone
    ("train_torchrl", "--caps.kappa_spatial"): {"0"},  # the CAPS term off
    ("train_torchrl", "--caps.kappa_temporal"): {"0"},
    ("train_torchrl", "--caps.action_weights"): {"0"},  # an action left out of the CAPS differences
    ("train_torchrl", "--optim.target_entropy"): {"0", "-1"},  # any finite entropy
    ("train_torchrl", "--distill.critic_warmup_updates"): {"0"},  # SAC straight after the distillation
    ("train_torchrl", "--distill.offline_share"): {"0"},  # no batch share kept for the teacher's steps
    ("train_torchrl", "--distill.bc_weight"): {"0"},  # no pull towards the teacher in SAC
}


def _train_config(parser: argparse.ArgumentParser, argv: list[str]) -> None:
    from training.config import TrainConfig

    TrainConfig.from_namespace(parser.parse_args(argv))


def _bench_config(parser: argparse.ArgumentParser, argv: list[str]) -> None:
    pytest.importorskip("pymavlink")
    import_script("loop_bench").bench_config(parser.parse_args(argv))


# Options a command requires, at valid values: given beside the hostile one.
REQUIRED = {"trim": ["--altitude-m", "1000", "--veas-mps", "10"]}


def _with_required(name: str, argv: list[str]) -> list[str]:
    """``argv`` (one option and its value) with the command's other required options."""
    required = REQUIRED.get(name, [])
    given = {**dict(zip(required[::2], required[1::2])), **dict(zip(argv[::2], argv[1::2]))}
    return [text for pair in given.items() for text in pair] if required else argv


def _flight_condition(name: str):
    """The check of a command that trims at a condition it takes (``condition(args)``)."""
    def check(parser: argparse.ArgumentParser, argv: list[str]) -> None:
        import_script(name).condition(parser.parse_args(_with_required(name, argv)))
    return check


# Commands whose settings are also checked after parsing, and how (given the parser and the arguments).
LATER_CHECKS = {"train_torchrl": _train_config, "loop_bench": _bench_config, "trim": _flight_condition("trim"),
                "derivatives": _flight_condition("derivatives")}


class _Captured(Exception):
    pass


def _parser_of(script: Path) -> argparse.ArgumentParser | None:
    """The parser the script builds, caught when it parses (no script body runs)."""
    captured = []

    def capture(self, args=None, namespace=None):
        captured.append(self)
        raise _Captured

    with mock.patch.object(argparse.ArgumentParser, "parse_args", capture), mock.patch.object(sys, "argv",
                                                                                             [str(script)]):
        try:
            runpy.run_path(str(script), run_name="__main__")
        except (_Captured, SystemExit):
            pass
    return captured[0] if captured else None


def _is_numeric(action: argparse.Action) -> bool:
    kind = action.type if action.type in (int, float) else getattr(action.type, "kind", None)
    return bool(action.option_strings) and kind in (int, float)


def _values(action: argparse.Action, value: str) -> list[str]:
    return [value] * (action.nargs if isinstance(action.nargs, int) else 1)


def _cases():
    for script in sorted(SCRIPTS.glob("*.py")):
        parser = _parser_of(script)
        for action in parser._actions if parser else ():
            if _is_numeric(action):
                for value in HOSTILE:
                    option = action.option_strings[-1]
                    yield pytest.param(script.stem, option, value, id=f"{script.stem} {option} {value}")


CASES = list(_cases())


@functools.cache
def _parser(name: str) -> argparse.ArgumentParser:
    return _parser_of(SCRIPTS / f"{name}.py")


def _refused_before_work(name: str, option: str, value: str) -> bool:
    parser = _parser(name)
    action = next(a for a in parser._actions if option in a.option_strings)
    try:
        for text in _values(action, value):
            action.type(text)
    except (argparse.ArgumentTypeError, TypeError, ValueError):
        return True
    if name in LATER_CHECKS:
        try:
            LATER_CHECKS[name](parser, [option, *_values(action, value)])
        except (ValueError, SystemExit):
            return True
    return False


def test_every_command_with_numbers_is_covered():
    names = {case.values[0] for case in CASES}
    assert {"sweep", "loop_bench", "evaluate", "train_torchrl", "trim", "bench_env"} <= names
    options = {(case.values[0], case.values[1]) for case in CASES}
    assert set(ACCEPTED) <= options, f"ACCEPTED names options no command has: {set(ACCEPTED) - options}"


@pytest.mark.parametrize(("name", "option", "value"), CASES)
def test_a_hostile_number_is_meaningful_or_refused_in_one_line(name, option, value, tmp_path, capsys):
    accepted = value in ACCEPTED.get((name, option), set())
    if not _refused_before_work(name, option, value):
        assert accepted, f"{name} {option} {value} is accepted: it should be refused before any work"
        return  # a meaningful value: not run (it would fly or train)
    if accepted and name != "train_torchrl":  # TrainConfig's ranges are training/config.py's to decide
        pytest.fail(f"{name} {option} {value} is refused, but it is meaningful (ACCEPTED)")
    action = next(a for a in _parser(name)._actions if option in a.option_strings)
    argv = _with_required(name, [option, *_values(action, value)])
    if name == "train_torchrl":
        argv += ["--log.run_root", str(tmp_path)]  # nothing is written there: the value is refused first
    capsys.readouterr()
    try:
        code = import_script(name).main(argv)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code not in (0, None), f"{name} {option} {value}: exit code {code}"
    assert "Traceback" not in err
    assert len(lines) == 1, f"{name} {option} {value}: {len(lines)} lines on stderr:\n{err}"
    assert option.lstrip("-") in lines[0], lines[0]

"""A gain table is checked for what it holds, not only for being there: malformed tables, another
controller's table, gains of the wrong sign and impossible trims are refused in one line before any
flight, and a tuning never writes one controller's table as the other's."""

from __future__ import annotations

import json
import shutil

import pytest
from conftest import import_script

from jsbsim_env.control import factory, gain_files
from jsbsim_env.control.factory import GainTableError, check_flyable


@pytest.fixture
def packaged_copy(tmp_path, monkeypatch):
    """The paper's aircraft's gain tables copied to a folder the controllers read instead."""
    for name in gain_files.FILES.values():
        if (gain_files.PACKAGED_DIR / name).is_file():
            shutil.copy(gain_files.PACKAGED_DIR / name, tmp_path / name)
    monkeypatch.setattr(gain_files, "PACKAGED_DIR", tmp_path)
    return tmp_path


def _edit_pid(folder, edit) -> None:
    path = folder / "pid_gains.json"
    table = json.loads(path.read_text())
    edit(table)
    path.write_text(json.dumps(table))


BROKEN = {
    "empty file": "",
    "a list": "[]",
    "a string": '"gains"',
    "no points": "{}",
    "NaN gain": None,  # written below from the real table
}


@pytest.mark.parametrize("case", list(BROKEN))
def test_a_malformed_table_is_refused_in_one_line(case, packaged_copy):
    path = packaged_copy / "pid_gains.json"
    if BROKEN[case] is None:
        _edit_pid(packaged_copy, lambda t: t["points"][0].update(k_pitch=float("nan")))
    else:
        path.write_text(BROKEN[case])
    with pytest.raises(GainTableError, match=r"PID gain table .*pid_gains.json") as err:
        check_flyable(["pid"])
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("edit", "words"), [
    (lambda t: t["points"][1].update(k_pitch=-t["points"][1]["k_pitch"]), "k_pitch must be >= 0"),
    (lambda t: t["points"][0].update(k_beta=abs(t["points"][0]["k_beta"])), "k_beta must be <= 0"),
    (lambda t: t["points"][0].update(throttle_trim=5.0), r"throttle_trim 5 at 500 m is outside \[0, 1\]"),
    (lambda t: t["points"][2].update(elevator_trim_deg=90.0), "elevator_trim_deg 90"),
    (lambda t: t.update(controller="lqi"), "records the LQI's gains, not the PID's"),
])
def test_inverted_signs_impossible_trims_and_another_controllers_table_are_refused(edit, words, packaged_copy):
    _edit_pid(packaged_copy, edit)
    with pytest.raises(GainTableError, match=words):
        check_flyable(["pid"])


@pytest.mark.parametrize(("script", "argv"), [
    ("benchmark", ["--controllers", "pid", "--episodes", "1", "--quick"]),
    ("sweep", ["--controllers", "pid", "--axis", "delay_ms=0", "--episodes", "1"]),
    ("evaluate", ["--controller", "pid", "--episodes", "1"]),
    ("report", ["--quick"]),
])
def test_the_commands_refuse_a_malformed_table_before_any_flight(script, argv, packaged_copy, tmp_path, capsys):
    (packaged_copy / "pid_gains.json").write_text("[]")
    out = tmp_path / "out"
    extra = [] if script == "evaluate" else ["--out", str(out)]
    assert import_script(script).main(argv + extra) == 2
    err = capsys.readouterr().err
    assert "PID gain table" in err and "Traceback" not in err and not out.exists()


def test_the_shipped_and_tuned_tables_pass_their_checks():
    for name in ("pid", "lqi", "pid_tuned", "lqi_tuned", "pid_robust", "lqi_robust"):
        factory.check_gain_table(name, gain_files.gain_file(name))


def test_a_tuning_never_writes_one_controllers_table_as_the_others(tmp_path, capsys):
    tune = import_script("tune_classical").main
    with pytest.raises(SystemExit) as exit_:
        tune(["--controller", "lqi", "--out", str(gain_files.PACKAGED_DIR / "pid_tuned_gains.json"), "--overwrite"])
    assert exit_.value.code == 2 and "named as the pid_tuned table" in capsys.readouterr().err
    held = tmp_path / "mine.json"
    shutil.copy(gain_files.PACKAGED_DIR / "pid_tuned_gains.json", held)
    with pytest.raises(SystemExit) as exit_:
        tune(["--controller", "lqi", "--out", str(held), "--overwrite"])
    assert exit_.value.code == 2 and "holds the PID's tuned table" in capsys.readouterr().err

"""The commands under bad input and on a second run: every argument is checked before any flight
(one line on stderr, exit code 2), the loop bench survives its controller process dying, and no
command replaces the results of an earlier run silently (docs/reliability.md)."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

UNWRITABLE = "/proc/solar_uav_no_such_folder"  # cannot be created, even by root


def _run(script, argv: list[str]) -> int:
    """``script.main(argv)``'s exit code, whether it returns it or exits with it."""
    try:
        code = script.main(argv)
    except SystemExit as stop:
        code = stop.code
    return 0 if code is None else code


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


class _Flew(AssertionError):
    pass


def _must_not_fly(*args, **kwargs):
    raise _Flew("a flight started before the arguments were checked")


# ---------------------------------------------------------------------------------- sweep
@pytest.fixture
def sweep(load_script, monkeypatch):
    """scripts/sweep.py, with every way of flying replaced by one that fails the test."""
    script = load_script("sweep")
    monkeypatch.setattr(script, "run_local", _must_not_fly)
    monkeypatch.setattr(script, "run_ray", _must_not_fly)
    monkeypatch.setattr("jsbsim_env.control.policy.load_policy", _must_not_fly)
    return script


@pytest.mark.parametrize("out", ["file", "under_file", "unwritable"])
def test_sweep_refuses_an_out_it_cannot_write_before_any_flight_and_at_once(out, sweep, tmp_path, capsys):
    (tmp_path / "file").write_text("not a folder")
    path = {"file": tmp_path / "file", "under_file": tmp_path / "file" / "sweep", "unwritable": Path(UNWRITABLE)}[out]
    start = time.perf_counter()
    code = _run(sweep, ["--axis", "delay_ms=0,100", "--out", str(path)])
    assert time.perf_counter() - start < 0.5
    assert code == 2 and _one_line(capsys).startswith(f"sweep: --out: {path}" if out == "file" else "sweep: --out: ")


def test_sweep_refuses_an_axis_given_twice(sweep, tmp_path, capsys):
    code = _run(sweep, ["--axis", "delay_ms=0,100", "--axis", "delay_ms=200", "--controllers", "pid",
                        "--out", str(tmp_path)])
    assert code == 2 and "axis delay_ms given twice" in _one_line(capsys)


def test_sweep_refuses_a_value_given_twice_on_one_axis(sweep, tmp_path, capsys):
    code = _run(sweep, ["--axis", "delay_ms=40,40", "--controllers", "pid", "--out", str(tmp_path)])
    assert code == 2 and "axis delay_ms: 40 given more than once" in _one_line(capsys)


@pytest.mark.parametrize(("axis", "value", "allowed"), [
    ("delay_ms", "-5", "[0, 1000] ms"),
    ("noise_scale", "-1", "[0, 100] x Table 3"),
    ("servo_rate_limit_degps", "0", "(0, 1000] deg/s"),
    ("control_interval_ms", "8.33333", "[8.33333333333333, 1000] ms"),
    ("parameter_strength", "5", "[0, 5) x Table 4"),
    ("backlash_deg", "-0.5", "[0, 20] deg"),
    ("turbulence_sigma_mps", "inf", "[0, 10] m/s"),
    ("delay_ms", "nan", "[0, 1000] ms"),
    ("altitude_m", "25000", "[0, 20000] m"),
    ("eas_mps", "20", "[8, 12] m/s"),
])
def test_sweep_refuses_an_axis_value_outside_its_range_naming_the_axis_value_and_range(axis, value, allowed, sweep,
                                                                                      tmp_path, capsys):
    code = _run(sweep, ["--axis", f"{axis}={value}", "--controllers", "pid", "--out", str(tmp_path)])
    line = _one_line(capsys)
    assert code == 2 and line.startswith(f"sweep: axis {axis}: {value} is outside its range {allowed}"), line


def test_the_envelope_of_the_sweep_is_the_simulations():
    from jsbsim_env.sim.core import CoreConfig, FlightCore
    from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS
    from training.evaluation.sweep import AXES, AXIS_RANGES, AXIS_UNITS

    assert (AXIS_RANGES["altitude_m"].low, AXIS_RANGES["altitude_m"].high) == ALTITUDE_RANGE_M
    assert (AXIS_RANGES["eas_mps"].low, AXIS_RANGES["eas_mps"].high) == EAS_RANGE_MPS
    # the training's own starts lie inside it
    paper = FlightCore(CoreConfig.ideal())
    assert AXIS_RANGES["altitude_m"].allows(paper.altitude_range_m[0])
    assert all(AXIS_RANGES["eas_mps"].allows(v) for v in paper.eas_range_mps)
    assert list(AXIS_RANGES) == list(AXES) == list(AXIS_UNITS)


def _fake_rows(jobs, policy=None, workers=1, progress=None, *rest):
    return [{"controller": job.controller, **{f"axis_{k}": v for k, v in job.condition.items()}, "episode": k,
             "return_norm": 0.5, "ended_early": False, "rmse_pitch_deg": 1.0, "rmse_beta_deg": 1.0}
            for job in jobs for k in range(job.first, job.first + job.count)]


def _earlier_run(folder: Path, command: str, files: dict[str, str | bytes]) -> None:
    """``folder`` as an earlier run of ``command`` left it: its files and the manifest naming them."""
    from training.output_folders import MANIFEST

    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        (folder / name).write_bytes(data if isinstance(data, bytes) else data.encode())
    (folder / MANIFEST).write_text(json.dumps({"version": 1, "command": command, "files": sorted(files)}))


def test_sweep_refuses_a_folder_with_an_earlier_sweep_and_overwrite_replaces_it(sweep, monkeypatch, tmp_path, capsys):
    _earlier_run(tmp_path, "sweep", {"sweep.json": "{}", "delay_ms.png": b"an earlier sweep's figure"})
    (tmp_path / "notes.txt").write_text("the user's own file")
    common = ["--axis", "backlash_deg=0,1", "--controllers", "pid", "--episodes", "1", "--out", str(tmp_path)]
    assert _run(sweep, common) == 2
    line = _one_line(capsys)
    assert "holds the results of an earlier run (delay_ms.png, sweep.json)" in line and "--overwrite" in line
    assert (tmp_path / "sweep.json").read_text() == "{}"
    monkeypatch.setattr(sweep, "run_local", _fake_rows)
    assert _run(sweep, [*common, "--overwrite", "--json"]) == 0
    capsys.readouterr()
    assert json.loads((tmp_path / "sweep.json").read_text())["flights"] == 2
    assert not (tmp_path / "delay_ms.png").exists()  # the earlier sweep's axis: not mixed with this one
    assert (tmp_path / "backlash_deg.png").is_file() and (tmp_path / "notes.txt").read_text() == "the user's own file"


def test_sweep_never_replaces_results_it_has_no_record_of_writing(sweep, tmp_path, capsys):
    (tmp_path / "sweep.json").write_text("{}")
    (tmp_path / "delay_ms.png").write_bytes(b"a figure of unknown origin")
    common = ["--axis", "backlash_deg=0,1", "--controllers", "pid", "--episodes", "1", "--out", str(tmp_path)]
    for overwrite in ([], ["--overwrite"]):
        assert _run(sweep, [*common, *overwrite]) == 2
        line = _one_line(capsys)
        assert "no earlier run of it recorded (delay_ms.png, sweep.json)" in line, line
    assert (tmp_path / "delay_ms.png").read_bytes() == b"a figure of unknown origin"


# ---------------------------------------------------------------------------------- report
@pytest.fixture
def report(load_script, monkeypatch):
    script = load_script("report")
    monkeypatch.setattr(script, "run_report", _must_not_fly)
    return script


@pytest.mark.parametrize("out", ["file", "unwritable"])
def test_report_refuses_an_out_it_cannot_write_before_any_flight_and_at_once(out, report, tmp_path, capsys):
    path = tmp_path / "file" if out == "file" else Path(UNWRITABLE)
    if out == "file":
        path.write_text("x")
    start = time.perf_counter()
    code = _run(report, ["--out", str(path), "--quick", "--controllers", "PID"])
    assert time.perf_counter() - start < 0.5
    assert code == 2 and _one_line(capsys).startswith(f"report: --out: {path if out == 'file' else ''}")


def test_report_refuses_an_earlier_report_and_overwrite_replaces_it_whole(report, monkeypatch, tmp_path, capsys):
    _earlier_run(tmp_path, "report", {"report.md": "earlier", "fig13_turbulence_RL.png": b"an earlier report's figure"})
    argv = ["--out", str(tmp_path), "--quick", "--controllers", "PID", "--experiments", "altitudes"]
    assert _run(report, argv) == 2
    assert "holds the results of an earlier run" in _one_line(capsys)
    assert (tmp_path / "report.md").read_text() == "earlier"

    def fake_report(out, policy, **kwargs):
        assert not (Path(out) / "fig13_turbulence_RL.png").exists()  # a new folder: the report lists only its own
        assert (tmp_path / "report.md").read_text() == "earlier"  # kept until the new report is complete
        (Path(out) / "report.md").write_text("new")

    monkeypatch.setattr(report, "run_report", fake_report)
    assert _run(report, [*argv, "--overwrite"]) == 0
    assert (tmp_path / "report.md").read_text() == "new"
    assert not (tmp_path / "fig13_turbulence_RL.png").exists()  # the earlier report's, not written again


def test_report_with_overwrite_keeps_the_earlier_report_when_the_policy_file_is_missing(report, tmp_path, capsys):
    _earlier_run(tmp_path, "report", {"report.md": "earlier"})
    code = _run(report, ["--out", str(tmp_path), "--overwrite", "--policy", str(tmp_path / "missing.pt")])
    assert code == 2 and "missing.pt does not exist" in _one_line(capsys)
    assert (tmp_path / "report.md").read_text() == "earlier"


# ---------------------------------------------------------------------------------- the other commands that write results
# Each command, a second run of it into a folder holding its results, and what does its work (replaced
# by a failure here, so that a command that did not refuse fails at once instead of working for minutes).
SECOND_RUNS = {
    "loop_bench": (["--controller", "pid", "--mode", "lockstep", "--out", "{out}"], "summary.json",
                   "jsbsim_env.bench.plant.run_bench"),
    "evaluate": (["--controller", "pid", "--plots", "{out}"], "doublets_500m.png", "training.evaluation.suite.evaluate"),
    "plot_effectiveness": (["--out", "{out}"], "effectiveness.json", "effectiveness"),
    "plot_training": (["{out}", "--out", "{out}/fig8.png"], "fig8.png", "run_summary"),
}


@pytest.mark.parametrize("recorded", [True, False], ids=["recorded", "unrecorded"])
@pytest.mark.parametrize("name", SECOND_RUNS)
def test_a_second_run_into_a_folder_of_results_is_refused_before_any_work(name, recorded, load_script, monkeypatch,
                                                                          tmp_path, capsys):
    argv, earlier, work = SECOND_RUNS[name]
    script = load_script(name)
    if "." in work:
        if "bench" in work:
            pytest.importorskip("pymavlink")
        monkeypatch.setattr(work, _must_not_fly)
    else:
        monkeypatch.setattr(script, work, _must_not_fly)
    single_file = name == "plot_training"  # writes one file, named by --out: no folder of its own
    if recorded and not single_file:
        _earlier_run(tmp_path, name, {earlier: "earlier"})
    else:
        (tmp_path / earlier).write_text("earlier")
    start = time.perf_counter()
    code = _run(script, [a.replace("{out}", str(tmp_path)) for a in argv])
    line = _one_line(capsys)
    assert code == 2 and time.perf_counter() - start < 0.5
    if recorded or single_file:
        assert "of an earlier run" in line and "--overwrite" in line and line.startswith(f"{name}: "), line
    else:  # files it may not replace, even with --overwrite
        assert f"no earlier run of it recorded ({earlier})" in line and line.startswith(f"{name}: "), line
    assert (tmp_path / earlier).read_text() == "earlier"


def test_the_output_file_helper_refuses_an_earlier_result_and_a_folder(tmp_path):
    from training.runtime import OutputFolderError, claim_output_file

    (tmp_path / "data.csv").write_text("data.csv")
    with pytest.raises(OutputFolderError, match="data.csv holds the result of an earlier run"):
        claim_output_file(tmp_path / "data.csv")
    with pytest.raises(OutputFolderError, match="is a folder"):
        claim_output_file(tmp_path)
    assert claim_output_file(tmp_path / "data.csv", overwrite=True) == tmp_path / "data.csv"


# ---------------------------------------------------------------------------------- the loop bench
@pytest.fixture
def loop_bench(load_script, monkeypatch):
    pytest.importorskip("pymavlink")
    monkeypatch.setattr("jsbsim_env.bench.plant.run_bench", _must_not_fly)
    return load_script("loop_bench")


@pytest.mark.parametrize(("argv", "says"), [
    (["--timeout-frames", "-1"], "--timeout-frames must be at least 0, got -1"),
    (["--recover-frames", "0"], "--recover-frames must be in [1, 1000], got 0"),
    (["--duration", "nan"], "--duration must be in [2, 3600] s, got nan"),
    (["--duration", "0"], "--duration must be in [2, 3600] s, got 0"),
    (["--duration", "1e-300"], "--duration must be in [2, 3600] s, got 1e-300"),  # one frame, RMSE 0.000
    (["--baud", "0"], "--baud must be in [1, 4000000], got 0"),
    (["--seed", "-1"], "--seed must be at least 0, got -1"),
    (["--faults", "delay_ms=1e9"], "fault delay_ms=1e+09 is more than the line can carry in time"),
    (["--faults", "delay_ms=60"], "the most delay_ms is 50.8"),
    (["--faults", "delay_ms=20", "--timeout-frames", "0"], "hold time, 1 frame of 40 ms = 40 ms"),
    (["--baud", "9600"], "baud 9600 is too slow for real time"),
    (["--faults", "drop=nan"], "fault drop is a probability in [0, 1], got nan"),
    (["--faults", "corrupt=-0.1"], "fault corrupt is a probability in [0, 1], got -0.1"),
    (["--faults", "disconnect_at=-1"], "fault disconnect_at must be a finite number >= 0 (s), got -1.0"),
    (["--faults", "stall_s=inf"], "fault stall_s must be a finite number >= 0 (s), got inf"),
    (["--faults", "disconnect_at=100"], "fault disconnect_at=100 is at or after the flight's end (60 s)"),
    (["--faults", "drop=0.1,drop=0.2"], "fault drop given twice"),
    (["--faults", "drop=lots"], "fault drop must be a number, got 'lots'"),
])
def test_loop_bench_refuses_a_meaningless_number_in_one_line_before_the_controller_starts(argv, says, loop_bench,
                                                                                          tmp_path, capsys):
    start = time.perf_counter()
    code = _run(loop_bench, [*argv, "--controller", "pid", "--out", str(tmp_path)])
    line = _one_line(capsys)
    assert code == 2 and time.perf_counter() - start < 1.0
    assert line.startswith("loop_bench: ") and says in line, line


def test_the_loop_bench_duration_limit_is_the_plants(load_script):
    pytest.importorskip("pymavlink")
    from jsbsim_env.bench.plant import MAX_DURATION_S, MIN_DURATION_S, BenchConfig

    assert load_script("loop_bench").MAX_DURATION_S == MAX_DURATION_S
    assert load_script("loop_bench").MIN_DURATION_S == MIN_DURATION_S
    with pytest.raises(ValueError, match="2 to 3600 s"):
        BenchConfig(duration_s=MAX_DURATION_S + 1)
    with pytest.raises(ValueError, match=r"2 to 3600 s \(the shortest flight whose RMSE means something"):
        BenchConfig(duration_s=1e-300)


def test_a_controller_process_killed_mid_flight_is_survived_and_recorded(load_script, monkeypatch, tmp_path, capsys):
    """SIGKILL at 10 s of a 20 s flight: the failsafe PID flies the rest, and summary.json, frames.npz and
    the plot are written, with the loss in the summary."""
    pytest.importorskip("pymavlink")
    from jsbsim_env.bench import plant as plant_module

    killed = []

    def run_and_kill(cfg, progress=None):
        plant = plant_module.Plant(cfg)

        def watch(fraction):
            if fraction >= 0.5 and not killed:
                os.kill(plant.process.proc.pid, signal.SIGKILL)
                killed.append(fraction)

        return plant.run(watch)

    monkeypatch.setattr(plant_module, "run_bench", run_and_kill)
    script = load_script("loop_bench")
    code = _run(script, ["--mode", "lockstep", "--controller", "pid", "--duration", "20", "--no-compare", "--json",
                         "--out", str(tmp_path)])
    assert code == 0 and killed == [0.5], capsys.readouterr().err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary == json.loads(capsys.readouterr().out)
    assert summary["frames"] == 500 and summary["ended_early"] is None
    assert 10.0 <= summary["controller_lost_at_s"] <= 10.2 and summary["controller_exit_code"] == -signal.SIGKILL
    events = summary["failsafe_events"]
    assert [e["event"] for e in events] == ["controller_lost", "pid_takeover"] and summary["failsafe_takeovers"] == 1
    assert events[1]["time_s"] <= summary["controller_lost_at_s"] + 3 * 0.04 + 1e-9  # the stated timeout
    frames = np.load(tmp_path / "frames.npz")
    assert (frames["source"][frames["time_s"] > events[1]["time_s"]] == 2).all()  # the PID to the end
    assert (frames["source"][frames["time_s"] < 10.0] == 0).all()  # the controller process before
    assert (tmp_path / "loop_bench.png").stat().st_size > 0


def test_in_real_time_too_a_killed_controller_process_hands_over_to_the_pid_and_the_flight_finishes():
    pytest.importorskip("pymavlink")
    from jsbsim_env.bench.plant import PID, BenchConfig, Plant

    plant = Plant(BenchConfig(mode="realtime", controller="pid", duration_s=3.0))

    def kill_after_a_second(fraction):
        if plant.process.alive():
            os.kill(plant.process.proc.pid, signal.SIGKILL)

    result = plant.run(kill_after_a_second)  # progress comes once a second of flight
    s, f = result.summary, result.frames
    assert s["frames"] == 75 and s["ended_early"] is None
    assert 1.0 <= s["controller_lost_at_s"] <= 1.2 and s["failsafe_takeovers"] == 1
    assert (f["source"][f["time_s"] >= s["controller_lost_at_s"] + 0.2] == PID).all()

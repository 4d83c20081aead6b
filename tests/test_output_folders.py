"""Output folders (training.output_folders): a command replaces only the files its own earlier run
recorded, refuses a folder another command owns or one holding files it would write that no run
of it recorded, and moves its results into place only when all are written, so an error or a
Ctrl-C leaves the earlier results as they were. Worker pools start no more processes than the
work and the cores (training.workers.pool_size)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from test_reliability_scripts import _one_line, _run

from training.output_folders import MANIFEST, OutputFolder, read_manifest, write_json_atomic, writing
from training.runtime import OutputFolderError


def _must_not_fly(*args, **kwargs):
    raise AssertionError("a flight started before the output folder was checked")


def _earlier_run(folder: Path, command: str, files: dict[str, str]) -> None:
    """``folder`` as an earlier run of ``command`` left it: its files and its manifest."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text)
    write_json_atomic(folder / MANIFEST, {"version": 1, "command": command, "files": sorted(files)})


def _no_staging_left(parent: Path) -> bool:
    return not [p for p in parent.iterdir() if p.name.startswith(".staging_")]


# ---------------------------------------------------------------------------------- the helper
def test_overwrite_replaces_only_the_files_the_earlier_run_recorded(tmp_path):
    out = tmp_path / "out"
    _earlier_run(out, "report", {"report.md": "earlier", "fig1_a.png": "earlier figure"})
    (out / "notes.txt").write_text("the user's own")
    with pytest.raises(OutputFolderError, match=r"holds the results of an earlier run \(fig1_a.png, report.md\)"):
        OutputFolder(out, "report", ("report.md", "fig*.png")).claim()
    folder = OutputFolder(out, "report", ("report.md", "fig*.png"), overwrite=True).claim()
    with writing(folder) as staging:
        (staging / "report.md").write_text("new")
    assert (out / "report.md").read_text() == "new"
    assert not (out / "fig1_a.png").exists()  # the earlier run's, not written again: removed
    assert (out / "notes.txt").read_text() == "the user's own"  # never the command's: kept
    assert read_manifest(out)["files"] == ["report.md"] and _no_staging_left(tmp_path)


def test_a_folder_with_files_the_command_would_write_but_no_record_is_refused_even_with_overwrite(tmp_path):
    (tmp_path / "fig1_architecture.png").write_text("a documentation figure")
    for overwrite in (False, True):
        with pytest.raises(OutputFolderError, match=r"holds files report would write that no earlier run of it "
                                                    r"recorded \(fig1_architecture.png\)"):
            OutputFolder(tmp_path, "report", ("report.md", "fig*.png"), overwrite).claim()
    # ... and so is a file of that kind beside an earlier run's recorded ones
    _earlier_run(tmp_path / "run", "report", {"report.md": "earlier"})
    (tmp_path / "run" / "fig2_mine.png").write_text("the user's figure")
    with pytest.raises(OutputFolderError, match=r"no earlier run of it recorded \(fig2_mine.png\)"):
        OutputFolder(tmp_path / "run", "report", ("report.md", "fig*.png"), True).claim()


def test_a_folder_another_command_owns_is_refused_even_with_overwrite(tmp_path):
    _earlier_run(tmp_path, "sweep", {"command.txt": "python scripts/sweep.py", "sweep.json": "{}"})
    with pytest.raises(OutputFolderError, match=r"holds the results of sweep .*give another folder for benchmark's"):
        OutputFolder(tmp_path, "benchmark", ("benchmark.json", "command.txt"), True).claim()


def test_a_damaged_manifest_is_one_line(tmp_path):
    (tmp_path / MANIFEST).write_text('{"command": "rep')
    with pytest.raises(OutputFolderError, match="is damaged"):
        OutputFolder(tmp_path, "report", ("report.md",), True).claim()


def test_an_error_while_writing_leaves_the_earlier_results_and_no_temporary_folder(tmp_path):
    out = tmp_path / "out"
    _earlier_run(out, "sweep", {"sweep.json": "earlier"})
    folder = OutputFolder(out, "sweep", ("sweep.json",), overwrite=True).claim()
    with pytest.raises(KeyboardInterrupt), writing(folder) as staging:
        (staging / "sweep.json").write_text("half")
        raise KeyboardInterrupt
    assert (out / "sweep.json").read_text() == "earlier" and read_manifest(out)["files"] == ["sweep.json"]
    assert _no_staging_left(tmp_path)


def test_a_new_folder_is_created_only_at_the_commit(tmp_path):
    folder = OutputFolder(tmp_path / "a" / "b", "sweep", ("sweep.json",)).claim()
    assert not (tmp_path / "a" / "b").exists()
    with writing(folder) as staging:
        assert staging.parent == tmp_path / "a" and not (tmp_path / "a" / "b").exists()
        (staging / "sweep.json").write_text("{}")
    assert sorted(p.name for p in (tmp_path / "a" / "b").iterdir()) == ["sweep.json", MANIFEST]


# ---------------------------------------------------------------------------------- the commands
@pytest.fixture
def report(load_script, monkeypatch):
    script = load_script("report")
    monkeypatch.setattr(script, "run_report", _must_not_fly)
    return script


def test_report_overwrite_interrupted_during_the_flights_keeps_the_earlier_report(report, monkeypatch, tmp_path):
    out = tmp_path / "report"
    _earlier_run(out, "report", {"report.md": "earlier", "metrics.json": "{}", "fig7_altitudes.png": "earlier"})

    def interrupted(folder, policy, **kwargs):
        (Path(folder) / "report.md").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "run_report", interrupted)
    with pytest.raises(KeyboardInterrupt):
        report.main(["--out", str(out), "--overwrite", "--quick", "--controllers", "PID", "--experiments", "altitudes"])
    assert {p.name: p.read_text() for p in out.iterdir() if p.name != MANIFEST} == {
        "report.md": "earlier", "metrics.json": "{}", "fig7_altitudes.png": "earlier"}
    assert _no_staging_left(tmp_path)


def test_report_overwrite_into_a_documentation_folder_is_refused_before_any_flight(report, tmp_path, capsys):
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "fig1_architecture.png").write_text("a documentation figure")
    (docs / "training.md").write_text("a page")
    start = time.perf_counter()
    code = _run(report, ["--out", str(docs), "--overwrite", "--quick", "--controllers", "PID"])
    line = _one_line(capsys)
    assert code == 2 and time.perf_counter() - start < 0.5
    assert line.startswith("report: --out: ") and "fig1_architecture.png" in line, line
    assert (docs / "fig1_architecture.png").read_text() == "a documentation figure"


def test_benchmark_overwrite_into_a_sweeps_folder_is_refused_before_any_flight(load_script, monkeypatch, tmp_path,
                                                                               capsys):
    script = load_script("benchmark")
    monkeypatch.setattr(script, "run_local", _must_not_fly)
    monkeypatch.setattr(script, "check_flyable", _must_not_fly)
    _earlier_run(tmp_path, "sweep", {"command.txt": "python scripts/sweep.py --axis delay_ms=0", "sweep.json": "{}"})
    code = _run(script, ["--controllers", "pid", "--families", "steps", "--episodes", "1", "--quick",
                         "--out", str(tmp_path), "--overwrite"])
    line = _one_line(capsys)
    assert code == 2 and line.startswith("benchmark: --out: ") and "sweep" in line, line
    assert (tmp_path / "command.txt").read_text() == "python scripts/sweep.py --axis delay_ms=0"


def test_benchmark_caps_its_workers_and_writes_nothing_when_its_flights_fail(load_script, monkeypatch,
                                                                                   tmp_path, capsys):
    script = load_script("benchmark")
    seen = {}

    def no_flights(jobs, policy, workers, progress, run=None):
        seen["workers"], seen["jobs"] = workers, len(jobs)
        raise RuntimeError("no flights in this test")

    monkeypatch.setattr(script, "run_local", no_flights)
    argv = ["--controllers", "pid", "--families", "steps", "--episodes", "1", "--quick", "--out", str(tmp_path),
            "--workers", "200", "--no-progress"]
    assert _run(script, argv) == 2
    capsys.readouterr()
    from training.workers import pool_size

    assert seen["workers"] == pool_size(200, seen["jobs"]) <= seen["jobs"]
    assert list(tmp_path.iterdir()) == []  # nothing written by a benchmark that failed


# ---------------------------------------------------------------------------------- worker pools
def test_a_pool_never_starts_more_processes_than_the_work_or_the_cores():
    import os

    from training.workers import pool_size

    cores = len(os.sched_getaffinity(0))
    assert pool_size(200, 3) == min(3, cores)
    assert pool_size(200) == cores
    assert pool_size(1, 10) == 1 and pool_size(5, 0) == 1
    with pytest.raises(ValueError):
        pool_size(0, 3)


def test_run_local_with_200_workers_for_2_jobs_starts_at_most_2_processes(monkeypatch):
    import contextlib

    import training.workers
    from training.evaluation import sweep

    started = {}
    real = training.workers.process_pool

    @contextlib.contextmanager
    def counting(workers, grace_s=training.workers.STOP_GRACE_S, jobs=None):
        started["processes"] = training.workers.pool_size(workers, jobs)
        with real(workers, grace_s, jobs) as pool:
            yield pool

    monkeypatch.setattr(training.workers, "process_pool", counting)
    rows = sweep.run_local([1, 2], None, 200, run=_double)
    assert rows == [2, 4] and started.get("processes", 1) <= 2


def _double(job, policy):
    return [2 * job]


def test_manifest_is_json_with_the_command_line(tmp_path):
    folder = OutputFolder(tmp_path / "o", "sweep", ("sweep.json",), invocation="python scripts/sweep.py --x").claim()
    with writing(folder) as staging:
        (staging / "sweep.json").write_text("{}")
    manifest = json.loads((tmp_path / "o" / MANIFEST).read_text())
    assert manifest["command"] == "sweep" and manifest["invocation"] == "python scripts/sweep.py --x"


# ---------------------------------------------------------------------------------- damaged files
def test_ablation_on_a_truncated_scorecard_is_one_line_before_any_flight(load_script, monkeypatch, tmp_path, capsys):
    from conftest import write_untrained_run

    script = load_script("ablation")
    monkeypatch.setattr(script, "score", _must_not_fly)
    run = write_untrained_run(tmp_path, "c1_seed0", 0)
    (run / "scorecard").mkdir()
    (run / "scorecard" / "scorecard.json").write_text('{"key": {"scoring": 2, "contr')
    code = _run(script, [str(run), "--episodes", "1", "--quick"])
    line = _one_line(capsys)
    assert code == 2 and line.startswith("ablation: ") and "scorecard.json is damaged" in line, line


def test_an_atomic_write_leaves_the_file_whole_or_as_it_was(tmp_path, monkeypatch):
    path = tmp_path / "scorecard.json"
    write_json_atomic(path, {"a": 1})

    def full_disk(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("os.fsync", full_disk)
    with pytest.raises(OSError):
        write_json_atomic(path, {"a": 2})
    assert json.loads(path.read_text()) == {"a": 1} and [p.name for p in tmp_path.iterdir()] == ["scorecard.json"]

"""``scripts/build_aircraft.py`` never writes over what it did not make: an occupied ``--out`` and a
user's description without ``--out`` (the package) are refused in one line before any analysis,
``--from-data`` refuses a data set computed from another description, and a build that fails or
is stopped midway leaves nothing behind (it is written into a temporary folder and moved into
place only when all of it succeeded). The analysis is replaced here by one that fails if called,
or that raises midway: each case takes well under a second."""

from __future__ import annotations

import shutil

import pytest
from test_description import _edited

import aircraft
from aircraft.design import aero_data, build, xml_writer
from aircraft.design.description import PAPER_AIRCRAFT


def _snapshot(folder):
    """Every file under ``folder``, relative path -> bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def build_main(load_script):
    return load_script("build_aircraft").main


@pytest.fixture
def no_analysis(monkeypatch):
    """The aerodynamic analysis, replaced by one that fails the test if it runs."""

    def analysis(*args, **kwargs):
        raise AssertionError("the analysis ran")

    monkeypatch.setattr(aero_data, "compute_aero_data", analysis)


def _one_line(capsys, *named: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("build_aircraft: "), err
    for text in named:
        assert text in err, err
    return err


def _no_staging_left(parent):
    assert not [p for p in parent.iterdir() if p.name.startswith(build.STAGING_PREFIX)]


@pytest.mark.parametrize("holding", ["a file", "another aircraft", "an earlier build"])
def test_an_occupied_out_is_refused_before_any_analysis(tmp_path, capsys, build_main, no_analysis, holding):
    out = tmp_path / "out"
    if holding == "a file":
        (out / "notes").mkdir(parents=True)
        (out / "notes" / "mine.txt").write_text("mine")
    else:
        shutil.copytree(aircraft.aircraft_dir(), out / "aircraft" / ("survey_uav" if holding == "another aircraft"
                                                                     else "solar_uav"))
        shutil.copy(aero_data.DATA_PATH, out / "aero_data.json")
    before = _snapshot(out)
    assert build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--no-survey"]) == 2
    _one_line(capsys, str(out), "is not empty", "give a new or empty folder")
    assert _snapshot(out) == before
    _no_staging_left(tmp_path)
    if holding != "an earlier build":  # --from-data rewrites only a folder holding this aircraft's build
        assert build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--from-data", "--no-survey"]) == 2
        _one_line(capsys, "which no build of solar_uav wrote")
        assert _snapshot(out) == before


def test_out_as_a_file_or_inside_the_package_is_refused(tmp_path, package_copy, capsys, build_main, no_analysis):
    (tmp_path / "file").write_text("x")
    assert build_main([str(PAPER_AIRCRAFT), "--out", str(tmp_path / "file")]) == 2
    _one_line(capsys, "is not a folder")
    before = _snapshot(package_copy)
    for inside in (package_copy / "aircraft" / "mine", package_copy / "aircraft", package_copy):
        assert build_main([str(PAPER_AIRCRAFT), "--out", str(inside)]) == 2
        _one_line(capsys, "the package's folder")
    assert _snapshot(package_copy) == before


def test_a_users_description_never_writes_into_the_package(tmp_path, package_copy, capsys, build_main, no_analysis):
    # Named as the packaged aircraft, edited: refused without --out, whatever its name.
    before = _snapshot(package_copy)
    same_name = _edited(tmp_path, r"^mass_kg = 359.0", "mass_kg = 350.0", name="solar_uav.toml")
    copy = tmp_path / "copy" / "solar_uav.toml"
    copy.parent.mkdir()
    shutil.copy(PAPER_AIRCRAFT, copy)  # even an exact copy: only the package's own file builds into it
    for description in (same_name, copy):
        for extra in ([], ["--from-data"]):
            assert build_main([str(description), "--no-survey", *extra]) == 2
            _one_line(capsys, "is not the package's own description", "give --out DIR")
    assert _snapshot(package_copy) == before


def test_from_data_refuses_a_data_set_of_another_description_naming_the_key(tmp_path, capsys, build_main,
                                                                             no_analysis):
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(aero_data.DATA_PATH, out / "aero_data.json")
    before = _snapshot(out)
    for old, new, key in ((r"^span_m = 35.0", "span_m = 36.0", "wing.span_m"),
                          (r"^mass_kg = 359.0", "mass_kg = 350.0", "mass.mass_kg"),
                          (r"^sense = -1", "sense = 1", "rotors[0].sense"),
                          (r'^name = "solar_uav"', 'name = "other_uav"', "name")):
        changed = _edited(tmp_path, old, new)
        assert build_main([str(changed), "--out", str(out), "--from-data", "--no-survey"]) == 2
        _one_line(capsys, f"was computed from another description ({key} differs)", "without --from-data")
        assert _snapshot(out) == before
    _no_staging_left(tmp_path)


@pytest.mark.parametrize("stop", [RuntimeError("singular matrix"), KeyboardInterrupt()], ids=["error", "ctrl-c"])
def test_a_build_failing_or_stopped_midway_leaves_no_folder(tmp_path, capsys, build_main, monkeypatch, stop):
    def analysis(geometry, log=None):
        (tmp_path / "started").write_text("")
        raise stop

    monkeypatch.setattr(aero_data, "compute_aero_data", analysis)
    out = tmp_path / "new" / "deeper" / "out"
    if isinstance(stop, KeyboardInterrupt):
        with pytest.raises(KeyboardInterrupt):
            build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--no-survey"])
    else:
        assert build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--no-survey"]) == 2
        _one_line(capsys, str(PAPER_AIRCRAFT), "the build failed (RuntimeError: singular matrix)", "nothing was written")
    assert (tmp_path / "started").exists()  # it failed in the analysis, not before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["started"]  # not even the folders made for it


@pytest.mark.parametrize("stop", [RuntimeError("disk full"), KeyboardInterrupt()], ids=["error", "ctrl-c"])
def test_a_from_data_rebuild_failing_midway_leaves_the_earlier_build_as_it_was(tmp_path, capsys, build_main,
                                                                               monkeypatch, stop):
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(aero_data.DATA_PATH, out / "aero_data.json")
    assert build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--from-data", "--no-survey", "--no-controllers"]) == 0
    capsys.readouterr()
    before = _snapshot(out)
    assert "aircraft/solar_uav/solar_uav.xml" in before and "build_report.md" in before

    real_write = xml_writer.write

    def write_half(files, folder):  # half of the files, then the failure
        real_write(dict(list(files.items())[: len(files) // 2]), folder)
        raise stop

    monkeypatch.setattr(xml_writer, "write", write_half)
    if isinstance(stop, KeyboardInterrupt):
        with pytest.raises(KeyboardInterrupt):
            build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--from-data", "--no-survey", "--no-controllers"])
    else:
        assert build_main([str(PAPER_AIRCRAFT), "--out", str(out), "--from-data", "--no-survey",
                           "--no-controllers"]) == 2
        _one_line(capsys, "the build failed (RuntimeError: disk full)")
    assert _snapshot(out) == before
    _no_staging_left(tmp_path)


@pytest.fixture
def package_copy(tmp_path, monkeypatch):
    """A copy of the package's JSBSim root (the paper's aircraft's folder and data set) that the
    build takes for the package's own."""
    root = tmp_path / "package"
    shutil.copytree(aircraft.aircraft_dir(), root / "aircraft" / "solar_uav")
    (root / "aircraft" / "solar_uav" / "written_by_another_command.xml").write_text("<kept/>")
    data = root / "aircraft" / "design" / "aero_data.json"
    data.parent.mkdir()
    shutil.copy(aero_data.DATA_PATH, data)
    monkeypatch.setattr(build, "jsbsim_root", lambda: root)
    monkeypatch.setattr(aero_data, "DATA_PATH", data)
    return root


def test_the_package_is_rebuilt_from_its_own_description(package_copy, capsys, build_main):
    folder = package_copy / "aircraft" / "solar_uav"
    (folder / "Aerodynamics.xml").write_text("<stale/>")
    assert build_main(["--from-data", "--no-survey"]) == 0
    assert f"wrote 17 files under {folder}" in capsys.readouterr().out
    assert (folder / "Aerodynamics.xml").read_bytes() == (aircraft.aircraft_dir() / "Aerodynamics.xml").read_bytes()
    assert (folder / "written_by_another_command.xml").read_text() == "<kept/>"  # what the build does not write
    assert aircraft.model_fingerprint(folder=folder) != ""
    _no_staging_left(package_copy / "aircraft")


def test_a_package_rebuild_failing_midway_leaves_the_package_as_it_was(package_copy, capsys, build_main,
                                                                       monkeypatch):
    before = _snapshot(package_copy)

    def analysis(geometry, log=None):
        raise ValueError("no tail incidence trims")

    monkeypatch.setattr(aero_data, "compute_aero_data", analysis)
    assert build_main(["--no-survey"]) == 2
    _one_line(capsys, "no tail incidence trims")
    assert _snapshot(package_copy) == before

"""``scripts/evaluate.py --compare``: given policy files, the shipped policy and the PID flown on
the same suite, side by side."""

import json
import shutil

from jsbsim_env.control.policy import shipped_policy_path


def test_compare_flies_every_controller_on_the_same_suite(tmp_path, capsys, load_script):
    evaluate = load_script("evaluate")
    copy = tmp_path / "copy_of_shipped.pt"
    shutil.copyfile(shipped_policy_path(), copy)
    assert evaluate.main(["--compare", str(copy), "--episodes", "1", "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert list(results) == [str(copy), "shipped", "PID"]
    # The same weights and stack on the same suite fly the same numbers; the PID flies others.
    assert json.dumps(results[str(copy)]["episodes"], sort_keys=True) == json.dumps(results["shipped"]["episodes"],
                                                                                    sort_keys=True)
    assert results["PID"]["episodes"] != results["shipped"]["episodes"]


def test_compare_prints_one_table(tmp_path, capsys, load_script):
    evaluate = load_script("evaluate")
    copy = tmp_path / "mine.pt"
    shutil.copyfile(shipped_policy_path(), copy)
    assert evaluate.main(["--compare", str(copy), "--episodes", "1"]) == 0
    out = capsys.readouterr().out
    header, rule, *rows = out.splitlines()
    assert header.split() == ["controller", str(copy), "shipped", "PID"]
    assert set(rule.replace(" ", "")) == {"-"}
    returns = next(row for row in rows if row.startswith("return"))
    assert returns.split()[-3] == returns.split()[-2]  # the copy and the shipped policy fly alike


def test_one_controller_prints_readable_tables_and_json_only_when_asked(capsys, load_script):
    evaluate = load_script("evaluate")
    assert evaluate.main(["--controller", "pid", "--episodes", "1"]) == 0
    out = capsys.readouterr().out
    assert not out.lstrip().startswith("{")
    lines = out.splitlines()
    assert lines[0] == "PID: gain-scheduled PID"
    doublets = next(line for line in lines if line.startswith("doublets"))
    assert doublets.split()[-3:] == ["500m", "5000m", "15000m"]
    settling = next(line for line in lines if line.startswith("settling time pitch"))
    assert settling.count("/") == 6  # three steps at each of three altitudes
    assert evaluate.main(["--controller", "pid", "--episodes", "1", "--json"]) == 0
    as_json = json.loads(capsys.readouterr().out)
    row = next(line for line in lines if line.startswith("RMSE roll, deg"))
    assert float(row.split()[-1]) == round(as_json["episodes"]["mean_rmse_roll_deg"], 2)

"""Every kind of bad input: one line per problem naming file, line and key; exit 2; no output."""

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app

ROOT = Path(__file__).resolve().parents[2]
FOURBAR = (ROOT / "tests" / "data" / "fourbar.yaml").read_text()
runner = CliRunner()


def _mech(tmp_path: Path, text: str, name: str = "m.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _scenario(tmp_path: Path, mech_rel: str = "m.yaml", extra: str = "") -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(
        "name: s\ntask: fk\nmechanism: " + mech_rel + "\nunits: {angle: deg}\n"
        "fk:\n  time: {start: 0, stop: 1, step: 0.5}\n  motion:\n"
        "    q_crank: {type: ramp, from: 60, to: 70}\n" + extra
    )
    return p


def _run_fk(tmp_path: Path, scenario: Path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["fk", str(scenario), "--out", str(out), "--no-plots"])
    return res, out


def _mutate(path_keys, value, text=FOURBAR):
    d = yaml.safe_load(text)
    cur = d
    for k in path_keys[:-1]:
        cur = cur[k]
    if value is _DELETE:
        del cur[path_keys[-1]]
    else:
        cur[path_keys[-1]] = value
    return yaml.safe_dump(d, sort_keys=False)


_DELETE = object()

CASES = {
    "yaml syntax": ("name: fourbar\nlinks: [\n", r"m\.yaml:\d+: YAML syntax error"),
    "unknown key": (_mutate(["links", 1, "colour"], "red"),
                    r"m\.yaml:\d+: links\[1\]\.colour: unknown key \(valid keys: name"),
    "empty limits": (_mutate(["joints", 0, "limits"], []),  # once an IndexError (exit 3)
                     r"m\.yaml:\d+: joints\[0\]: limits: expected a \[lo, hi\] pair, got \[\]"),
    "wrong type": (_mutate(["joints", 0, "home"], "sixty"),
                   r"m\.yaml:\d+: joints\[0\]\.home: "),
    "missing link": (_mutate(["joints", 1, "child"], "couplr"),
                     r"m\.yaml:\d+: joints\[1\]\.child: unknown link 'couplr'"),
    "duplicate link": (_mutate(["links", 3, "name"], "coupler"),
                       r"m\.yaml:\d+: links\[3\]\.name: duplicate link 'coupler'"),
    "loop without cut": (
        _mutate(["joints", 2, "child"], "coupler"),
        r"m\.yaml:\d+: joints\[2\]\.child: link 'coupler' is already the child of joint "
        r"'q_coupler': a closed loop needs a cut",
    ),
    "cut on one branch": (
        _mutate(["cuts", 0, "frames"], ["coupler_end", "coupler"]),
        r"m\.yaml:\d+: cuts\[0\]\.frames: frames 'coupler_end' and 'coupler' lie on the same "
        r"branch",
    ),
    "unknown independent": (_mutate(["independent"], ["q_crnk"]),
                            r"m\.yaml:\d+: independent\[0\]: unknown joint 'q_crnk'"),
    "too many independent": (
        _mutate(["independent"], ["q_crank", "q_rocker"]),
        r"m\.yaml:\d+: independent: expected 1 independent joints .* got 2",
    ),
    "too few independent": (_mutate(["independent"], []),
                            r"m\.yaml:\d+: independent: expected 1 independent joints"),
    "unknown units": (_mutate(["units", "length"], "inch"),
                      r"m\.yaml:\d+: units\.length: Input should be 'm' or 'mm'"),
    "non-finite": (FOURBAR.replace("xyz: [0.3, 0, 0]", "xyz: [.nan, 0, 0]"),
                   r"m\.yaml:\d+: joints\[1\]\.origin\.xyz\[0\]: Input should be a finite "
                   r"number"),
    "missing end effector frame": (_mutate(["end_effector"], "tool"),
                                   r"m\.yaml:\d+: end_effector: unknown frame 'tool'"),
    "duplicate key": (FOURBAR.replace("name: fourbar", "name: fourbar\nname: again"),
                      r"m\.yaml:\d+: name: duplicate key"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_mechanism_file(tmp_path, case):
    text, pattern = CASES[case]
    _mech(tmp_path, text)
    res, out = _run_fk(tmp_path, _scenario(tmp_path))
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert lines, "no message"
    import re

    assert any(re.search(pattern, ln) for ln in lines), lines
    assert all("Traceback" not in ln for ln in lines)
    assert not out.exists()


def test_scenario_missing_mechanism_file(tmp_path):
    res, out = _run_fk(tmp_path, _scenario(tmp_path, "nowhere.yaml"))
    assert res.exit_code == 2
    assert "s.yaml:3: mechanism: mechanism file not found: nowhere.yaml" in res.stderr
    assert not out.exists()


def test_scenario_unknown_joint_in_motion(tmp_path):
    _mech(tmp_path, FOURBAR)
    s = _scenario(tmp_path, extra="    q_elbow: {type: constant, value: 1}\n")
    res, out = _run_fk(tmp_path, s)
    assert res.exit_code == 2
    assert "fk.motion.q_elbow: 'q_elbow' is not an independent joint" in res.stderr
    assert not out.exists()


def test_scenario_unknown_key_and_wrong_type_all_reported(tmp_path):
    _mech(tmp_path, FOURBAR)
    s = tmp_path / "s.yaml"
    s.write_text("name: s\ntask: fk\nmechanism: m.yaml\nbogus: 1\n"
                 "fk:\n  time: {start: 0, stop: one, step: 0.5}\n  motion: {}\n")
    res, out = _run_fk(tmp_path, s)
    assert res.exit_code == 2
    assert "s.yaml:4: bogus: unknown key" in res.stderr
    assert not out.exists()


def test_missing_scenario_file(tmp_path):
    res, _ = _run_fk(tmp_path, tmp_path / "nope.yaml")
    assert res.exit_code == 2
    assert "nope.yaml: file not found" in res.stderr


def test_check_reports_every_problem_and_passes_good_files(tmp_path):
    bad = _mech(tmp_path, _mutate(["links", 1, "colour"], "red"), "bad.yaml")
    good = ROOT / "mechanisms" / "puma560.yaml"
    res = runner.invoke(app, ["check", str(bad), str(good)])
    assert res.exit_code == 2
    assert "bad.yaml" in res.stderr and "colour" in res.stderr
    assert f"{good}: ok" in res.stdout


def test_schema_commands_print_json():
    import json

    for kind in ("mechanism", "scenario"):
        res = runner.invoke(app, ["schema", kind])
        assert res.exit_code == 0
        s = json.loads(res.stdout)
        assert "properties" in s
    res = runner.invoke(app, ["schema", "robot"])
    assert res.exit_code == 2


def test_info_on_a_scenario_file_says_so():
    res = runner.invoke(app, ["info", str(ROOT / "scenarios" / "puma560_wave_fk.yaml")])
    assert res.exit_code == 2
    assert "this is a scenario file" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1

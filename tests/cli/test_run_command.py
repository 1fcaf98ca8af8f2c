"""``mechkin run PATH...``: scenarios of files and folders, one line each, exit codes that separate
solver failures (1), failed expects (5), bad input (2), internal errors (3); JUnit XML that a
JUnit schema accepts, one testcase per scenario and one per expect entry; the JSON summary."""

import json
import os
import shutil
from pathlib import Path

import pytest
import yaml
from lxml import etree
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.cli.run_many import overall_code

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()

# A JUnit XML schema (the elements and attributes of the Jenkins / Ant JUnit format that CI
# test reporters read), typed in: testsuites > testsuite > properties?, testcase*; a testcase
# holds at most one failure or error, then system-out / system-err.
JUNIT_XSD = b"""<?xml version="1.0" encoding="UTF-8"?>
<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" elementFormDefault="qualified">
  <xs:simpleType name="count"><xs:restriction base="xs:nonNegativeInteger"/></xs:simpleType>
  <xs:simpleType name="seconds"><xs:restriction base="xs:decimal">
    <xs:minInclusive value="0"/></xs:restriction></xs:simpleType>
  <xs:complexType name="problem">
    <xs:simpleContent><xs:extension base="xs:string">
      <xs:attribute name="message" type="xs:string"/>
      <xs:attribute name="type" type="xs:string"/>
    </xs:extension></xs:simpleContent>
  </xs:complexType>
  <xs:element name="testsuites">
    <xs:complexType><xs:sequence>
      <xs:element ref="testsuite" minOccurs="0" maxOccurs="unbounded"/>
    </xs:sequence>
    <xs:attribute name="name" type="xs:string"/>
    <xs:attribute name="tests" type="count"/>
    <xs:attribute name="failures" type="count"/>
    <xs:attribute name="errors" type="count"/>
    <xs:attribute name="time" type="seconds"/>
    </xs:complexType>
  </xs:element>
  <xs:element name="testsuite">
    <xs:complexType><xs:sequence>
      <xs:element name="properties" minOccurs="0">
        <xs:complexType><xs:sequence>
          <xs:element name="property" minOccurs="0" maxOccurs="unbounded">
            <xs:complexType>
              <xs:attribute name="name" type="xs:string" use="required"/>
              <xs:attribute name="value" type="xs:string" use="required"/>
            </xs:complexType>
          </xs:element>
        </xs:sequence></xs:complexType>
      </xs:element>
      <xs:element name="testcase" minOccurs="0" maxOccurs="unbounded">
        <xs:complexType><xs:sequence>
          <xs:choice minOccurs="0">
            <xs:element name="failure" type="problem"/>
            <xs:element name="error" type="problem"/>
            <xs:element name="skipped" type="problem"/>
          </xs:choice>
          <xs:element name="system-out" type="xs:string" minOccurs="0"/>
          <xs:element name="system-err" type="xs:string" minOccurs="0"/>
        </xs:sequence>
        <xs:attribute name="name" type="xs:string" use="required"/>
        <xs:attribute name="classname" type="xs:string" use="required"/>
        <xs:attribute name="time" type="seconds" use="required"/>
        <xs:attribute name="file" type="xs:string"/>
        </xs:complexType>
      </xs:element>
    </xs:sequence>
    <xs:attribute name="name" type="xs:string" use="required"/>
    <xs:attribute name="tests" type="count" use="required"/>
    <xs:attribute name="failures" type="count" use="required"/>
    <xs:attribute name="errors" type="count" use="required"/>
    <xs:attribute name="skipped" type="count"/>
    <xs:attribute name="time" type="seconds"/>
    <xs:attribute name="timestamp" type="xs:dateTime"/>
    <xs:attribute name="hostname" type="xs:string"/>
    </xs:complexType>
  </xs:element>
</xs:schema>
"""
SCHEMA = etree.XMLSchema(etree.fromstring(JUNIT_XSD))


def _junit(path: Path) -> etree._Element:
    doc = etree.parse(str(path))
    SCHEMA.assertValid(doc)
    return doc.getroot()


def _copy(tmp_path: Path, name: str, edit=None) -> Path:
    """A bundled scenario copied into tmp_path (mechanism path made absolute), edited."""
    d = yaml.safe_load((SCEN / name).read_text())
    if d.get("mechanism"):
        d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    if edit is not None:
        edit(d)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _far_ik(tmp_path: Path, expects: list, name: str = "far") -> Path:
    d = {"name": name, "task": "ik", "mechanism": str(ROOT / "mechanisms" / "planar3r.yaml"),
         "ik": {"method": "lm", "weights": [1, 1, 1, 0, 0, 0],
                "targets": [{"name": "far", "xyz": [10.0, 0.0, 0.0],
                             "euler": {"convention": "XYZ", "angles": [0, 0, 0]}}]},
         "expect": expects}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _run(args: list[str]):
    return runner.invoke(app, ["run", *args])


def test_two_scenarios_junit_and_summary(tmp_path):
    a = _copy(tmp_path, "delta_fk.yaml")
    b = _copy(tmp_path, "five_bar_fk.yaml")
    junit, summ = tmp_path / "r.xml", tmp_path / "r.json"
    res = _run([str(tmp_path), "--out", str(tmp_path / "o"), "--no-plots", "--junit",
                str(junit), "--summary", str(summ)])
    assert res.exit_code == 0, res.output
    lines = res.stdout.strip().splitlines()
    assert lines[0].startswith(f"PASS [exit 0] {a}") and lines[1].startswith(f"PASS [exit 0] {b}")
    n_exp = sum(len(yaml.safe_load(p.read_text())["expect"]) for p in (a, b))
    assert lines[-1].startswith("2 scenarios: 2 passed;")
    assert f"{n_exp}/{n_exp} expects held" in lines[-1]
    root = _junit(junit)
    suite = root.find("testsuite")
    cases = suite.findall("testcase")
    assert len(cases) == 2 + n_exp == int(suite.get("tests")) == int(root.get("tests"))
    assert suite.get("failures") == "0" and suite.get("errors") == "0"
    names = [c.get("name") for c in cases]
    assert names[0] == "delta_fk (fk)" and names[1].startswith("expect ")
    props = {p.get("name"): p.get("value") for p in suite.iter("property")}
    assert {f"exit code {c}" for c in (0, 1, 2, 3, 4, 5, 130, 143)} <= set(props)
    s = json.loads(summ.read_text())
    assert s["exit_code"] == 0 and s["n_scenarios"] == 2 and s["n_expects"] == n_exp
    assert s["n_expects_held"] == n_exp and s["scenarios"][0]["task"] == "fk"
    assert (tmp_path / "o" / "delta_fk" / "summary.json").is_file()


def test_failed_expect_exit_5_and_junit_failure_message(tmp_path):
    def edit(d):
        d["expect"][0] = {"key": "n_steps", "value": 7, "tol": 0.5}

    p = _copy(tmp_path, "delta_fk.yaml", edit)
    junit = tmp_path / "r.xml"
    res = _run([str(p), "--out", str(tmp_path / "o"), "--no-plots", "--junit", str(junit)])
    assert res.exit_code == 5, res.output
    assert res.stdout.startswith("FAIL [exit 5]")
    # the single-task command gives the same code
    single = runner.invoke(app, ["fk", str(p), "--out", str(tmp_path / "o2"), "--no-plots"])
    assert single.exit_code == 5
    root = _junit(junit)
    fails = root.findall(".//testcase/failure")
    msgs = [f.get("message") for f in fails]
    assert any(m == "n_steps: value 101.0, expected 7.0 +- tolerance 0.5 (SI)" for m in msgs), msgs
    assert root.find("testsuite").get("failures") == str(len(fails)) == "2"
    scen = root.find(".//testcase[@name='delta_fk (fk)']/failure")
    assert scen.get("type") == "exit 5: expect failed"


def test_expected_unreachable_passes_and_other_codes(tmp_path):
    ok = _far_ik(tmp_path, [{"key": "status", "value": "unreachable"},
                            {"key": "targets.0.status", "value": "unreachable"}], "far_ok")
    wrong = _far_ik(tmp_path, [{"key": "status", "value": "not converged"}], "far_wrong")
    plain = _far_ik(tmp_path, [], "far_plain")
    out = str(tmp_path / "o")
    assert _run([str(ok), "--out", out, "--no-plots"]).exit_code == 0
    assert _run([str(wrong), "--out", out, "--no-plots"]).exit_code == 5
    assert _run([str(plain), "--out", out, "--no-plots"]).exit_code == 1
    # the three together: the most serious code
    junit = tmp_path / "r.xml"
    res = _run([str(ok), str(wrong), str(plain), "--out", out, "--no-plots", "--junit",
                str(junit)])
    assert res.exit_code == 5, res.output
    root = _junit(junit)
    types = {c.get("name"): c.find("failure").get("type")
             for c in root.iter("testcase") if c.find("failure") is not None}
    assert types["far_plain (ik)"] == "exit 1: solver result not ok"
    assert types["far_wrong (ik)"] == "exit 5: expect failed"
    assert "far_ok (ik)" not in types


def test_bad_input_is_an_error_testcase_and_exit_2(tmp_path):
    good = _copy(tmp_path, "delta_fk.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\ntask: fk\nmechanism: nowhere.yaml\nfk: {}\n")
    junit = tmp_path / "r.xml"
    res = _run([str(tmp_path), "--out", str(tmp_path / "o"), "--no-plots", "--junit",
                str(junit)])
    assert res.exit_code == 2, res.output
    root = _junit(junit)
    err = root.find(f".//testcase[@file='{bad}']/error")
    assert err is not None and err.get("type") == "exit 2: bad input"
    assert str(bad) in err.get("message")
    assert root.find(f".//testcase[@file='{good}']/failure") is None


def test_refused_before_work(tmp_path):
    res = _run([str(tmp_path / "missing")])
    assert res.exit_code == 2 and "no such file or folder" in res.output
    (tmp_path / "m.yaml").write_text("name: m\n")  # no task: not a scenario
    res = _run([str(tmp_path)])
    assert res.exit_code == 2 and "no scenario files" in res.output
    a = _copy(tmp_path, "delta_fk.yaml")
    shutil.copy(a, tmp_path / "again.yaml")
    res = _run([str(tmp_path), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "is also the name of" in res.output
    assert not (tmp_path / "o").exists()
    res = _run([str(a), "--junit", str(tmp_path / "no" / "r.xml")])
    assert res.exit_code == 2 and "--junit" in res.output


def test_workers_run_scenarios_in_processes(tmp_path):
    _copy(tmp_path, "delta_fk.yaml")
    _copy(tmp_path, "five_bar_fk.yaml")
    summ = tmp_path / "r.json"
    res = _run([str(tmp_path), "--out", str(tmp_path / "o"), "--no-plots", "--workers", "2",
                "--summary", str(summ)])
    assert res.exit_code == 0, res.output
    s = json.loads(summ.read_text())
    assert [r["name"] for r in s["scenarios"]] == ["delta_fk", "five_bar_fk"]


def test_overall_code_order():
    assert overall_code([0, 1, 5]) == 5
    assert overall_code([1, 2, 5]) == 2
    assert overall_code([2, 4]) == 4 and overall_code([4, 3]) == 3
    assert overall_code([0, 130, 3]) == 130 and overall_code([]) == 0


def test_help_lists_exit_codes():
    res = runner.invoke(app, ["--help"])
    text = " ".join(res.stdout.split())
    for code in ("0", "1", "2", "3", "4", "5", "130", "143"):
        assert f"{code} " in text
    assert "expect" in text and "bad input" in text


@pytest.mark.skipif(os.environ.get("MECHKIN_SLOW_TESTS", "") in ("", "0"),
                    reason="runs all 59 bundled scenarios (~4 min on 2 cores): "
                           "MECHKIN_SLOW_TESTS=1; .ci/run runs the same command")
def test_bundled_set_all_pass(tmp_path):
    files = sorted(SCEN.glob("*.yaml"))
    n_exp = sum(len(yaml.safe_load(p.read_text()).get("expect") or []) for p in files)
    junit = tmp_path / "r.xml"
    res = _run([str(SCEN), "--out", str(tmp_path / "o"), "--no-plots", "--workers", "2",
                "--junit", str(junit)])
    assert res.exit_code == 0, res.output
    root = _junit(junit)
    assert len(files) == 59
    assert int(root.get("tests")) == 59 + n_exp == len(list(root.iter("testcase")))
    assert root.get("failures") == "0" and root.get("errors") == "0"


def test_max_time_per_scenario_and_the_estimates_in_junit_and_summary(tmp_path):
    """--max-time applies to each scenario (a job estimated beyond it: that scenario is bad
    input, the others run); every run's estimate is in its summary.json, the aggregate summary
    and the JUnit file."""
    def bigger(d):
        d["fk"]["time"] = {"start": 0, "stop": 2, "step": 2 / 99_999}  # 100000 steps

    a = _copy(tmp_path, "delta_fk.yaml")
    b = _copy(tmp_path, "five_bar_fk.yaml", bigger)  # estimated well beyond 20 s
    junit, summ = tmp_path / "r.xml", tmp_path / "r.json"
    res = _run([str(a), str(b), "--out", str(tmp_path / "o"), "--no-plots", "--junit",
                str(junit), "--summary", str(summ), "--max-time", "20s"])
    assert res.exit_code == 2, res.output
    lines = res.stdout.strip().splitlines()
    assert lines[0].startswith("PASS [exit 0]") and lines[1].startswith("BAD INPUT [exit 2]")
    assert "> --max-time 20 s" in lines[1] and "--max-time-policy stop" in lines[1]
    s = json.loads(summ.read_text())
    est = s["scenarios"][0]["estimated_time_s"]
    assert est > 0 and s["scenarios"][1]["estimated_time_s"] is None
    assert s["estimated_time_s"] == est
    own = json.loads((tmp_path / "o" / "delta_fk" / "summary.json").read_text())
    assert own["estimated_time_s"] == est
    props = {p.get("name"): p.get("value") for p in _junit(junit).iter("property")}
    assert float(props["estimated_time_s delta_fk"]) == est
    assert "estimated_time_s five_bar_fk" not in props


def test_max_time_policy_stop_runs_each_scenario_to_its_limit(tmp_path, monkeypatch):
    import itertools

    from mechkin.tasks import budget

    calls = itertools.count()  # the run's clock: the limit is used as soon as a job starts
    monkeypatch.setattr(budget, "_clock", lambda: 0.0 if next(calls) == 0 else 1e6)
    p = _copy(tmp_path, "five_bar_fk.yaml",
              lambda d: d["fk"].update(time={"start": 0, "stop": 2, "step": 0.0004}))
    summ = tmp_path / "r.json"
    res = _run([str(p), "--out", str(tmp_path / "o"), "--no-plots", "--summary", str(summ),
                "--max-time", "1s", "--max-time-policy", "stop"])
    assert res.exit_code == 1, res.output
    s = json.loads(summ.read_text())["scenarios"][0]
    assert s["status"] == "stopped: max-time" and s["estimated_time_s"] > 1
    own = json.loads((tmp_path / "o" / "five_bar_fk" / "summary.json").read_text())
    assert own["stopped"]["done"] == 1000 and own["stopped"]["total"] == 5001


@pytest.mark.parametrize(("args", "words"), [
    (["--max-time", "soon"], "--max-time: expected a duration"),
    (["--max-time", "1h", "--max-time-policy", "maybe"], "--max-time-policy: expected refuse"),
])
def test_a_bad_max_time_of_run_is_one_line_before_any_work(tmp_path, args, words):
    p = _copy(tmp_path, "delta_fk.yaml")
    res = _run([str(p), "--out", str(tmp_path / "o"), "--no-plots", *args])
    assert res.exit_code == 2 and words in res.output and not (tmp_path / "o").exists()

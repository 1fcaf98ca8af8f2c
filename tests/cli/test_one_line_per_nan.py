"""One NaN is one located line naming its file (issue 28): a NaN in a joint limit, a link
length, a motion amplitude, a target, a track limit, a workspace range, an expect value, an
inertia, a URDF origin or an MJCF body position; and the refusals of the hostile corpus that once
named no file (tests/cli/test_hostile_corpus.py asserts the file on every line)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mechkin.cli.check_files import check_file_status

ROOT = Path(__file__).resolve().parents[2]

# (scenario, file edited (mechanism or scenario), old text, new text)
YAML_CASES = {
    "joint limit": ("five_bar_fk.yaml", "five_bar.yaml", "limits: [-90, 270], home: 135",
                    "limits: [.nan, 270], home: 135"),
    "link length": ("five_bar_fk.yaml", "five_bar.yaml", "origin: {xyz: [0.25, 0, 0]}",
                    "origin: {xyz: [.nan, 0, 0]}"),
    "dh length": ("puma560_wave_fk.yaml", "puma560.yaml", "a: 0.4318", "a: .nan"),
    "inertia": ("puma560_wave_fk.yaml", "puma560.yaml", "inertia: [0, 0.35, 0, 0, 0, 0]",
                "inertia: [.nan, 0.35, 0, 0, 0, 0]"),
    "motion amplitude": ("five_bar_fk.yaml", None, "amplitude: 15, frequency: 0.5}",
                         "amplitude: .nan, frequency: 0.5}"),
    "target": ("ur5_ik.yaml", None, "matrix: [[-0.0864974734875,", "matrix: [[.nan,"),
    "track limit": ("park_conveyor_torque.yaml", None, "limits: {torque: [0.5, 0.2]}",
                    "limits: {torque: [.nan, 0.2]}"),
    "workspace range": ("five_bar_workspace.yaml", None, "q1: {range: [115, 155], n: 21}",
                        "q1: {range: [.nan, 155], n: 21}"),
    "expect value": ("five_bar_workspace.yaml", None, "value: 1.0, tol: 0}",
                     "value: .nan, tol: 0}"),
    "expect vector": ("five_bar_workspace.yaml", None, "value: [-0.109014504449,",
                      "value: [.nan,"),
}


def _copy(tmp_path: Path, scenario: str, edited: str | None, old: str, new: str
          ) -> tuple[Path, Path]:
    text = (ROOT / "scenarios" / scenario).read_text()
    mdir = tmp_path / "mechanisms"
    mdir.mkdir()
    mech_name = next(ln.split("/")[-1].strip() for ln in text.splitlines()
                     if ln.startswith("mechanism:"))
    mtext = (ROOT / "mechanisms" / mech_name).read_text()
    if edited is not None:
        assert old in mtext
        mtext = mtext.replace(old, new, 1)
    else:
        assert old in text
        text = text.replace(old, new, 1)
    (mdir / mech_name).write_text(mtext)
    sdir = tmp_path / "scenarios"
    sdir.mkdir()
    sc = sdir / scenario
    sc.write_text(text)
    return sc, (mdir / mech_name if edited is not None else sc)


@pytest.mark.parametrize("case", sorted(YAML_CASES))
def test_one_nan_is_one_located_line(tmp_path, case):
    sc, bad = _copy(tmp_path, *YAML_CASES[case])
    problems, internal = check_file_status(sc)
    assert not internal and len(problems) == 1, problems
    line = problems[0]
    assert line.startswith(f"{bad}:") and "nan" in line and len(line) <= 300, line


URDF = """<robot name="r">
  <link name="base"/>
  <link name="l1"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""
MJCF = """<mujoco model="m">
  <worldbody>
    <body name="b1" pos="0 0 0.1">
      <joint name="j1" type="hinge" axis="0 0 1" range="-1 1"/>
      <geom type="sphere" size="0.05"/>
      <body name="b2" pos="0 0 0.2">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="sphere" size="0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
ROBOT_CASES = {
    "urdf origin": ("r.urdf", URDF, 'xyz="0 0 0.1"', 'xyz="nan 0 0.1"', 6,
                    "joint[j1].origin.xyz"),
    "urdf rpy": ("r.urdf", URDF, 'rpy="0 0 0"', 'rpy="0 inf 0"', 6, "joint[j1].origin.rpy"),
    "urdf axis": ("r.urdf", URDF, 'xyz="0 0 1"', 'xyz="0 nan 1"', 7, "joint[j1].axis.xyz"),
    "mjcf body pos": ("m.xml", MJCF, 'pos="0 0 0.2"', 'pos="nan 0 0.2"', 6, "body[b2].pos"),
    "mjcf joint axis": ("m.xml", MJCF, 'axis="0 1 0"', 'axis="0 nan 0"', 7, "joint[j2].axis"),
}


@pytest.mark.parametrize("case", sorted(ROBOT_CASES))
def test_one_nan_in_a_robot_file_is_one_located_line(tmp_path, case):
    name, text, old, new, line_no, key = ROBOT_CASES[case]
    if name.endswith(".xml"):
        pytest.importorskip("mujoco")
    else:
        pytest.importorskip("yourdfpy")
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1))
    problems, internal = check_file_status(p)
    got = new.split("=")[1].strip(chr(34))
    # one line, at the element, naming the key and the value (the URDF element checks add the
    # fix: "expected 3 finite numbers, got '0 nan 1'; fix: e.g. ...")
    assert not internal and len(problems) == 1, problems
    assert problems[0].startswith(f"{p}:{line_no}: {key}: expected ")
    assert "finite numbers" in problems[0] and f"got {got!r}" in problems[0], problems

"""Conventions users already know: URDF inertia names, URDF rpy for IK targets, a number that
YAML read as a string gets a hint (exit 2, one line)."""

from pathlib import Path

import yaml
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.config.ik_spec import TargetSpec, target_matrix
from mechkin.config.mechanism_file import read_mechanism_spec
from mechkin.config.schema import Units

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def test_inertia_by_urdf_names_equals_the_positional_order(tmp_path):
    d = yaml.safe_load((ROOT / "mechanisms" / "park_scara2.yaml").read_text())
    # an asymmetric tensor, so every off-diagonal lands in a distinct place
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = 0.5, 0.6, 0.7, 0.01, 0.02, 0.03
    d["links"][1]["inertial"]["inertia"] = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
    a = tmp_path / "a.yaml"
    a.write_text(yaml.safe_dump(d, sort_keys=False))
    d["links"][1]["inertial"]["inertia"] = {"ixx": Ixx, "ixy": Ixy, "ixz": Ixz, "iyy": Iyy,
                                            "iyz": Iyz, "izz": Izz}
    b = tmp_path / "b.yaml"
    b.write_text(yaml.safe_dump(d, sort_keys=False))
    sa, _ = read_mechanism_spec(a)
    sb, _ = read_mechanism_spec(b)
    assert list(sb.links[1].inertial.inertia) == [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
    assert sa.links[1].inertial.inertia == sb.links[1].inertial.inertia
    d["links"][1]["inertial"]["inertia"] = {"ixx": 1.0, "iyy": 1.0}
    c = tmp_path / "c.yaml"
    c.write_text(yaml.safe_dump(d, sort_keys=False))
    res = runner.invoke(app, ["check", str(c)])
    assert res.exit_code == 2 and "inertia" in res.output and "izz" in res.output


def test_rpy_target_is_urdf_rpy_and_scipy_extrinsic_xyz():
    rpy = [10.0, -20.0, 30.0]
    units = Units(length="m", angle="deg")
    T_rpy = target_matrix(TargetSpec(xyz=[0, 0, 0], rpy=rpy), units)
    T_eul = target_matrix(TargetSpec(xyz=[0, 0, 0], euler={"convention": "xyz",
                                                              "angles": rpy}), units)
    want = Rotation.from_euler("xyz", rpy, degrees=True).as_matrix()
    assert_allclose(T_rpy[:3, :3], want, atol=1e-12)
    assert_allclose(T_eul[:3, :3], want, atol=1e-12)


def test_number_read_as_a_string_gets_a_hint(tmp_path):
    d = yaml.safe_load((ROOT / "scenarios" / "five_bar_ik.yaml").read_text())
    d["mechanism"] = str(ROOT / "mechanisms" / "five_bar.yaml")
    text = yaml.safe_dump(d, sort_keys=False).replace("position: 1.0e-10", "position: 1e-6")
    assert "position: 1e-6" in text
    p = tmp_path / "s.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["check", str(p)])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"{p}:")
    assert "ik.tolerances.position" in lines[0]
    assert lines[0].endswith("did you mean the number 1e-6? write 1.0e-6")

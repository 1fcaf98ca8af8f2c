"""``fk: base:`` (kim1995 §5.1 Step 1: the base pose T_0(t) in the inertial frame).

Cross-checks: a base at the world frame that never moves gives today's numbers bit for bit;
a moving base gives today's frame poses premultiplied by T_0(t); the world-frame twists and
accelerations of the end effector (and of the base) match central finite differences of the
world-frame poses; a table or CSV of base poses reproduces the generator it was sampled from;
bad input is a located ConfigError (one line, exit 2)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.config.scenario import load_scenario
from mechkin.errors import ConfigError
from mechkin.io.motion_out import frame_tree_of
from mechkin.spatial.rotations import matrix_from_quat, matrix_from_rpy, rotation_log
from mechkin.tasks import fk

ROOT = Path(__file__).resolve().parents[2]
DD = ROOT / "mechanisms" / "kim1995_direct_drive.yaml"
runner = CliRunner()

JOINTS = {"q1": {"type": "sinusoid", "amplitude": 40, "frequency": 0.5},
          "q2": {"type": "ramp", "from": 0, "to": -30},
          "q3": {"type": "sinusoid", "amplitude": 10, "frequency": 0.3, "phase": 20}}
BASE_MOTION = {"x": {"type": "ramp", "from": 0, "to": 1.0},
               "y": {"type": "sinusoid", "amplitude": 0.2, "frequency": 0.4},
               "z": {"type": "sinusoid", "amplitude": 0.05, "frequency": 1.0, "phase": 30},
               "roll": {"type": "sinusoid", "amplitude": 8, "frequency": 0.7},
               "pitch": {"type": "sinusoid", "amplitude": 12, "frequency": 0.5, "phase": 45},
               "yaw": {"type": "ramp", "from": 10, "to": 100}}


def _scenario(tmp_path: Path, base=None, time=(0.0, 2.0, 0.05), name="s", outputs=None):
    fk_sec = {"time": {"start": time[0], "stop": time[1], "step": time[2]}, "motion": JOINTS}
    if base is not None:
        fk_sec["base"] = base
    doc = {"name": name, "task": "fk", "mechanism": str(DD), "units": {"length": "m",
                                                                       "angle": "deg"},
           "fk": fk_sec, "outputs": outputs or {"csv": True, "plots": False, "mcap": True}}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def _run(path):
    return fk.run(load_scenario(path))


def _strip(summary):
    s = {k: v for k, v in summary.items() if not k.endswith("time_s") and k not in
         ("time_per_step_s", "base", "scenario")}
    s["final"] = {k: v for k, v in s["final"].items() if k != "end_effector_in_base"}
    return json.dumps(s, sort_keys=True)


def _ee_T(cols, prefix="ee_"):
    q = np.stack([cols[f"{prefix}q{a}"] for a in "wxyz"], axis=1)
    T = np.zeros((len(q), 4, 4))
    T[:, :3, :3] = matrix_from_quat(q)
    T[:, :3, 3] = np.stack([cols[f"{prefix}{a}_m"] for a in "xyz"], axis=1)
    T[:, 3, 3] = 1
    return T


def _T0(t):
    """T_0(t) of BASE_MOTION, typed in independently of the code (deg -> rad here)."""
    d = math.pi / 180
    x = t / 2.0
    y = 0.2 * np.sin(2 * np.pi * 0.4 * t)
    z = 0.05 * np.sin(2 * np.pi * 1.0 * t + 30 * d)
    roll = 8 * d * np.sin(2 * np.pi * 0.7 * t)
    pitch = 12 * d * np.sin(2 * np.pi * 0.5 * t + 45 * d)
    yaw = (10 + 90 * t / 2.0) * d
    T = np.zeros((len(t), 4, 4))
    T[:, :3, :3] = matrix_from_rpy(np.stack([roll, pitch, yaw], axis=1))
    T[:, :3, 3] = np.stack([x, y, z], axis=1)
    T[:, 3, 3] = 1
    return T


ZERO_BASES = {
    "pose": {"pose": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}},
    "motion": {"motion": {"x": {"type": "constant", "value": 0},
                          "yaw": {"type": "sinusoid", "amplitude": 0, "frequency": 1}}},
    "table": {"table": {"t": [0, 1, 2], "x": [0, 0, 0], "roll": [0, 0, 0]}},
}


@pytest.mark.parametrize("form", sorted(ZERO_BASES))
def test_base_at_world_and_still_is_bit_identical(tmp_path, form):
    ref = _run(_scenario(tmp_path, name="ref"))
    got = _run(_scenario(tmp_path, ZERO_BASES[form], name="zero"))
    assert _strip(got.summary) == _strip(ref.summary)
    for k, v in ref.data.columns.items():
        a, b = np.asarray(v), np.asarray(got.data.columns[k])
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), k
    assert np.array_equal(got.data.segments, ref.data.segments)
    assert got.summary["base"]["source"] == form
    assert got.summary["final"]["end_effector_in_base"] == ref.summary["final"]["end_effector"]
    # the base columns are there, and the frame tree has the world root with an identity base
    assert np.all(got.data.columns["base_qw"] == 1.0)
    root, names, parents, T = frame_tree_of(got.data)
    assert root == "world" and names[0] == ref.data.frame_root and parents[0] == "world"
    assert np.array_equal(T[:, 0], np.broadcast_to(np.eye(4), T[:, 0].shape))


def test_moving_base_is_fk_premultiplied_by_T0(tmp_path):
    ref = _run(_scenario(tmp_path, name="ref"))
    got = _run(_scenario(tmp_path, {"motion": BASE_MOTION}, name="moving"))
    t = ref.data.times
    T0 = _T0(t)
    np.testing.assert_allclose(_ee_T(got.data.columns), T0 @ _ee_T(ref.data.columns),
                               atol=1e-12)
    # joints are not changed by the base
    for k in ("q1_rad", "p_C_rad", "q1_rad_s", "p_Q_rad_s2"):
        assert np.array_equal(got.data.columns[k], ref.data.columns[k])
    # base columns
    np.testing.assert_allclose(np.stack([got.data.columns[f"base_{a}_m"] for a in "xyz"], 1),
                               T0[:, :3, 3], atol=1e-14)
    # summary: world pose and the base-frame pose
    fin = got.summary["final"]
    np.testing.assert_allclose(fin["end_effector_in_base"]["xyz_m"],
                               ref.summary["final"]["end_effector"]["xyz_m"], atol=0)
    np.testing.assert_allclose(fin["end_effector"]["xyz_m"],
                               (T0[-1] @ np.r_[ref.summary["final"]["end_effector"]["xyz_m"],
                                               1])[:3], atol=1e-12)
    assert got.summary["base"]["world_frame"] == "world"
    # stick segments in world axes; the frame tree's world -> base transform is T_0(t)
    seg_ref = ref.data.segments
    want = np.einsum("mij,msej->msei", T0[:, :3, :3], seg_ref) + T0[:, None, None, :3, 3]
    np.testing.assert_allclose(got.data.segments, want, atol=1e-12)
    root, names, parents, T = frame_tree_of(got.data)
    assert (root, names[0], parents[0]) == ("world", "base", "world")
    np.testing.assert_allclose(T[:, 0], T0, atol=1e-14)
    assert names[1:] == ref.data.frame_names


def _fd_twist(T, h):
    """Central differences: angular velocity from log(R_{k+1} R_{k-1}^T) / 2h, origin
    velocity, and the same again for the accelerations (interior steps)."""
    R, p = T[:, :3, :3], T[:, :3, 3]
    w = rotation_log(R[2:] @ np.swapaxes(R[:-2], 1, 2)) / (2 * h)
    v = (p[2:] - p[:-2]) / (2 * h)
    a = (p[2:] - 2 * p[1:-1] + p[:-2]) / h ** 2
    return w, v, a


def test_world_rates_match_finite_differences(tmp_path):
    h = 1e-3
    got = _run(_scenario(tmp_path, {"motion": BASE_MOTION}, time=(0.4, 0.9, h),
                         name="fd", outputs={"csv": True, "plots": False, "mcap": False}))
    c = got.data.columns
    for prefix in ("ee_", "base_"):
        T = _ee_T(c, prefix)
        w_fd, v_fd, a_fd = _fd_twist(T, h)
        w = np.stack([c[f"{prefix}w{a}_rad_s"] for a in "xyz"], 1)[1:-1]
        v = np.stack([c[f"{prefix}v{a}_m_s"] for a in "xyz"], 1)[1:-1]
        al = np.stack([c[f"{prefix}alpha{a}_rad_s2"] for a in "xyz"], 1)
        acc = np.stack([c[f"{prefix}a{a}_m_s2"] for a in "xyz"], 1)[1:-1]
        al_fd = np.stack([c[f"{prefix}w{a}_rad_s"] for a in "xyz"], 1)
        al_fd = (al_fd[2:] - al_fd[:-2]) / (2 * h)
        # O(h^2) differences of motions whose derivatives are O(1-10): 1e-4 holds with margin
        np.testing.assert_allclose(w, w_fd, atol=2e-5, err_msg=prefix)
        np.testing.assert_allclose(v, v_fd, atol=2e-5, err_msg=prefix)
        np.testing.assert_allclose(acc, a_fd, atol=1e-4, err_msg=prefix)
        np.testing.assert_allclose(al[1:-1], al_fd, atol=1e-4, err_msg=prefix)
    # the base motion changes the end-effector motion (the check is not vacuous)
    ref = _run(_scenario(tmp_path, time=(0.4, 0.9, h), name="fd_ref",
                         outputs={"csv": True, "plots": False, "mcap": False}))
    assert np.abs(ref.data.columns["ee_ax_m_s2"] - c["ee_ax_m_s2"]).max() > 0.1


def test_table_and_csv_of_base_poses(tmp_path):
    """A table / CSV sampled from BASE_MOTION on a fine grid reproduces the generator's poses
    at the samples exactly and its rates to the spline's accuracy."""
    tt = np.linspace(0.0, 2.0, 201)
    T0 = _T0(tt)
    d = math.pi / 180
    from mechkin.spatial.rotations import rpy_from_matrix

    rpy = rpy_from_matrix(T0[:, :3, :3]) / d
    tab = {"t": tt.tolist(), "x": T0[:, 0, 3].tolist(), "y": T0[:, 1, 3].tolist(),
           "z": T0[:, 2, 3].tolist(), "roll": rpy[:, 0].tolist(), "pitch": rpy[:, 1].tolist(),
           "yaw": rpy[:, 2].tolist()}
    gen = _run(_scenario(tmp_path, {"motion": BASE_MOTION}, name="gen"))
    by_tab = _run(_scenario(tmp_path, {"table": tab}, name="tab"))
    csv = tmp_path / "base.csv"
    rows = ["t_s,x_mm,y_m,z_m,roll_rad,pitch_deg,yaw_deg"]
    for k in range(len(tt)):
        rows.append(",".join(repr(float(v)) for v in (
            tt[k], 1000 * tab["x"][k], tab["y"][k], tab["z"][k], rpy[k, 0] * d, rpy[k, 1],
            rpy[k, 2])))
    csv.write_text("\n".join(rows) + "\n")
    by_csv = _run(_scenario(tmp_path, {"csv": "base.csv"}, name="csv"))
    for r in (by_tab, by_csv):
        c, g = r.data.columns, gen.data.columns
        np.testing.assert_allclose(_ee_T(c), _ee_T(g), atol=1e-12)
        for k in ("base_vx_m_s", "base_wz_rad_s", "ee_vy_m_s"):
            np.testing.assert_allclose(c[k], g[k], atol=1e-4, err_msg=k)
        for k in ("base_ay_m_s2", "ee_ax_m_s2"):
            np.testing.assert_allclose(c[k][5:-5], g[k][5:-5], atol=2e-2, err_msg=k)
    assert by_csv.summary["base"]["source"] == "csv"


@pytest.mark.parametrize("base, key", [
    ({"table": {"t": [0, 1, 2], "w": [0, 1, 2]}}, r"fk\.base\.table\.w: not a base coordinate"),
    ({"table": {"t": [0, 1], "x": [0, 1]}}, r"fk\.base\.table\.t: the base times \[0, 1\] s "
                                            r"do not cover the fk times \[0, 2\] s"),
    ({"table": {"t": [0, 2, 1], "x": [0, 1, 2]}}, r"fk\.base\.table\.t: base times must "
                                                  r"increase strictly"),
    ({"table": {"t": [0, 1, 2], "x": [0, 1]}}, r"fk\.base\.table: columns must have the same"),
    ({"pose": {"xyz": [0, 0, 0]}, "motion": {"x": {"type": "constant", "value": 1}}},
     r"fk\.base: .*exactly one of pose, motion, table or csv"),
    ({"motion": {"w": {"type": "constant", "value": 1}}}, r"fk\.base\.motion"),
    ({"motion": {"x": {"type": "ramp", "from": 0}}}, r"fk\.base\.motion\.x: .*needs to"),
    ({"pose": {"xyz": [0, 0]}}, r"fk\.base\.pose\.xyz"),
    ({"pose": {"xyz": [0, 0, 0]}, "frame": "tool"}, r"fk\.base\.frame: 'tool' is a frame of "
                                                    r"the mechanism"),
    ({"csv": "missing.csv"}, r"fk\.base\.csv: file not found"),
])
def test_bad_base_is_a_located_config_error(tmp_path, base, key):
    import re

    path = _scenario(tmp_path, base, name="bad")
    with pytest.raises(ConfigError) as exc:
        fk.run(load_scenario(path))
    assert any(re.search(rf"^{re.escape(str(path))}:\d+: {key}", p) for p in exc.value.problems), \
        exc.value.problems
    res = runner.invoke(app, ["fk", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    # mechkin check refuses it the same way, before any solving
    res = runner.invoke(app, ["check", str(path)])
    assert res.exit_code == 2, res.output


def test_bad_base_csv_column_names_the_file(tmp_path):
    (tmp_path / "b.csv").write_text("t_s,x_m,heading_deg\n0,0,0\n2,1,0\n")
    path = _scenario(tmp_path, {"csv": "b.csv"}, name="badcsv")
    with pytest.raises(ConfigError, match=r"b\.csv:1: column 'heading_deg' is not a base"):
        fk.run(load_scenario(path))
    (tmp_path / "c.csv").write_text("t_s,x_m,x_mm\n0,0,0\n2,1,1000\n")
    path = _scenario(tmp_path, {"csv": "c.csv"}, name="badcsv2")
    with pytest.raises(ConfigError, match=r"c\.csv:1: columns 'x_m' and 'x_mm' give the same"):
        fk.run(load_scenario(path))


def test_cli_writes_base_outputs(tmp_path):
    path = _scenario(tmp_path, {"motion": BASE_MOTION}, name="cli",
                     outputs={"csv": True, "plots": True, "mcap": True})
    out = tmp_path / "out"
    res = runner.invoke(app, ["fk", str(path), "-o", str(out)])
    assert res.exit_code == 0, res.output
    head = (out / "fk.csv").read_text().splitlines()[0].split(",")
    assert head.index("base_x_m") < head.index("closure_residual")
    assert {"base_qw", "base_wz_rad_s", "base_az_m_s2"} <= set(head)
    s = json.loads((out / "summary.json").read_text())
    assert s["base"]["source"] == "motion" and "end_effector_in_base" in s["final"]
    from mcap.reader import make_reader

    with open(out / "fk.mcap", "rb") as f:
        chans = {c.topic for c in make_reader(f).get_summary().channels.values()}
    assert "/tf" in chans

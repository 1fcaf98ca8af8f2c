"""`mechkin track` along curved paths (issue 11 item 1): the bundled PUMA 560 arc and spline
scenarios (pose held / slerp, the part moving along the path by arc length), a planar 3R on an
arc in its plane, and bad path input as one located line (exit 2)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.io.csv_out import read_csv
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.spatial.rotations import matrix_from_rpy, rotation_log
from tests.scenario_copy import local_scenario as _local

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()
DEG = np.pi / 180.0


def _run(tmp_path: Path, p: Path, *extra: str):
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots", "--json",
                              *extra])
    return res, out


@pytest.mark.parametrize("name", ["puma560_track_arc", "puma560_track_spline"])
def test_bundled_curved_scenarios(tmp_path: Path, name: str) -> None:
    """Exit 0, every expect holds; FK of the realised plan (the CSV's joint values) on the path
    with the orientation held or slerped, independently of the solver; the part on the path
    and the hand on the part after t_a."""
    res, out = _run(tmp_path, _local(tmp_path, name))
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["status"] == "ok" and s["limits_ok"] and all(c["ok"] for c in s["expect"])
    path = s["path"]
    cols = {k: np.asarray(v, dtype=float) for k, v in read_csv(out / "track.csv").items()}
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q = np.column_stack([cols[f"q{k}_rad"] for k in range(1, 7)])
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    r = cols["r"]
    hand = T[:, :3, 3]
    assert np.allclose(hand, np.column_stack([cols[f"hand_{a}_m"] for a in "xyz"]), atol=1e-9)
    part = np.column_stack([cols[f"part_{a}_m"] for a in "xyz"])
    after = cols["t_s"] >= s["t_a_s"] - 1e-12
    assert np.max(np.linalg.norm(hand - part, axis=1)[after]) <= 1e-9
    if name == "puma560_track_arc":
        c, rho = np.array(path["centre_m"]), 0.1
        assert path["type"] == "arc" and path["length_m"] == pytest.approx(0.1 * np.pi)
        # on the circle x = 0.80575, |X - c| = 0.1, at the angle pi r from the start
        assert np.max(np.abs(np.linalg.norm(hand - c, axis=1) - rho)) <= 1e-9
        assert np.max(np.abs(hand[:, 0] - 0.80574977)) <= 1e-9
        ang = np.arctan2(hand[:, 2] - c[2], -(hand[:, 1] - c[1])) % (2 * np.pi)
        ang[r > 0.99] = np.where(ang[r > 0.99] < 1.0, ang[r > 0.99] + 2 * np.pi, ang[r > 0.99])
        assert np.allclose(ang, np.pi * r, atol=1e-9)
        # and so is the part before t_a: the circle continued behind the start
        assert np.max(np.abs(np.linalg.norm(part - c, axis=1) - rho)) <= 1e-9
        R_target = np.broadcast_to(T[0, :3, :3], T.shape[:1] + (3, 3))
    else:
        assert path["type"] == "spline" and path["orientation"] == "slerp"
        R0 = matrix_from_rpy(np.array([-180.0, 50.0, -180.0]) * DEG)
        R1 = matrix_from_rpy(np.array([-170.0, 35.0, -150.0]) * DEG)
        v = rotation_log((R1 @ R0.T)[None])[0]
        from scipy.spatial.transform import Rotation

        R_target = Rotation.from_rotvec(r[:, None] * v).as_matrix() @ R0
        assert np.linalg.norm(v) == pytest.approx(28.49 * DEG, abs=0.01 * DEG)
    err = np.linalg.norm(rotation_log(T[:, :3, :3] @ np.swapaxes(R_target, 1, 2)), axis=1)
    assert np.max(err) <= 1e-6
    assert path["max_orientation_error_rad"] <= 1e-6 and path["max_position_error_m"] <= 1e-6


def test_planar_3r_on_an_arc_in_its_plane_exits_0(tmp_path: Path) -> None:
    p = _local(tmp_path, "planar3r_track_line",
               ("path: {start: [0.7794228634059948, 0.95], end: [0.3794228634059948, 0.95]}",
                "path: {type: arc, start: [0.7794228634059948, 0.95], via: [0.5794228634059948,"
                " 1.05], end: [0.3794228634059948, 0.95]}"),
               ("objective: tracking", "objective: time"),
               ("  conveyor: {part_start: [0.8794228634059948, 0.95], belt_velocity: [-0.1, 0]}"
                "\n", ""))
    res, _ = _run(tmp_path, p)
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["status"] == "ok" and s["limits_ok"]
    assert s["path"]["type"] == "arc" and s["path"]["redundancy"] == 1
    assert s["path"]["radius_m"] == pytest.approx(0.25)  # chord 0.4, sagitta 0.1
    L = 0.25 * 2 * np.arcsin(0.2 / 0.25)
    assert s["path"]["length_m"] == pytest.approx(L, rel=1e-12)
    assert s["path"]["max_position_error_m"] <= 1e-9


ARC = ("    type: arc\n    start: [0.80574977, -0.15005, 0.86743]\n"
       "    via: [0.80574977, -0.05005, 0.96743]\n")


@pytest.mark.parametrize(("name", "edit", "pattern"), [
    ("puma560_track_arc", ("    via: [0.80574977, -0.05005, 0.96743]\n", ""),
     r":\d+: track\.path: .*type arc needs via"),
    ("puma560_track_arc", ("    via: [0.80574977, -0.05005, 0.96743]",
                           "    via: [0.80574977, -0.10005, 0.86743]"),
     r":\d+: track\.path: .*on one line"),
    ("puma560_track_arc", ("    type: arc", "    type: spline"),
     r":\d+: track\.path: .*type spline needs points"),
    ("puma560_track_spline", ("    orientations: [[-180, 50, -180], [-170, 35, -150]]\n", ""),
     r":\d+: track\.path: .*orientation slerp needs orientations: two \(start, end\) or one "
     r"per point, got none"),
    ("puma560_track_spline", ("    orientation: slerp", "    orientation: slerp\n"
                              "    mask: [x, y, z]"),
     r":\d+: track\.path: .*orientation slerp needs rx, ry or rz in the mask"),
    ("puma560_track_spline", ("    orientation: slerp", "    orientation: free"),
     r":\d+: track\.path: .*orientations \(2 given\) go with orientation slerp"),
    ("puma560_track_spline", ("[-170, 35, -150]]", "[-170, 35]]"),
     r":\d+: track\.path\.orientations\[1\]: "),
    ("puma560_track_spline", ("    points:\n", "    start: [0, 0, 0]\n    points:\n"),
     r":\d+: track\.path: .*type spline takes no start"),
    ("puma560_track_arc", ("part_start: [0.80574977, -0.137808256189",
                           "part_start: [0.80574977, -0.138808256189"),
     r":\d+: track\.conveyor: .*the part starts [0-9.e-]+ m off the hand's arc"),
    ("puma560_track_arc", ("belt_velocity: [0, -0.047942553860, 0.087758256189]",
                           "belt_velocity: [0, 0.1, 0]"),
     r":\d+: track\.conveyor: .*not along the hand's arc .*unit tangent"),
])
def test_bad_path_input_is_one_located_line(tmp_path: Path, name: str, edit, pattern) -> None:
    p = _local(tmp_path, name, edit)
    res, out = _run(tmp_path, p)
    assert res.exit_code == 2, res.output
    assert re.search(str(p).replace(".", r"\.") + pattern, res.stderr), res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert "Traceback" not in res.output
    assert not out.exists()


def test_arc_leaving_the_workspace_names_r_and_the_point(tmp_path: Path) -> None:
    """A half circle bulging outwards past the PUMA's reach: one line at track.path naming r
    and the point, which is the arc's point at that r (centre (0.80575, -0.05005, 0.86743),
    radius 0.1, horizontal)."""
    p = _local(tmp_path, "puma560_track_arc",
               ("    via: [0.80574977, -0.05005, 0.96743]",
                "    via: [0.90574977, -0.05005, 0.86743]"))
    res, out = _run(tmp_path, p)
    assert res.exit_code == 2, res.output
    m = re.search(str(p).replace(".", r"\.") + r":\d+: track\.path: the hand arc leaves the "
                  r"reachable workspace or meets a singularity near r = ([0-9.]+) \(point "
                  r"\[([-0-9., ]+)\] m", res.stderr)
    assert m is not None, res.stderr
    r = float(m.group(1))
    point = np.array([float(v) for v in m.group(2).split(",")])
    assert 0.0 < r < 1.0
    c = np.array([0.80574977, -0.05005, 0.86743])
    th = np.pi * r  # from the start (0, -1, 0) towards via (+x)
    assert np.allclose(point, c + 0.1 * np.array([np.sin(th), -np.cos(th), 0.0]), atol=2e-6)
    assert not out.exists()

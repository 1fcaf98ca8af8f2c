"""The robot in every MCAP (issue 27): bundled scenarios of every task, open and closed chains,
run in-process with plots off; each MCAP passes the strict check, its ``/robot_description``
parses as URDF (yourdfpy) and the URDF's forward kinematics at every logged ``/joint_states``
message equals the logged ``/tf`` (chained to the root) to 1e-9 for every URDF link: the
picture Foxglove's URDF layer draws equals the numbers mechkin computed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.io.mcap_checks import (
    check_robot_in_view,
    strict_check,
    tf_world_poses,
    urdf_fk_errors,
)

ROOT = Path(__file__).resolve().parents[2]
ATOL_POSE = 1e-9
# every fk scenario (cheap), and ik, track and biped scenarios with open and closed chains
SCENARIOS = {
    "kim1995_direct_drive_fk": "fk",
    "kim1995_direct_drive_moving_base_fk": "fk",
    "kim1995_stewart_fk": "fk",            # closed: Stewart platform
    "delta_fk": "fk",                      # closed
    "five_bar_fk": "fk",                   # closed, planar
    "planar_3rrr_fk": "fk",                # closed
    "puma560_wave_fk": "fk",               # D-H links (<link>_dh in the URDF)
    "ur5_fk": "fk",
    "ur5_ik": "ik",
    "kim1995_table6_stewart_ik": "ik",     # closed
    "planar_3rrr_ik": "ik",                # closed
    "planar3r_track_line": "track",
    "kim1995_stewart_track": "track",      # closed
    "hwang2023_walk_to_skate": "biped",
    "ur5_workspace": "workspace",
    "planar_3rrr_workspace": "workspace",  # closed
}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, tuple[Any, Path]]:
    from mechkin.api import run

    out = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MECHKIN_JIT", "0")
        if "NUMBA_CACHE_DIR" not in os.environ:
            mp.setenv("NUMBA_CACHE_DIR", str(tmp_path_factory.mktemp("numba")))
        for name, task in SCENARIOS.items():
            report = run(ROOT / "scenarios" / f"{name}.yaml")
            folder = tmp_path_factory.mktemp(name)
            report.write(folder, plots=False)
            out[name] = (report, folder / f"{task}.mcap")
    return out


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_urdf_forward_kinematics_equals_tf_at_every_joint_state(written, name):
    report, path = written[name]
    data = strict_check(path)
    err, n_msgs, n_links = urdf_fk_errors(data)
    assert n_msgs == len(data["msgs"]["/tf"]) and n_links >= 3
    assert err <= ATOL_POSE, f"{name}: URDF FK differs from /tf by {err:.3g}"
    check_robot_in_view(data, path)  # URIs well formed; the layout's URDF layer on the topics


@pytest.mark.parametrize("name", ["kim1995_stewart_fk", "five_bar_fk", "kim1995_stewart_track"])
def test_closed_chains_are_drawn_closed(written, name):
    """Every joint (passive ones too) is in /joint_states, so the URDF's two branches of each
    loop end at the same place at every step: the cut frames coincide in the picture."""
    from mechkin.api import load_mechanism, load_scenario

    report, path = written[name]
    data = strict_check(path)
    mech = load_mechanism(load_scenario(ROOT / "scenarios" / f"{name}.yaml").mechanism_path)
    names = [j.name for j in data["msgs"]["/joint_states"][0][1].joints]
    assert names == list(mech.joint_names)  # every joint, passive and coupled included
    # the cut frames' positions, chained from /tf, coincide at every step
    worst = 0.0
    for c in mech.cuts:
        a, b = mech.frame_names[c.a], mech.frame_names[c.b]
        for world in tf_world_poses(data):
            worst = max(worst, float(np.abs(world[a][:3, 3] - world[b][:3, 3]).max()))
    assert worst <= 1e-6, f"{name}: a loop opens by {worst:.3g} m"


@pytest.mark.parametrize("name", ["ur5_workspace", "planar_3rrr_workspace"])
def test_workspace_log_is_the_map_as_a_point_cloud_with_isotropy(written, name):
    import json

    from tests.io.mcap_checks import point_cloud_arrays
    from tests.io.test_layouts_and_plots import _check_panel_keys

    report, path = written[name]
    data = strict_check(path)
    rec = report.data.record
    (_, msg), = data["msgs"]["/mechkin/workspace"]
    assert data["schemas"]["/mechkin/workspace"].name == "foxglove.PointCloud"
    cols = point_cloud_arrays(msg)
    reach = np.asarray(rec.reachable, bool)
    assert len(cols["x"]) == reach.sum() > 0
    want = rec.position[reach] if hasattr(rec, "position") else rec.T_P[reach, :3, 3]
    xyz = np.stack([cols["x"], cols["y"], cols["z"]], axis=1)
    np.testing.assert_allclose(xyz, want, atol=1e-6 * max(1.0, np.abs(want).max()))  # float32
    iso = rec.isotropy_normalized if rec.isotropy_normalized is not None else rec.isotropy
    np.testing.assert_allclose(cols["isotropy"], iso[reach], atol=1e-6)
    assert msg.frame_id == data["msgs"]["/tf"][0][1].transforms[0].parent_frame_id
    lay = json.loads((path.parent / "workspace.layout.json").read_text())
    _check_panel_keys(lay)
    three_d = lay["configById"]["3D!mechkin"]
    cloud = three_d["topics"]["/mechkin/workspace"]
    assert cloud["colorMode"] == "colormap" and cloud["colorField"] == "isotropy"
    assert (cloud["minValue"], cloud["maxValue"]) == (0.0, 1.0)


def test_ik_targets_are_tf_frames_and_scene_axes(written):
    """Each step's target is the /tf frame ``target`` (the CSV's target position) and its axes
    in /scene; the end effector the URDF draws sits on it (the targets were reached)."""
    report, path = written["ur5_ik"]
    data = strict_check(path)
    cols = report.data.columns
    worlds = tf_world_poses(data)
    ee = "tool"  # ur5.yaml end_effector
    for k, world in enumerate(worlds):
        p = world["target"][:3, 3]
        np.testing.assert_allclose(p, [cols["target_x_m"][k], cols["target_y_m"][k],
                                       cols["target_z_m"][k]], atol=1e-12)
        assert np.abs(world[ee] - world["target"]).max() < 1e-8  # reached, pose and all
        ent = data["msgs"]["/scene"][k][1].entities[0]
        axes = [ln for ln in ent.lines if len(ln.points) == 2
                and np.allclose([ln.points[0].x, ln.points[0].y, ln.points[0].z], p)]
        assert len(axes) == 3  # x, y, z from the target's origin


def _urdf_joints(urdf: str) -> dict[str, Any]:
    import io as _io

    import yourdfpy

    robot = yourdfpy.URDF.load(_io.StringIO(urdf), build_scene_graph=False, load_meshes=False,
                               build_collision_scene_graph=False, load_collision_meshes=False)
    return robot.robot


def test_export_writes_visuals_and_the_yaml_limits():
    """``mechkin export``'s URDF: every link that carries a joint point has visuals, the end
    effector its x/y/z triad, the position limits are the YAML's (puma560.yaml, degrees ->
    rad) and effort / velocity are the URDF-required 0 ("not given")."""
    from mechkin.api import load_mechanism
    from mechkin.io.urdf_out import robot_urdf
    from mechkin.tasks.robot import robot_description

    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    robot = _urdf_joints(robot_urdf(robot_description(mech)))
    links = {lk.name: lk for lk in robot.links}
    for name in mech.link_names[1:]:
        assert links[name].visuals, name
    assert len(links["tool"].visuals) == 3  # puma560.yaml end_effector: tool
    # puma560.yaml limits [deg]: q1 [-160, 160], q2 [-110, 110], q3 [-135, 135], q4 [-266, 266]
    want = {"q1": 160, "q2": 110, "q3": 135, "q4": 266}
    for j in robot.joints:
        if j.name in want:
            np.testing.assert_allclose([j.limit.lower, j.limit.upper],
                                       np.deg2rad([-want[j.name], want[j.name]]), rtol=1e-12)
            assert (j.limit.effort, j.limit.velocity) == (0.0, 0.0)


def test_track_urdf_carries_the_scenarios_rate_limits(written):
    """planar3r_track_line.yaml limits: {torque: [30, 8, 2], qd: [0.5, 0.3, 0.5]} -> the URDF in
    track.mcap; kim1995_stewart_track: every leg 4000 N, 1 m/s, passive joints none (0)."""
    _, path = written["planar3r_track_line"]
    robot = _urdf_joints(strict_check(path)["msgs"]["/robot_description"][0][1]["data"])
    got = {j.name: (j.limit.effort, j.limit.velocity) for j in robot.joints if j.limit}
    assert [got[n] for n in ("q1", "q2", "q3")] == [(30.0, 0.5), (8.0, 0.3), (2.0, 0.5)]
    report, path = written["kim1995_stewart_track"]
    robot = _urdf_joints(strict_check(path)["msgs"]["/robot_description"][0][1]["data"])
    got = {j.name: (j.limit.effort, j.limit.velocity) for j in robot.joints if j.limit}
    motors = set(report.data.motors)
    assert len(motors) == 6
    for name, lim in got.items():
        assert lim == ((4000.0, 1.0) if name in motors else (0.0, 0.0)), name

"""The robot in the MCAP of an imported robot file (issue 27): example-robot-data's UR5 URDF
(package:// meshes) driven by an fk run and shown by a workspace run, and the bundled MJCF
biped (its mesh files are not shipped) by its ik scenario. Each MCAP passes the strict check;
its ``/robot_description`` parses with yourdfpy, carries the source's meshes (same URIs, same
links, same world poses) beside well-formed URIs only, and its forward kinematics at every
``/joint_states`` message equals ``/tf`` to 1e-9; the layout's URDF layer reads that topic,
driven by ``/joint_states``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.config.robot_files import robots_dir
from tests.config.visual_poses import load_urdf, match_poses, visual_poses
from tests.io.mcap_checks import check_robot_in_view, strict_check, urdf_fk_errors

ROOT = Path(__file__).resolve().parents[2]
ATOL_POSE = 1e-9
UR5 = "ur_description/urdf/ur5_robot.urdf"
FK = """name: ur5_urdf_fk
task: fk
mechanism: {path}
fk:
  time: {{start: 0, stop: 1, step: 0.1}}
  motion:
    shoulder_pan_joint: {{type: ramp, from: 0, to: 1}}
    shoulder_lift_joint: {{type: ramp, from: -1, to: -0.5}}
    elbow_joint: {{type: ramp, from: 1, to: 0.2}}
    wrist_1_joint: {{type: ramp, from: 0, to: -1}}
    wrist_2_joint: {{type: ramp, from: 0.3, to: 1.5}}
    wrist_3_joint: {{type: ramp, from: 0, to: 2}}
"""

WORKSPACE = """name: ur5_urdf_workspace
task: workspace
mechanism: {path}
workspace:
  kind: joint_sweep
  method: grid
  joints:
    shoulder_pan_joint: {{range: [-1, 1], n: 2}}
    shoulder_lift_joint: {{range: [-1, 1], n: 2}}
    elbow_joint: {{range: [-1, 1], n: 2}}
"""


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, Path]:
    from mechkin.api import run

    folder = tmp_path_factory.mktemp("imported")
    (folder / "ur5_urdf_fk.yaml").write_text(FK.format(path=robots_dir() / UR5))
    (folder / "ur5_urdf_ws.yaml").write_text(WORKSPACE.format(path=robots_dir() / UR5))
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MECHKIN_JIT", "0")
        if "NUMBA_CACHE_DIR" not in os.environ:
            mp.setenv("NUMBA_CACHE_DIR", str(tmp_path_factory.mktemp("numba")))
        for name, scenario, task in [
                ("ur5_urdf_fk", folder / "ur5_urdf_fk.yaml", "fk"),
                ("ur5_urdf_workspace", folder / "ur5_urdf_ws.yaml", "workspace"),
                ("biped_floating_ik", ROOT / "scenarios" / "biped_floating_ik.yaml", "ik")]:
            report = run(scenario)
            dest = tmp_path_factory.mktemp(name)
            report.write(dest, plots=False)
            out[name] = dest / f"{task}.mcap"
    return out


@pytest.mark.parametrize("name", ["ur5_urdf_fk", "ur5_urdf_workspace", "biped_floating_ik"])
def test_imported_robot_mcap_is_drawn_as_logged(written, name):
    path = written[name]
    data = strict_check(path)
    err, n_msgs, n_links = urdf_fk_errors(data)
    assert n_msgs == len(data["msgs"]["/tf"]) and n_links >= 6
    assert err <= ATOL_POSE, f"{name}: URDF FK differs from /tf by {err:.3g}"
    uris = check_robot_in_view(data, path)
    assert sum(not u.startswith("data:") for u in uris) >= 7  # the source's meshes


@pytest.mark.parametrize("name", ["ur5_urdf_fk", "ur5_urdf_workspace"])
def test_ur5_mcap_carries_the_source_meshes_where_the_source_puts_them(written, name):
    """Every ``<visual>`` mesh of the UR5 file is in the MCAP's URDF with its package:// URI on
    the link of the same name (base_link's on world: base_link is fixed to it), and at the
    logged joint states it sits where the source URDF puts it (1e-9)."""
    data = strict_check(written[name])
    robot = load_urdf(data["msgs"]["/robot_description"][0][1]["data"])
    src = load_urdf(robots_dir() / UR5)
    src_meshes = {lk.name: [v.geometry.mesh.filename for v in lk.visuals
                            if v.geometry.mesh is not None] for lk in src.robot.links}
    got = {lk.name: [v.geometry.mesh.filename for v in lk.visuals
                     if v.geometry.mesh is not None] for lk in robot.robot.links}
    for link, uris in src_meshes.items():
        if uris:
            assert got["world" if link == "base_link" else link] == uris, link
    keys = {u for uris in src_meshes.values() for u in uris}
    assert len(keys) == 7
    for _, msg in data["msgs"]["/joint_states"]:
        q = {j.name: j.position for j in msg.joints}
        err = match_poses(visual_poses(src, q), visual_poses(robot, q), keys=keys)
        assert err <= ATOL_POSE


def test_biped_mcap_references_its_missing_meshes_and_still_draws_the_legs(written):
    """biped_floating.xml names meshes_not_shipped/part.stl: the URDF references it (file://
    beside the MJCF) on every body that has the geom, and those links keep their generated
    cylinders, so the legs show although the viewer cannot load the mesh."""
    data = strict_check(written["biped_floating_ik"])
    robot = load_urdf(data["msgs"]["/robot_description"][0][1]["data"])
    uri = (ROOT / "mechanisms" / "meshes_not_shipped" / "part.stl").as_uri()
    with_mesh = [lk for lk in robot.robot.links
                 if any(v.geometry.mesh is not None and v.geometry.mesh.filename == uri
                        for v in lk.visuals)]
    assert len(with_mesh) == 7  # the file's seven <geom type="mesh"> bodies
    for lk in with_mesh:
        assert any(v.name == "mechkin_generated" for v in lk.visuals), lk.name

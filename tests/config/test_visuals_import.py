"""Imported visuals (issue 27): a robot file's ``<visual>`` elements (URDF) and visible geoms
(MJCF) reach ``links[].visuals``, the URDF of ``mechkin export`` and of the MCAP logs, at the
same places in the world as in the source, with the same mesh URIs; no mesh file is opened."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.config.robot_files import robots_dir
from tests.config.visual_poses import load_urdf, match_poses, visual_poses

ROOT = Path(__file__).resolve().parents[2]
ATOL_POSE = 1e-9


def _exported(mech_path: Path) -> str:
    from mechkin.io.urdf_out import robot_urdf
    from mechkin.model import load_mechanism
    from mechkin.tasks.robot import robot_description

    return robot_urdf(robot_description(load_mechanism(mech_path)))


def _random_q(robot, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    q = {}
    for j in robot.robot.joints:
        if j.type in ("revolute", "prismatic"):
            q[j.name] = float(rng.uniform(j.limit.lower, j.limit.upper))
        elif j.type == "continuous":
            q[j.name] = float(rng.uniform(-np.pi, np.pi))
    return q


@pytest.mark.parametrize("rel", ["ur_description/urdf/ur5_robot.urdf",
                                 "panda_description/urdf/panda.urdf"])
def test_urdf_meshes_keep_their_uris_and_world_poses_through_export(rel):
    """Every source ``<visual>`` mesh is in the exported URDF with the same URI, and at every
    one of 3 random configurations at the same world pose (scale folded in) to 1e-9; a link
    that stays a link keeps exactly its own URIs (fixed bodies' meshes move to their link)."""
    src_path = robots_dir() / rel
    src = load_urdf(src_path)
    out = load_urdf(_exported(src_path))
    src_meshes = {v[1] for v in visual_poses(src, {})
                  if v[1] not in ("box", "cylinder", "sphere")}
    assert len(src_meshes) >= 7 and all(u.startswith("package://") for u in src_meshes)
    for seed in range(3):
        q = _random_q(src, seed)
        err = match_poses(visual_poses(src, q), visual_poses(out, q), keys=src_meshes)
        assert err <= ATOL_POSE, f"{rel}: a mesh moved by {err:.3g}"
    # per link: its own meshes and those of the bodies fixed to it (they become its frames)
    parent_joint = {j.child: j for j in src.robot.joints}

    def owner(link: str) -> str:
        j = parent_joint.get(link)
        return link if j is None or j.type != "fixed" else owner(j.parent)

    want: dict[str, list[str]] = {}
    for lk in src.robot.links:
        want.setdefault(owner(lk.name), []).extend(
            v.geometry.mesh.filename for v in lk.visuals if v.geometry.mesh)
    got = {lk.name: sorted(v.geometry.mesh.filename for v in lk.visuals if v.geometry.mesh)
           for lk in out.robot.links}
    assert {k: sorted(v) for k, v in want.items() if v} == {k: v for k, v in got.items() if v}


def test_import_yaml_and_export_round_trip_keep_the_visuals(tmp_path):
    """UR5: ``mechkin import`` -> YAML -> ``mechkin export`` -> URDF -> import again: the same
    visuals (URI, world pose) every time."""
    from mechkin.config.tree_import import spec_to_yaml_text
    from mechkin.config.urdf import read_urdf_spec

    src_path = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    spec, _ = read_urdf_spec(src_path)
    yaml_path = tmp_path / "ur5.yaml"
    yaml_path.write_text(spec_to_yaml_text(spec))
    assert "package://example-robot-data/robots/ur_description/meshes/ur5/visual/" \
        in yaml_path.read_text()
    first = _exported(src_path)
    from_yaml = _exported(yaml_path)
    (tmp_path / "again.urdf").write_text(from_yaml)
    again = _exported(tmp_path / "again.urdf")
    q = _random_q(load_urdf(src_path), 7)
    base = visual_poses(load_urdf(first), q)
    for text in (from_yaml, again):
        assert match_poses(base, visual_poses(load_urdf(text), q)) <= ATOL_POSE


URDF_HOSTILE = """<robot name="bot">
<material name="blue"><color rgba="0 0 1 1"/></material>
<link name="a"><visual><geometry><mesh filename="meshes/fifo.stl" scale="0.001 0.001 0.001"/>
</geometry><material name="blue"/></visual></link>
<link name="b"><visual><origin xyz="0 0 0.5" rpy="0 0 1"/><geometry>
<mesh filename="/nonexistent/dir/b.dae"/></geometry></visual>
<visual><geometry><box size="0.1 0.2 0.3"/></geometry><material name="red"><color rgba="1 0 0 1"/>
</material></visual></link>
<link name="c"><visual><geometry><mesh filename="package://pkg/meshes/c.dae" scale="-1 1 1"/>
</geometry></visual><visual><geometry><box size="0 1 1"/></geometry></visual>
<visual><geometry><cylinder radius="0.05" length="0.4"/></geometry></visual>
<visual><geometry><sphere radius="0.07"/></geometry></visual></link>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="j2" type="continuous"><parent link="b"/><child link="c"/><origin xyz="0 0 1"/>
<axis xyz="0 1 0"/></joint></robot>
"""


def test_mesh_files_are_referenced_never_opened(tmp_path):
    """A mesh that is a FIFO (opening it for reading would block the run: the time-out catches
    it), one that does not exist and a package:// one: import, export and an fk run with its
    MCAP all finish; the relative path becomes a file:// URI beside the URDF, the absolute one
    a file:// URI, the package:// one stays; colours come from the robot-level material."""
    (tmp_path / "meshes").mkdir()
    os.mkfifo(tmp_path / "meshes" / "fifo.stl")
    (tmp_path / "r.urdf").write_text(URDF_HOSTILE)
    (tmp_path / "s.yaml").write_text(
        "name: s\ntask: fk\nmechanism: r.urdf\nfk:\n  time: {start: 0, stop: 0.2, step: 0.1}\n"
        "  motion:\n    j1: {type: ramp, from: 0, to: 0.5}\n    j2: {type: ramp, from: 0, to: 1}\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MECHKIN_JIT="0", MPLBACKEND="Agg")
    for args in (["import", "r.urdf", "-o", "r.yaml"], ["export", "r.urdf", "-o", "e.urdf"],
                 ["fk", "s.yaml", "--out", "o", "--no-plots"]):
        r = subprocess.run([sys.executable, "-m", "mechkin", *args], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, (args, r.stderr[-2000:])
        if args[0] == "import":
            assert "r.urdf: note: left out 1 degenerate <visual> elements" in r.stderr
    fifo_uri = (tmp_path / "meshes" / "fifo.stl").as_uri()
    text = (tmp_path / "r.yaml").read_text()
    for uri in (fifo_uri, "file:///nonexistent/dir/b.dae", "package://pkg/meshes/c.dae"):
        assert uri in text
    out = load_urdf((tmp_path / "e.urdf").read_text())
    src = load_urdf(tmp_path / "r.urdf")
    q = {"j1": 0.3, "j2": -1.1}
    got = visual_poses(out, q)
    want = [(lk, fifo_uri if k == "meshes/fifo.stl" else
             ("file:///nonexistent/dir/b.dae" if k.startswith("/nonexistent") else k), T)
            for lk, k, T in visual_poses(src, q)]
    meshes = {w[1] for w in want if w[1] not in ("box", "cylinder", "sphere")}
    assert len(meshes) == 3
    assert match_poses(want, got, keys=meshes) <= ATOL_POSE
    # primitives: b's box, c's cylinder and sphere (generated visuals are named and left out;
    # c's box of size 0 is left out at import, its mirrored mesh (scale -1 1 1) kept)
    src_prims = [w for w in want if w[1] not in meshes and abs(np.linalg.det(w[2])) > 0]
    got_prims = [x for x, v in zip(got, _visual_elements(out), strict=True)
                 if x[1] not in meshes and v.name != "mechkin_generated"]
    assert len(src_prims) == 3 and match_poses(src_prims, got_prims) <= ATOL_POSE
    colours = {m.name: m.color.rgba for m in out.robot.materials if m.color is not None}
    a_vis = [v for lk in out.robot.links if lk.name == "a" for v in lk.visuals
             if v.geometry.mesh is not None]
    np.testing.assert_array_equal(colours[a_vis[0].material.name], [0, 0, 1, 1])
    # a and b name missing file:// meshes: they keep the generated geometry too; c (the end
    # effector) has its package:// mesh, cylinder and sphere and the generated triad only
    by_link = {lk.name: lk.visuals for lk in out.robot.links}
    assert any(v.name == "mechkin_generated" for v in by_link["b"])
    assert sorted(("mesh" if v.geometry.mesh else "cylinder" if v.geometry.cylinder else
                   "sphere") for v in by_link["c"] if v.name != "mechkin_generated"
                  ) == ["cylinder", "mesh", "sphere"]
    assert sorted(v.material.name for v in by_link["c"] if v.name == "mechkin_generated"
                  ) == ["mechkin_axis_x", "mechkin_axis_y", "mechkin_axis_z"]
    assert (tmp_path / "o" / "fk.mcap").stat().st_size > 0


def _visual_elements(robot) -> list:
    """yourdfpy's visuals in the order of :func:`visual_poses`."""
    return [v for lk in robot.robot.links for v in lk.visuals]


MJCF = """<mujoco model="vis"><compiler meshdir="meshes" angle="degree"/>
<asset><mesh name="tet" file="tet.obj" scale="2 1 1.5"/><material name="red" rgba="1 0 0 1"/>
</asset>
<default><default class="visual"><geom group="2" contype="0" conaffinity="0"/></default>
<default class="collision"><geom group="3"/></default></default>
<worldbody><geom type="plane" size="1 1 .1"/>
<body name="base"><geom type="box" size=".1 .2 .05" rgba="0 1 0 1"/>
<body name="arm" pos="0 0 .1" euler="0 0 30"><joint name="j1" type="hinge" axis="0 0 1"/>
<geom class="visual" type="mesh" mesh="tet" pos="0.1 0 0" euler="0 90 0"/>
<geom class="collision" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
<frame pos="0 0 .2" euler="90 0 0"><geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02"
material="red"/></frame>
<body name="tip" pos="0.4 0 0"><joint name="j2" type="hinge" axis="0 1 0" range="-90 90"/>
<geom type="cylinder" size=".02 .1" quat="0.7071 0.7071 0 0"/><site name="tool" pos=".1 0 0"/>
</body></body></body></worldbody></mujoco>
"""
TET = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.2, 0], [0, 0, 0.3]]) + [1.0, 2.0, 3.0]


def _write_mjcf(folder: Path, with_mesh: bool) -> Path:
    (folder / "meshes").mkdir()
    if with_mesh:  # off the origin, so MuJoCo's compiler recentres it
        (folder / "meshes" / "tet.obj").write_text(
            "".join(f"v {v[0]:.17g} {v[1]:.17g} {v[2]:.17g}\n" for v in TET)
            + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (folder / "r.xml").write_text(MJCF)
    return folder / "r.xml"


def test_mjcf_geoms_are_where_mujoco_puts_them(tmp_path):
    """The exported URDF's visuals of an MJCF file at q: the mesh's file vertices (scaled) land
    on MuJoCo's own compiled (recentred) vertices, box / cylinder / sphere on MuJoCo's geom
    poses, the capsule as a cylinder with two end spheres; the plane and the collision capsule
    (group 3) are left out; with the mesh file removed the same visuals are written (the mesh
    still referenced) and the link keeps its generated geometry beside it."""
    import mujoco

    path = _write_mjcf(tmp_path, with_mesh=True)
    q = {"j1": 0.4, "j2": -0.7}
    got = visual_poses(load_urdf(_exported(path)), q)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:] = [q["j1"], q["j2"]]
    mujoco.mj_kinematics(m, d)
    G = mujoco.mjtGeom
    uri = (tmp_path / "meshes" / "tet.obj").as_uri()
    meshes = [T for _, k, T in got if k == uri]
    assert len(meshes) == 1
    want = []  # (key, T_world with sizes as the diagonal, as visual_poses gives them)
    for g in range(m.ngeom):
        typ, grp = int(m.geom_type[g]), int(m.geom_group[g])
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g]
        r, h = m.geom_size[g][0], m.geom_size[g][1]
        if typ == G.mjGEOM_MESH:
            mid = int(m.geom_dataid[g])
            adr, n = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
            mj = (T[:3, :3] @ m.mesh_vert[adr:adr + n].T).T + T[:3, 3]
            ours = (meshes[0] @ np.c_[TET, np.ones(4)].T).T[:, :3]
            assert n == 4
            assert max(np.linalg.norm(mj - p, axis=1).min() for p in ours) <= 1e-6  # float32
        elif grp > 2 or typ == G.mjGEOM_PLANE:
            continue
        elif typ == G.mjGEOM_BOX:
            want.append(("box", T @ np.diag([*(2 * m.geom_size[g]), 1.0])))
        elif typ in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
            want.append(("cylinder", T @ np.diag([r, r, 2 * h, 1.0])))
            if typ == G.mjGEOM_CAPSULE:
                for sgn in (-1, 1):
                    Te = T.copy()
                    Te[:3, 3] += sgn * h * T[:3, 2]
                    want.append(("sphere", Te @ np.diag([r, r, r, 1.0])))
    # every link has the file's visuals, so nothing is generated but the triad on "tool"
    prim = [x for x in got if x[1] in ("box", "cylinder", "sphere") and x[0] != "tool"]
    assert len(want) == 5  # the box, the capsule (3), the cylinder; not the plane or group 3
    assert match_poses([("", k, T) for k, T in want], prim) <= 1e-6  # MuJoCo's float quats

    gone = tmp_path / "gone"
    gone.mkdir()
    path2 = _write_mjcf(gone, with_mesh=False)
    got2 = visual_poses(load_urdf(_exported(path2)), q)
    uri2 = (gone / "meshes" / "tet.obj").as_uri()
    meshes2 = [T for _, k, T in got2 if k == uri2]
    assert len(meshes2) == 1 and np.abs(meshes2[0] - meshes[0]).max() <= 1e-12
    arm = [x for x in got if x[0] == "arm"]
    arm2 = [x for x in got2 if x[0] == "arm"]
    assert len(arm2) > len(arm)  # the generated geometry beside the missing mesh


def test_visuals_in_a_mechanism_yaml_are_checked_and_converted(tmp_path):
    """``links[].visuals`` in a mechanism file: mm -> m (not a mesh's scale), a relative mesh
    path resolved beside the file; one geometry per entry and known URI schemes only, each
    refused with file:line and the key."""
    from mechkin.errors import ConfigError
    from mechkin.model import load_mechanism

    body = """name: m
units: {length: mm, angle: deg}
links:
  - name: base
    visuals:
      - {mesh: meshes/base.stl, scale: [0.001, 0.001, 0.001], xyz: [0, 0, 10], rpy: [0, 0, 90]}
      - {box: [10, 20, 30], rgba: [1, 0, 0, 1]}
  - name: arm
joints:
  - {name: q1, type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 100]},
     axis: [0, 0, 1]}
"""
    (tmp_path / "m.yaml").write_text(body)
    mech = load_mechanism(tmp_path / "m.yaml")
    mesh, box = mech.visuals
    assert mesh.uri == (tmp_path / "meshes" / "base.stl").as_uri()
    assert mesh.size == (0.001, 0.001, 0.001)
    np.testing.assert_allclose(mesh.T[:3, 3], [0, 0, 0.01])
    np.testing.assert_allclose(mesh.T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    assert box.size == pytest.approx((0.01, 0.02, 0.03)) and box.rgba == (1.0, 0.0, 0.0, 1.0)
    for bad, words in [("{box: [1, 1, 1], sphere: 2}", "exactly one geometry"),
                       ("{mesh: 'ftp://h/m.stl'}", "scheme 'ftp'"),
                       ("{sphere: 1, scale: [1, 1, 1]}", "scale goes with mesh")]:
        (tmp_path / "bad.yaml").write_text(body.replace("{box: [10, 20, 30], rgba: [1, 0, 0, 1]}",
                                                        bad))
        with pytest.raises(ConfigError) as exc:
            load_mechanism(tmp_path / "bad.yaml")
        msg = str(exc.value)
        assert "bad.yaml:7" in msg and "links[0].visuals[1]" in msg and words in msg, msg


@pytest.mark.parametrize("visual, ok", [
    ({"mesh": "package://p/m.dae"}, True),
    ({"mesh": "m.stl", "scale": [-1, 1, 1], "rgba": [1, 0, 0, 1]}, True),
    ({"box": [1, 2, 3], "xyz": [0, 0, 1]}, True),
    ({"cylinder": [0.1, 2]}, True),
    ({"sphere": 0.5}, True),
    ({}, False),
    ({"box": [1, 2, 3], "sphere": 1}, False),
    ({"sphere": 1, "scale": [1, 1, 1]}, False),
    ({"sphere": 0}, False),
    ({"cylinder": [1]}, False),
    ({"mesh": "m.stl", "rgba": [2, 0, 0, 1]}, False),
    ({"mesh": "m.stl", "color": "red"}, False),
])
def test_json_schema_and_loader_agree_on_visuals(visual, ok):
    """What an editor checks (the shipped JSON Schema) and what the loader checks agree."""
    import json

    import jsonschema

    from mechkin.config import schema_files
    from mechkin.config.schema import MechanismSpec

    data = {"name": "m", "links": [{"name": "a", "visuals": [visual]}]}
    validator = jsonschema.Draft202012Validator(json.loads(schema_files.schema_text("mechanism")))
    assert (next(validator.iter_errors(data), None) is None) == ok
    try:
        MechanismSpec.model_validate(data)
        loader_ok = True
    except ValueError:  # pydantic's ValidationError
        loader_ok = False
    assert loader_ok == ok


def test_mjcf_visuals_survive_the_yaml_round_trip(tmp_path):
    """``mechkin import`` of the MJCF file -> YAML -> the same visuals (URI, colour, world pose)
    as the MJCF file itself gives, at a configuration away from home."""
    from mechkin.config.mjcf import read_mjcf_spec
    from mechkin.config.tree_import import spec_to_yaml_text

    path = _write_mjcf(tmp_path, with_mesh=True)
    spec, _ = read_mjcf_spec(path)
    (tmp_path / "r.yaml").write_text(spec_to_yaml_text(spec))
    q = {"j1": -1.2, "j2": 0.9}
    direct, via_yaml = (load_urdf(_exported(p)) for p in (path, tmp_path / "r.yaml"))
    assert match_poses(visual_poses(direct, q), visual_poses(via_yaml, q)) <= ATOL_POSE
    colours = [sorted(tuple(m.color.rgba) for m in r.robot.materials if m.color is not None)
               for r in (direct, via_yaml)]
    assert colours[0] == colours[1] and (1.0, 0.0, 0.0, 1.0) in colours[0]

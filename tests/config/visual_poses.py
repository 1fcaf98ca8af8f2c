"""Helpers of the visuals tests (not a test module): the world pose of every ``<visual>`` of a
URDF at a joint configuration, by a forward kinematics written here from yourdfpy's parse
(independent of mechkin's model), so a source file and mechkin's export can be compared."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from tests.io.mcap_checks import _axis_motion


def load_urdf(source: str | Path) -> Any:
    """yourdfpy's parse of a URDF file or text; no mesh is loaded."""
    import yourdfpy

    src = io.StringIO(source) if isinstance(source, str) and "<robot" in source else str(source)
    return yourdfpy.URDF.load(src, build_scene_graph=False, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)


def link_poses(robot: Any, q: dict[str, float]) -> dict[str, np.ndarray]:
    """World pose (4, 4) of every link; ``q`` by joint name (mimic joints follow their master,
    joints missing from ``q`` at 0)."""
    joints = {j.child: j for j in robot.robot.joints}
    roots = set(robot.link_map) - set(joints)
    assert len(roots) == 1, roots
    T_w: dict[str, np.ndarray] = {roots.pop(): np.eye(4)}

    def value(j: Any) -> float:
        if j.mimic is not None:
            return j.mimic.multiplier * q.get(j.mimic.joint, 0.0) + j.mimic.offset
        return q.get(j.name, 0.0)

    def pose(link: str) -> np.ndarray:
        if link not in T_w:
            j = joints[link]
            origin = j.origin if j.origin is not None else np.eye(4)
            axis = np.asarray(j.axis if j.axis is not None else [1.0, 0.0, 0.0], dtype=float)
            T_w[link] = pose(j.parent) @ origin @ _axis_motion(j.type, axis,
                                                                np.array([value(j)]))[0]
        return T_w[link]

    return {name: pose(name) for name in robot.link_map}


def visual_poses(robot: Any, q: dict[str, float]) -> list[tuple[str, str, np.ndarray]]:
    """(link, key, T_world (4, 4) with the mesh scale or the primitive's sizes folded in as a
    diagonal) of every visual; key: the mesh URI, or ``box`` / ``cylinder`` / ``sphere``."""
    poses = link_poses(robot, q)
    out = []
    for lk in robot.robot.links:
        for v in lk.visuals:
            g = v.geometry
            origin = v.origin if v.origin is not None else np.eye(4)
            if g.mesh is not None:
                key = g.mesh.filename
                s = np.broadcast_to(np.asarray(1.0 if g.mesh.scale is None else g.mesh.scale,
                                               dtype=float), (3,))
            elif g.box is not None:
                key, s = "box", np.asarray(g.box.size, dtype=float)
            elif g.cylinder is not None:
                key, s = "cylinder", np.array([g.cylinder.radius, g.cylinder.radius,
                                               g.cylinder.length])
            else:
                key, s = "sphere", np.full(3, g.sphere.radius)
            out.append((lk.name, key, poses[lk.name] @ origin @ np.diag([*s, 1.0])))
    return out


def match_poses(a: list[tuple[str, str, np.ndarray]], b: list[tuple[str, str, np.ndarray]],
                keys: set[str] | None = None) -> float:
    """Largest pose difference when every visual of ``a`` (its key in ``keys``, default all) is
    matched to the nearest visual of ``b`` with the same key, one to one; asserts the counts."""
    def pick(lst):
        return [x for x in lst if keys is None or x[1] in keys]

    a, b = pick(a), pick(b)
    assert sorted(x[1] for x in a) == sorted(x[1] for x in b)
    free = list(b)
    worst = 0.0
    for _, key, T in a:
        cands = [i for i, x in enumerate(free) if x[1] == key]
        errs = [float(np.abs(free[i][2] - T).max()) for i in cands]
        k = int(np.argmin(errs))
        worst = max(worst, errs[k])
        free.pop(cands[k])
    return worst

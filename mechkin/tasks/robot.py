"""The robot model of a run (:class:`mechkin.records.robot.RobotDescription`): the mechanism and
visual geometry generated from it, for the URDF in every MCAP and for ``mechkin export``.

Geometry, every piece fixed in the link it belongs to (so a URDF viewer moves it with the link):

* links: a cylinder from the link's hub (the point of the joint that carries it) to each point
  it carries (the joints placed on it at q = 0, its named frames), like the stick drawing;
* joints: a short, wider cylinder along each joint axis at its point, on the child link
  (revolute and prismatic in two colours); a prismatic joint also as a telescope: a sleeve on
  its parent out to the lower stroke limit and a rod of the stroke's length on its child;
* plates (declared, or the drawing's convex hulls): the polygon extruded (a prism one link
  radius thick, written as a mesh) and its rim as cylinders; the points on the plate are not
  spoked from the hub;
* the end effector: an x/y/z triad (red, green, blue) on its frame.

A link whose file gives visuals (``links[].visuals``: imported meshes and primitives,
:mod:`mechkin.config.visuals_import`) is drawn with those instead (the triad stays), unless one
of its meshes is a ``file://`` URI of a file missing on this machine: then it is drawn with
both (the viewer reports the missing mesh and still shows the link).

Sizes scale with the mechanism (the largest extent of its joint points and frames at home).

Imports: model (drawing, kinematics), records.robot.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.records.robot import RobotDescription, RobotSnapshot, Visual

__all__ = ["link_visuals", "rate_limits", "robot_description", "robot_snapshot",
           "source_visuals"]

MATERIALS = {
    "link": (0.55, 0.6, 0.68, 1.0),
    "revolute": (0.95, 0.55, 0.1, 1.0),
    "prismatic": (0.3, 0.75, 0.35, 1.0),
    "plate": (0.35, 0.45, 0.8, 1.0),
    "axis_x": (0.9, 0.15, 0.15, 1.0),
    "axis_y": (0.15, 0.75, 0.2, 1.0),
    "axis_z": (0.15, 0.3, 0.95, 1.0),
}
LINK_RADIUS = 0.012   # of the mechanism's size
JOINT_RADIUS = 0.025
TRIAD_LENGTH = 0.12
TRIAD_RADIUS = 0.005


def _frame_along(z: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """A pose (4, 4) at ``centre`` whose z axis is the unit vector ``z``."""
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = centre
    return T


def _rod(link: str, a: np.ndarray, b: np.ndarray, radius: float, material: str,
         tol: float) -> Visual | None:
    d = b - a
    length = float(np.linalg.norm(d))
    if length <= tol:
        return None
    return Visual(link, "cylinder", _frame_along(d, 0.5 * (a + b)), (radius, length), material)


def link_visuals(mech: Any) -> tuple[Visual, ...]:
    """The generated visuals of ``mech`` (see the module docstring)."""
    from mechkin.model.drawing import plate_layouts
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.spatial.transforms import invert

    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    kin = forward_kinematics(mech, q0)
    T_f = kin.frames(mech)[0]
    pts = np.concatenate([T_f[:, :3, 3], kin.axes()[1][0]])
    size = float(np.ptp(pts, axis=0).max()) if len(pts) > 1 else 0.0
    size = size if size > 0 else 1.0
    tol = 1e-9 * size
    r_link, r_joint = LINK_RADIUS * size, JOINT_RADIUS * size
    names = mech.link_names
    virtual = set(getattr(mech, "virtual_links", ()))
    out: list[Visual] = []

    # points of each link in its own frame: the hub, then the joints and frames it carries
    hub = {L: np.zeros(3) for L in range(mech.n_links)}
    for k in range(mech.n):
        hub[int(mech.joint_child_link[k])] = invert(mech.B[k])[:3, 3]
    carried: dict[int, list[np.ndarray]] = {L: [] for L in range(mech.n_links)}
    for k in range(mech.n):
        carried[int(mech.joint_parent_link[k])].append(mech.A[k][:3, 3])
    for f in range(mech.n_links, len(mech.frame_names)):
        carried[int(mech.frame_link[f])].append(mech.frame_offset[f][:3, 3])

    plates: dict[int, list[np.ndarray]] = {}
    for p in plate_layouts(mech):
        T_L = T_f[p.link]
        world = _plate_vertices(mech, kin, p.refs, T_f)
        local = (invert(T_L) @ np.c_[world, np.ones(len(world))].T).T[:, :3]
        plates.setdefault(p.link, []).append(local)

    for L in range(mech.n_links):
        if L in virtual:
            continue
        for poly in plates.get(L, []):
            v = _plate_prism(names[L], poly, r_link)
            if v is not None:
                out.append(v)
        on_plate = [v for poly in plates.get(L, []) for v in poly]
        for poly in plates.get(L, []):
            for i in range(len(poly)):
                v = _rod(names[L], poly[i], poly[(i + 1) % len(poly)], r_link, "plate", tol)
                if v is not None:
                    out.append(v)
        seen: list[np.ndarray] = []
        for p in [np.zeros(3), *carried[L]]:
            if any(np.linalg.norm(p - s) <= tol for s in seen):
                continue
            seen.append(p)
            if any(np.linalg.norm(p - v) <= 1e-6 * size for v in on_plate) and on_plate:
                continue
            v = _rod(names[L], hub[L], p, r_link, "link", tol)
            if v is not None:
                out.append(v)

    for k in range(mech.n):
        if mech.s[k] and int(mech.joint_child_link[k]) not in virtual:
            out += _prismatic_visuals(mech, k, r_link, tol)
    for k in range(mech.n):
        C = int(mech.joint_child_link[k])
        if C in virtual:
            continue
        Binv = invert(mech.B[k])
        T = _frame_along(Binv[:3, 2], Binv[:3, 3])
        prism = bool(mech.s[k])
        out.append(Visual(names[C], "cylinder", T,
                          (r_joint * (0.6 if prism else 1.0), 3.0 * r_joint),
                          "prismatic" if prism else "revolute"))

    if mech.end_effector is not None:
        ee = mech.frame_names[mech.end_effector]
        length = TRIAD_LENGTH * size
        for i, axis in enumerate("xyz"):
            e = np.eye(3)[i]
            out.append(Visual(ee, "cylinder", _frame_along(e, 0.5 * length * e),
                              (TRIAD_RADIUS * size, length), f"axis_{axis}"))
    return tuple(out)


def _plate_prism(link: str, poly: np.ndarray, r_link: float) -> Visual | None:
    """A plate's polygon (p, 3) in its link frame as a prism (its best-fit plane, thickness
    one link radius); None for a degenerate polygon."""
    c = poly.mean(axis=0)
    _, sv, vt = np.linalg.svd(poly - c)
    if len(sv) < 2 or sv[1] <= 1e-9 * max(float(sv[0]), 1e-300):
        return None
    T = _frame_along(vt[2], c)
    uv = (poly - c) @ T[:3, :2]
    return Visual(link, "prism", T, (r_link,), "plate", polygon=uv)


def _prismatic_visuals(mech: Any, k: int, r_link: float, tol: float) -> list[Visual]:
    """A prismatic joint as a sleeve on its parent (from the joint's point at q = 0 out to the
    lower stroke limit) and a rod on its child (from the joint's point back along the axis by
    the stroke), so a leg reads as a telescope at every length; without finite limits both
    are half the home extension long."""
    from mechkin.spatial.transforms import invert

    lo, hi, home = float(mech.lower[k]), float(mech.upper[k]), float(mech.home[k])
    finite = np.isfinite(lo) and np.isfinite(hi)
    h = abs(home) if np.isfinite(home) else 0.0
    sleeve = lo if finite and lo > 0 else 0.5 * h
    rod = hi - lo if finite else 0.5 * h
    A, Binv = mech.A[k], invert(mech.B[k])
    P, C = mech.link_names[int(mech.joint_parent_link[k])], mech.link_names[
        int(mech.joint_child_link[k])]
    out = []
    v = _rod(P, A[:3, 3], A[:3, 3] + sleeve * A[:3, 2], 1.6 * r_link, "prismatic", tol)
    if v is not None:
        out.append(v)
    v = _rod(C, Binv[:3, 3] - rod * Binv[:3, 2], Binv[:3, 3], r_link, "link", tol)
    if v is not None:
        out.append(v)
    return out


def _plate_vertices(mech: Any, kin: Any, refs: tuple, T_f: np.ndarray) -> np.ndarray:
    """Vertices (p, 3) in the base frame at home of a plate's references."""
    jo = kin.axes()[1][0]
    pts = []
    for kind, i in refs:
        pts.append(T_f[i, :3, 3] if kind == "frame" else jo[i])
    return np.asarray(pts)


def rate_limits(mech: Any, limits: dict[str, tuple[np.ndarray, np.ndarray]]
                ) -> dict[str, tuple[float, float]]:
    """joint -> (velocity, effort) from a track run's per-joint limits ``{"qd": (lo, hi),
    "torque": (lo, hi)}`` (:func:`mechkin.config.track_spec.limits_si`): the smaller magnitude
    of each pair (URDF limits are symmetric), 0 where the run has none."""
    def sym(key: str, k: int) -> float:
        if key not in limits:
            return 0.0
        lo_a, hi_a = (np.atleast_1d(np.asarray(a, dtype=float)) for a in limits[key])
        if lo_a.shape != (mech.n,) or hi_a.shape != (mech.n,):
            return 0.0
        v = min(abs(float(lo_a[k])), abs(float(hi_a[k])))
        return v if np.isfinite(v) else 0.0

    out = {}
    for k, name in enumerate(mech.joint_names):
        vel, eff = sym("qd", k), sym("torque", k)
        if vel or eff:
            out[name] = (vel, eff)
    return out


def robot_description(mech: Any, rate_limits: dict[str, tuple[float, float]] | None = None
                      ) -> RobotDescription:
    """The robot model of ``mech``: the visuals its file gives (``links[].visuals``, e.g.
    imported meshes) on their links, generated visuals on every other link, the end-effector
    triad always (and velocity / effort limits where the run knows them)."""
    materials = dict(MATERIALS)
    given, own = source_visuals(mech, materials)
    visuals = given + tuple(v for v in link_visuals(mech)
                            if v.link not in own or v.material.startswith("axis_"))
    return RobotDescription(mechanism=mech, visuals=visuals, materials=materials,
                            rate_limits=dict(rate_limits or {}))


def source_visuals(mech: Any, materials: dict[str, Any]) -> tuple[tuple[Visual, ...], set[str]]:
    """(the file's visuals of ``mech`` as records, the links they draw); their colours are
    added to ``materials`` as ``source_<k>`` (one per distinct rgba); a visual without a colour
    names no material (the mesh's own colours). A link with a ``file://`` mesh that is not on
    this machine (looked up, never opened) is not counted as drawn: it keeps its generated
    geometry beside the reference, so the robot shows even where a viewer cannot load it."""
    out = []
    missing: set[str] = set()
    colour_name: dict[tuple, str] = {}
    for v in getattr(mech, "visuals", ()):
        material = ""
        if v.rgba is not None:
            key = tuple(float(x) for x in v.rgba)
            if key not in colour_name:
                colour_name[key] = f"source_{len(colour_name)}"
                materials[colour_name[key]] = key
            material = colour_name[key]
        out.append(Visual(v.link, v.shape, np.asarray(v.T, dtype=float), tuple(v.size),
                          material, uri=v.uri, generated=False))
        if v.uri.startswith("file:") and not _file_exists(v.uri):
            missing.add(v.link)
    return tuple(out), {v.link for v in out} - missing


def _file_exists(uri: str) -> bool:
    """Whether a ``file://`` URI names a regular file here (``os.stat``; nothing is opened)."""
    import os
    from urllib.parse import unquote, urlparse

    return os.path.isfile(unquote(urlparse(uri).path))


def robot_snapshot(mech: Any) -> RobotSnapshot:
    """The robot at home (the closure solved at home for closed chains: the mechanism's home
    values), with its URDF frame tree."""
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.model.urdf_tree import urdf_frame_tree

    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    root, names, parents, T = urdf_frame_tree(mech, forward_kinematics(mech, q0))
    return RobotSnapshot(robot_description(mech), root, names, parents, T,
                         list(mech.joint_names), q0)

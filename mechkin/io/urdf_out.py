"""Mechanism -> URDF text: the spanning tree, valid for Foxglove, RViz and Pinocchio.

Every 1-DOF joint of the built mechanism (``T_parent_child(q) = A Z(q) B``, mechkin.model.
mechanism) becomes one URDF joint, so universal and spherical joints appear as their 2 or 3
revolute joints ``<name>_1..3`` with their inner links ``<name>_link1..2``:

- ``B`` a rotation, or a translation along z for a revolute joint (every origin + axis joint,
  modified D-H, standard D-H with a = 0): ``A Z(q) B = (A B) Z'(q)`` with the axis ``R_B^T z``,
  one URDF joint with origin ``A B`` whose child is the mechkin link itself;
- otherwise (standard D-H with a != 0): the URDF joint (origin ``A``, axis z) moves an
  intermediate link ``<link>_dh`` and a fixed joint ``<link>_dh_fixed`` (origin ``B``) carries
  the mechkin link, so every mechkin link frame keeps its name and pose;
- named frames become massless links on fixed joints ``<frame>_fixed``; inertials are written
  with the com as origin and the tensor in the link axes (rpy 0);
- unlimited revolute joints are ``continuous``; an unlimited prismatic joint gets limits
  +-1e6 m (URDF requires them) and ``unlimited="true"`` in its extension element;
- ``<limit>`` carries the position limits of the mechanism file; URDF requires ``effort`` and
  ``velocity`` too (urdfdom refuses a limit without them): they are the joint's
  ``torque_limit`` and ``velocity_limit`` where the mechanism file gives them (imported from
  the robot file's ``<limit>``), else the run's rate limits where it has them (a track
  scenario's ``limits:``), else ``0``, which the ``<!-- -->`` comment at the top says means
  "not given";
- with ``visuals`` (:func:`robot_urdf`, :mod:`mechkin.tasks.robot`) every link carries the
  generated ``<visual>`` elements (cylinders, spheres, boxes, meshes by URI, plates as
  COLLADA meshes in ``data:`` URIs: :mod:`mechkin.io.collada`) and the robot the
  ``<material>`` colours they name (``mechkin_<name>``); generated visuals are named
  ``mechkin_generated`` so that importing the file again keeps only the source's visuals.

Cuts (and the independent joints, end effector, home values) do not exist in URDF: they are
written twice, as an XML comment for the reader and as elements in the namespace
``urn:mechkin:urdf`` that URDF parsers ignore and ``mechkin.config.urdf`` reads back.
May import: spatial, numpy (duck-typed Mechanism; io sees no model code).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import quoteattr

import numpy as np

from mechkin.io.collada import prism_data_uri
from mechkin.spatial.rotations import rpy_of

if TYPE_CHECKING:
    from mechkin.model import Mechanism
    from mechkin.records.robot import RobotDescription

NS = "urn:mechkin:urdf"
#: the name of generated ``<visual>`` elements (``mechkin import`` leaves them out)
GENERATED = "mechkin_generated"
AXIS_NAMES = ("x", "y", "z", "rx", "ry", "rz")


def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0 else repr(x)


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)


def _origin(T: np.ndarray) -> str:
    return f'<origin xyz="{_vec(T[:3, 3])}" rpy="{_vec(rpy_of(T[:3, :3]))}"/>'


def _own(mech: Any, key: str, k: int, otherwise: float) -> float:
    """The mechanism's own rate limit ``key`` of joint k where it gives one, else
    ``otherwise``."""
    arr = getattr(mech, key, None)
    v = float(arr[k]) if arr is not None else np.inf
    return v if np.isfinite(v) and v > 0 else float(otherwise)


def _visual_xml(visuals: Sequence[Any]) -> str:
    """``<visual>`` elements of one link (records.robot.Visual, duck-typed)."""
    out = []
    for v in visuals:
        size = [float(x) for x in v.size]
        if v.shape == "cylinder":
            geo = f'<cylinder radius="{_num(size[0])}" length="{_num(size[1])}"/>'
        elif v.shape == "sphere":
            geo = f'<sphere radius="{_num(size[0])}"/>'
        elif v.shape == "box":
            geo = f'<box size="{_vec(size)}"/>'
        elif v.shape == "prism":  # a plate: an extruded polygon as an embedded mesh
            uri = prism_data_uri(np.asarray(v.polygon, dtype=float), size[0])
            geo = f"<mesh filename={quoteattr(uri)}/>"
        else:
            geo = f"<mesh filename={quoteattr(v.uri)} scale=\"{_vec(size)}\"/>"
        mat = f"<material name={quoteattr('mechkin_' + v.material)}/>" if v.material else ""
        tag = f'<visual name="{GENERATED}">' if getattr(v, "generated", True) else "<visual>"
        out.append(f"{tag}{_origin(np.asarray(v.T, dtype=float))}<geometry>{geo}</geometry>"
                   f"{mat}</visual>")
    return "".join(out)


def robot_urdf(desc: RobotDescription) -> str:
    """The URDF text of a run's robot model: :func:`mechanism_to_urdf` with its visuals."""
    return mechanism_to_urdf(desc.mechanism, visuals=desc.visuals, materials=desc.materials,
                             rate_limits=desc.rate_limits)


def mechanism_to_urdf(mech: Mechanism, *, visuals: Sequence[Any] = (),
                      materials: Mapping[str, Sequence[float]] | None = None,
                      rate_limits: Mapping[str, tuple[float, float]] | None = None) -> str:
    """The URDF text of ``mech`` (SI: m, rad, kg); see the module docstring for the mapping.

    ``visuals`` (records.robot.Visual) go into their links, ``materials`` (name -> rgba) are
    declared once, ``rate_limits`` (joint -> (velocity, effort)) fill ``<limit>`` where the
    mechanism gives no ``velocity_limit`` / ``torque_limit`` of its own.
    """
    by_link: dict[str, list[Any]] = {}
    for v in visuals:
        by_link.setdefault(v.link, []).append(v)
    rates = dict(rate_limits or {})
    used: set[str] = set(mech.link_names) | set(mech.frame_names) | set(mech.joint_names)

    def fresh(base: str) -> str:
        name = base
        while name in used:
            name += "_"
        used.add(name)
        return name

    out = ['<?xml version="1.0"?>',
           f'<robot name={quoteattr(mech.name)} xmlns:mechkin="{NS}">',
           f"  <!-- written by mechkin export from {mech.source.name if mech.source else 'a'}"
           " mechanism: the spanning tree; loop closures below; effort=\"0\" velocity=\"0\" in"
           " a limit: not given (URDF requires the attributes) -->"]
    for name, rgba in (materials or {}).items():
        out.append(f"  <material name={quoteattr('mechkin_' + name)}><color "
                   f'rgba="{_vec(rgba)}"/></material>')
    nl = len(mech.link_names)
    link_xml: list[str] = []
    joint_xml: list[str] = []
    for li, name in enumerate(mech.link_names):
        inert = ""
        m = float(mech.mass[li])
        Ii = mech.inertia[li]
        if m > 0 or np.any(Ii != 0):
            inert = (f"<inertial><origin xyz=\"{_vec(mech.com[li])}\" rpy=\"0 0 0\"/>"
                     f"<mass value=\"{_num(m)}\"/><inertia ixx=\"{_num(Ii[0, 0])}\" "
                     f"ixy=\"{_num(Ii[0, 1])}\" ixz=\"{_num(Ii[0, 2])}\" iyy=\"{_num(Ii[1, 1])}\" "
                     f"iyz=\"{_num(Ii[1, 2])}\" izz=\"{_num(Ii[2, 2])}\"/></inertial>")
        inert += _visual_xml(by_link.get(name, ()))
        link_xml.append(f"  <link name={quoteattr(name)}>{inert}</link>" if inert
                        else f"  <link name={quoteattr(name)}/>")
    ext: list[str] = []
    joint_pos: dict[int, int] = {}
    for k, jname in enumerate(mech.joint_names):
        prism = bool(mech.s[k])
        parent = mech.link_names[mech.joint_parent_link[k]]
        child = mech.link_names[mech.joint_child_link[k]]
        A, B = mech.A[k], mech.B[k]
        p_B = B[:3, 3]
        lo, hi = float(mech.lower[k]), float(mech.upper[k])
        unlimited = not (np.isfinite(lo) and np.isfinite(hi))
        if prism or (abs(p_B[0]) == 0 and abs(p_B[1]) == 0):
            # A Z(q) Trans(p) R_B = (A Trans(p) R_B) Z'(q): Trans(p) commutes with Z(q)
            origin, axis, target = A @ B, B[:3, :3].T @ np.array([0.0, 0.0, 1.0]), child
            extra = None
        else:
            origin, axis = A, np.array([0.0, 0.0, 1.0])
            target = fresh(f"{child}_dh")
            extra = (target, child, B)
        if prism:
            typ = "prismatic"
            lim = (-1e6, 1e6) if unlimited else (lo, hi)
        else:
            typ = "continuous" if unlimited else "revolute"
            lim = None if unlimited else (lo, hi)
        vel, eff = rates.get(jname, (0.0, 0.0))
        vel, eff = _own(mech, "velocity_limit", k, vel), _own(mech, "torque_limit", k, eff)
        limit = (f'<limit lower="{_num(lim[0])}" upper="{_num(lim[1])}" effort="{_num(eff)}" '
                 f'velocity="{_num(vel)}"/>') if lim else ""
        if not lim and (vel or eff):  # a continuous joint: rate limits only
            limit = f'<limit effort="{_num(eff)}" velocity="{_num(vel)}"/>'
        joint_pos[k] = len(joint_xml)
        joint_xml.append(
            f'  <joint name={quoteattr(jname)} type="{typ}"><parent link={quoteattr(parent)}/>'
            f"<child link={quoteattr(target)}/>{_origin(origin)}<axis xyz=\"{_vec(axis)}\"/>"
            f"{limit}</joint>")
        if extra is not None:
            link_xml.append(f"  <link name={quoteattr(extra[0])}/>")
            joint_xml.append(
                f'  <joint name={quoteattr(fresh(extra[0] + "_fixed"))} type="fixed">'
                f"<parent link={quoteattr(extra[0])}/><child link={quoteattr(extra[1])}/>"
                f"{_origin(extra[2])}</joint>")
        attrs = f'name={quoteattr(jname)} home="{_num(mech.home[k])}"'
        if prism and unlimited:
            attrs += ' unlimited="true"'
        ext.append(f"  <mechkin:joint {attrs}/>")
    for c in getattr(mech, "couplings", ()):  # joint couplings -> URDF <mimic>
        i = joint_pos[c.joint]
        mimic = (f"<mimic joint={quoteattr(mech.joint_names[c.master])} "
                 f'multiplier="{_num(c.multiplier)}" offset="{_num(c.offset)}"/>')
        joint_xml[i] = joint_xml[i][: -len("</joint>")] + mimic + "</joint>"
    for f in range(nl, len(mech.frame_names)):
        fname = mech.frame_names[f]
        vis = _visual_xml(by_link.get(fname, ()))
        link_xml.append(f"  <link name={quoteattr(fname)}>{vis}</link>" if vis
                        else f"  <link name={quoteattr(fname)}/>")
        joint_xml.append(
            f'  <joint name={quoteattr(fresh(fname + "_fixed"))} type="fixed">'
            f"<parent link={quoteattr(mech.link_names[mech.frame_link[f]])}/>"
            f"<child link={quoteattr(fname)}/>{_origin(mech.frame_offset[f])}</joint>")
    out += link_xml + joint_xml
    attrs = f"name={quoteattr(mech.name)}"
    if len(mech.cuts) or len(mech.independent) != mech.n:
        ind = " ".join(mech.joint_names[i] for i in mech.independent)
        attrs += f" independent={quoteattr(ind)}"
    if mech.end_effector is not None:
        attrs += f" end_effector={quoteattr(mech.frame_names[mech.end_effector])}"
    if mech.description:
        attrs += f" description={quoteattr(mech.description)}"
    g = np.asarray(mech.gravity, dtype=float)
    if not np.array_equal(g, [0.0, 0.0, -9.81]):
        attrs += f' gravity="{_vec(g)}"'
    if len(mech.cuts):
        out.append("  <!-- closed loops (mechkin cuts): these frame pairs must coincide;")
        for c in mech.cuts:
            axes = " ".join(a for a, on in zip(AXIS_NAMES, c.mask, strict=True) if on)
            out.append(f"       {c.name}: {mech.frame_names[c.a]} == {mech.frame_names[c.b]}"
                       f" in {axes} -->" if c is mech.cuts[-1] else
                       f"       {c.name}: {mech.frame_names[c.a]} == {mech.frame_names[c.b]}"
                       f" in {axes}")
    out.append(f"  <mechkin:mechanism {attrs}/>")
    for c in mech.cuts:
        frames = f"{mech.frame_names[c.a]} {mech.frame_names[c.b]}"
        mask = "" if bool(np.all(c.mask)) else (
            f' mask="{" ".join(a for a, on in zip(AXIS_NAMES, c.mask, strict=True) if on)}"')
        out.append(f"  <mechkin:cut name={quoteattr(c.name)} frames={quoteattr(frames)}{mask}/>")
    out += ext
    out.append("</robot>")
    return "\n".join(out) + "\n"

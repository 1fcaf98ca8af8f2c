"""URDF robot file -> MechanismSpec (DESIGN.md: config/; "importers produce the same specs").

Parsed by yourdfpy (any xacro-expanded URDF); the raw XML is read once more with lxml for the
line numbers of the problems and for mechkin's own extension elements. The mapping:

- ``<link>`` -> a link; ``<inertial>`` (origin xyz + rpy, mass, inertia about the com in the
  *inertial* frame) -> mechkin's inertial (com in the link frame, inertia about the com in the
  *link* axes: ``R I R^T`` with R the inertial origin's rotation);
- ``revolute`` (limits; beyond +-1e6 both ways: no limit), ``continuous`` (no limits),
  ``prismatic`` -> origin + axis joints (the child link frame is ``T_origin Rot(axis, q)``, the
  URDF convention), ``<limit velocity= effort=>`` -> ``velocity_limit`` and ``torque_limit``
  (0, URDF's usual "not given", is left out); ``fixed`` -> the child link becomes a named
  frame on the parent link (``mechkin.config.tree_import``); a name mechkin names cannot hold
  (``LFoot/FSR/x``) is renamed (``LFoot_FSR_x``) with one note;
- ``<mimic joint= multiplier= offset=>`` -> a joint coupling ``q = multiplier q_joint + offset``
  (``couplings:``; a constraint row of phi, :mod:`mechkin.model.couplings`); ``floating`` and
  ``planar`` joints are refused (no 6-DOF or planar joint): one ``file:line`` message naming
  the joint and the fix;
- ``<gazebo>``, ``<transmission>`` and other extensions are ignored with one note on stderr;
  ``<collision>`` carries no kinematics and is skipped silently; ``<visual>`` (with its
  ``<material>`` colour) goes to ``links[].visuals`` (``mechkin.config.visuals_import``; mesh
  files referenced by URI, never opened);
- closed chains: cuts, independent joints, end effector and home come from the sidecar
  (``ROBOT.mechkin.yaml`` beside the file, or ``sidecar=``), or from the extension elements
  written by ``mechkin export`` (namespace ``urn:mechkin:urdf``)::

      <mechkin:mechanism name="five_bar" independent="q1 q2" end_effector="P"/>
      <mechkin:cut name="pin_P" frames="P P2" mask="x y"/>
      <mechkin:joint name="r1" home="-1.69"/>

May import: config, spatial, errors, numpy, yourdfpy, lxml.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from mechkin.config.load import YamlDoc, note_once, short_str
from mechkin.config.schema import MechanismSpec
from mechkin.config.tree_import import (
    Tree,
    TreeJoint,
    TreeLink,
    find_sidecar,
    merge_sidecar,
    tree_to_spec,
)
from mechkin.config.urdf_check import element_problems, locate_rejection, nonfinite_numbers
from mechkin.config.visuals_import import attach_urdf_visuals
from mechkin.errors import ConfigError

NS = "urn:mechkin:urdf"
#: limits beyond +-1e6 (rad or m) both ways are a vendor's "no limit" (iris.urdf: +-1e16)
UNLIMITED = 1e6
_KNOWN = {"link", "joint", "material"}


def is_urdf(path: str | Path) -> bool:
    """A ``.urdf`` file, or an ``.xml`` file whose root element is ``<robot>``."""
    p = Path(path)
    if p.suffix.lower() == ".urdf":
        return True
    if p.suffix.lower() != ".xml":
        return False
    from mechkin.config.guarded_read import read_head

    head = read_head(p, 4096)  # "" for a FIFO or device: the reader refuses it, located
    import re

    m = re.search(r"<\s*([A-Za-z_][\w:.-]*)", re.sub(r"<\?.*?\?>|<!--.*?-->", "", head, flags=re.S))
    return bool(m) and m.group(1) == "robot"


def _parse_xml(path: Path):
    try:
        from lxml import etree
    except ImportError:  # pragma: no cover - lxml comes with yourdfpy
        raise ConfigError(f"{path}: reading URDF needs yourdfpy (pip install "
                          "'mechkin[urdf]')") from None
    from mechkin.config.guarded_read import check_count, read_robot_xml

    try:
        data = read_robot_xml(path, "URDF file")
        check_count(path, "<joint>", data.count(b"<joint"))
        return etree.fromstring(data, base_url=str(path))
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc}") from None
    except etree.XMLSyntaxError as exc:
        line = exc.lineno or 1
        raise ConfigError(f"{path}:{line}: XML syntax error: {exc.msg}") from None


def _without_geometry(root, path: Path):
    """A copy of the ``<robot>`` element without ``<collision>`` (mechkin uses none) and without
    the ``<visual>`` elements yourdfpy cannot read (a shape it does not know, e.g. a capsule: no
    reason to refuse the kinematics; one note); lxml keeps each element's source line in the
    copy."""
    import copy

    import yourdfpy

    light = copy.deepcopy(root)
    if not light.get("name"):  # xacro output may leave it out (ur3.urdf): the file's stem then
        light.set("name", "")
    dropped = 0
    for link in light.findall("link"):
        for e in link.findall("collision"):
            link.remove(e)
        for e in link.findall("visual"):
            try:
                yourdfpy.URDF._parse_visual(e)
            except Exception:  # yourdfpy raises assorted errors on shapes it does not read
                link.remove(e)
                dropped += 1
    if dropped:
        note_once(path, f"{path.name}: note: left out {dropped} <visual> elements yourdfpy "
                         "cannot read (no kinematics in them)\n")
    return light


def _floats(s: str | None, n: int, where: str) -> list[float]:
    try:
        v = [float(x) for x in (s or "").split()]
    except ValueError:
        raise ConfigError(f"{where}: expected {n} numbers, got {s!r}") from None
    if len(v) != n or not all(np.isfinite(v)):
        raise ConfigError(f"{where}: expected {n} finite numbers, got {s!r}")
    return v


#: The numeric attributes of URDF elements: each must hold finite numbers (a NaN in an origin
#: would otherwise surface as several derived lines, or a numpy message, after the import).
_NUMERIC_ATTRS = {"origin": ("xyz", "rpy"), "axis": ("xyz",),
                  "limit": ("lower", "upper", "effort", "velocity"), "mass": ("value",),
                  "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
                  "dynamics": ("damping", "friction"), "box": ("size",),
                  "cylinder": ("radius", "length"), "sphere": ("radius",),
                  "mesh": ("scale",)}


def read_urdf_spec(path: str | Path, sidecar: str | Path | None = None
                   ) -> tuple[MechanismSpec, YamlDoc]:
    """Read a URDF (+ sidecar) into an SI MechanismSpec and a YamlDoc with the XML lines.

    Raises ConfigError (``file:line: element[name].key: message``) for unsupported joints,
    mimic joints, loops without a cut and unknown names in the sidecar.
    """
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path}: file not found")
    root = _parse_xml(path)
    if root.tag != "robot":
        raise ConfigError(f"{path}:{root.sourceline}: expected a <robot> root element (URDF), "
                          f"got <{root.tag}>")
    try:
        import yourdfpy
        from lxml import etree
    except ImportError:
        raise ConfigError(f"{path}: reading URDF needs yourdfpy (pip install "
                          "'mechkin[urdf]')") from None
    problems = element_problems(root, path)  # located before yourdfpy's bare errors
    if problems:
        raise ConfigError(problems)
    link_line = {e.get("name"): e.sourceline for e in root.findall("link")}
    joint_el = {e.get("name"): e for e in root.findall("joint")}
    couplings = []
    for name, e in joint_el.items():
        m = e.find("mimic")
        typ = e.get("type")
        if m is not None and typ == "fixed":  # a fixed joint follows nothing (talos_reduced)
            continue
        if m is not None:  # q_name = multiplier * q_master + offset: a coupling row of phi
            where = f"{path}:{m.sourceline}: joint[{name}].mimic"
            mult = _floats(m.get("multiplier", "1"), 1, where + ".multiplier")[0]
            off = _floats(m.get("offset", "0"), 1, where + ".offset")[0]
            if not m.get("joint"):
                problems.append(f"{where}: missing joint=\"...\" (the joint it follows); fix: "
                                "e.g. <mimic joint=\"finger_joint1\" multiplier=\"1\"/>")
            elif (joint_el.get(m.get("joint")) is not None
                  and joint_el[m.get("joint")].get("type") == "fixed"):
                problems.append(f"{where}.joint: the master {m.get('joint')!r} is a fixed joint; "
                                f"fix: remove the <mimic> (or make joint {name!r} fixed too)")
            else:
                couplings.append({"joint": name, "master": m.get("joint"), "multiplier": mult,
                                  "offset": off, "_line": m.sourceline, "_file": str(path),
                                  "_label": f"joint[{name}].mimic"})
        if typ in ("floating", "planar"):
            problems.append(f"{path}:{e.sourceline}: joint[{short_str(name)}].type: "
                            f"{short_str(typ)} joints are not supported (mechkin joints: revolute, "
                            "continuous, prismatic, fixed); fix: make it type=\"fixed\" (or "
                            "remove it and its parent link, so its child is the base)")
    problems += nonfinite_numbers(root, path, _NUMERIC_ATTRS)
    if problems:
        raise ConfigError(problems)
    light = _without_geometry(root, path)
    try:
        robot = yourdfpy.URDF.load(io.BytesIO(etree.tostring(light)), build_scene_graph=False,
                                   load_meshes=False, build_collision_scene_graph=False,
                                   load_collision_meshes=False).robot
    except Exception as exc:  # yourdfpy raises assorted errors on malformed files
        raise ConfigError(locate_rejection(light, path, exc)) from None
    links = []
    for lk in robot.links:
        tl = TreeLink(lk.name, line=link_line.get(lk.name, 1))
        if lk.inertial is not None:
            T = np.asarray(lk.inertial.origin if lk.inertial.origin is not None else np.eye(4))
            inertia = np.asarray(lk.inertial.inertia if lk.inertial.inertia is not None
                                 else np.zeros((3, 3)), dtype=float)
            tl.mass = float(lk.inertial.mass or 0.0)
            tl.com = T[:3, 3].copy()
            tl.inertia = T[:3, :3] @ inertia @ T[:3, :3].T  # inertial axes -> link axes
        links.append(tl)
    attach_urdf_visuals(links, robot, path)  # <visual> -> links[].visuals (mesh URIs, unopened)
    joints = []
    for j in robot.joints:
        line = joint_el[j.name].sourceline if j.name in joint_el else 1
        T = np.asarray(j.origin if j.origin is not None else np.eye(4), dtype=float)
        kind = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic",
                "fixed": "fixed"}[j.type]
        axis = np.asarray(j.axis if j.axis is not None else [1.0, 0.0, 0.0], dtype=float)
        if kind != "fixed" and not np.linalg.norm(axis) > 0:
            raise ConfigError(f"{path}:{line}: joint[{j.name}].axis: zero axis")
        limits = None
        if j.type in ("revolute", "prismatic") and j.limit is not None:
            lo, hi = j.limit.lower, j.limit.upper
            nonfinite = [v for v in (lo, hi) if v is not None and not np.isfinite(v)]
            if nonfinite or (lo is not None and hi is not None and lo > hi):
                raise ConfigError(f"{path}:{line}: joint[{j.name}].limit: expected finite "
                                  f"lower <= upper, got lower={lo}, upper={hi}")
            if (lo is not None and hi is not None and lo < hi
                    and min(abs(lo), abs(hi)) < UNLIMITED):
                limits = (float(lo), float(hi))
        rates = _rates(j, f"{path}:{line}: joint[{j.name}].limit") if kind != "fixed" else {}
        joints.append(TreeJoint(j.name, kind, j.parent, j.child, T, axis, limits, line=line,
                                **rates))
    tree = Tree(name=robot.name or path.stem, path=path, links=links, joints=joints,
                couplings=couplings)
    _read_extensions(root, tree, path)
    tree, _ = merge_sidecar(tree, find_sidecar(path, sidecar))
    return tree_to_spec(tree)


def _rates(j, where: str) -> dict[str, float]:
    """``{velocity, effort}`` of a moving joint's ``<limit>`` (URDF requires both on revolute
    and prismatic joints; 0 is the common "not given" and is left out); a negative or
    non-finite value is refused."""
    out: dict[str, float] = {}
    for key in ("velocity", "effort"):
        v = getattr(j.limit, key, None) if j.limit is not None else None
        if v is None:
            continue
        if not (np.isfinite(v) and v >= 0):
            raise ConfigError(f"{where}.{key}: expected a finite number >= 0 (0: not given), "
                              f"got {v}")
        if v > 0:
            out[key] = float(v)
    return out


def _read_extensions(root, tree: Tree, path: Path) -> None:
    """mechkin's elements (cuts, independent, end effector, home); count the ignored ones."""
    for e in root:
        if not isinstance(e.tag, str):  # comments, processing instructions
            continue
        if e.tag.startswith("{" + NS + "}"):
            tag = e.tag[len(NS) + 2:]
            where = f"{path}:{e.sourceline}: mechkin:{tag}"
            if tag == "cut":
                d = {"name": e.get("name"), "frames": (e.get("frames") or "").split(),
                     "_line": e.sourceline, "_file": str(path)}
                if e.get("mask"):
                    d["mask"] = e.get("mask").split()
                if len(d["frames"]) != 2 or not d["name"]:
                    raise ConfigError(f"{where}: expected name= and frames=\"A B\"")
                tree.cuts.append(d)
            elif tag == "mechanism":
                if e.get("independent") is not None:
                    tree.independent = e.get("independent").split()
                if e.get("end_effector"):
                    tree.end_effector = e.get("end_effector")
                if e.get("name"):
                    tree.name = e.get("name")
                if e.get("description"):
                    tree.description = e.get("description")
                if e.get("gravity"):
                    tree.gravity = _floats(e.get("gravity"), 3, where + ".gravity")
            elif tag == "joint":
                if e.get("home") is not None:
                    tree.home[e.get("name")] = _floats(e.get("home"), 1, where + ".home")[0]
                if e.get("unlimited") == "true":
                    for j in tree.joints:
                        if j.name == e.get("name"):
                            j.limits = None
            else:
                tree.ignored[f"mechkin:{tag}"] = tree.ignored.get(f"mechkin:{tag}", 0) + 1
        elif e.tag not in _KNOWN:
            tag = e.tag.split("}")[-1]
            tree.ignored[tag] = tree.ignored.get(tag, 0) + 1

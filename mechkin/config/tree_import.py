"""A kinematic tree read from a robot file (URDF, MJCF) -> MechanismSpec (DESIGN.md: config/).

Importers (``mechkin.config.urdf``, ``mechkin.config.mjcf``) read their format into the plain
``Tree`` below -- bodies, joints (revolute, prismatic, spherical or fixed) with 4x4 origins in the
parent body frame, extra frames (sites, anchors) -- and this module turns it into the same frozen
``MechanismSpec`` the YAML reader produces:

- a body attached by a ``fixed`` joint is not a mechkin link: it becomes a named frame (the body's
  name) on the nearest moving ancestor, with the composed transform; joints hung on it use the
  frame as their parent, and its inertial is lumped into that link (parallel axes);
- a moving joint becomes an ``origin: {xyz, rpy}`` + ``axis`` joint, so the child link frame is
  ``T_origin @ Rot(axis, q)`` (or ``Trans(axis q)``), exactly the URDF joint convention;
- the sidecar (cuts, independent, end_effector, home) is merged in and checked by name here, with
  ``file:line`` of the sidecar.

Every line number of the source file is kept in a ``YamlDoc`` so the model builder reports
topology problems as ``robot.urdf:LINE: joints[3].child: ...``. May import: config, spatial,
errors, numpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field

from mechkin.config.load import YamlDoc, note_once, read_yaml
from mechkin.config.schema import (
    CouplingSpec,
    CutSpec,
    MechanismSpec,
    Name,
    Num,
    Spec,
    validate_model,
)
from mechkin.errors import ConfigError
from mechkin.spatial.rotations import rpy_of

_NAME_OK = r"^[A-Za-z_][A-Za-z0-9_.\-]*$"


@dataclass
class TreeLink:
    """A rigid body: name, inertial (mass, com (3,), inertia about the com (3, 3), both in the
    body frame) or None, and the source line."""

    name: str
    line: int = 1
    mass: float = 0.0
    com: np.ndarray | None = None
    inertia: np.ndarray | None = None
    #: visual elements {"T": (4, 4) in the body frame, mesh|box|cylinder|sphere, scale?, rgba?}
    #: (mechkin.config.visuals_import)
    visuals: list[dict] = field(default_factory=list)


@dataclass
class TreeJoint:
    """A joint: ``kind`` revolute | prismatic | spherical | fixed; ``T`` (4, 4) the pose of the
    joint frame in the parent body frame; ``axis`` in the joint frame; ``limits`` (lo, hi) or
    None; ``offset`` added to q (rad | m)."""

    name: str
    kind: str
    parent: str
    child: str
    T: np.ndarray
    axis: np.ndarray | None = None
    limits: tuple[float, float] | None = None
    offset: float = 0.0
    line: int = 1
    label: str | None = None  # how messages name the element (default ``joint[<name>]``)
    velocity: float | None = None  # rate limits (> 0; rad/s | m/s, N m | N) or None
    effort: float | None = None


@dataclass
class Tree:
    """What an importer read: bodies, joints, extra frames (name, body, T_body_frame, line)."""

    name: str
    path: Path
    links: list[TreeLink]
    joints: list[TreeJoint]
    frames: list[tuple[str, str, np.ndarray, int]] = field(default_factory=list)
    cuts: list[dict] = field(default_factory=list)
    independent: list[str] | None = None
    end_effector: str | None = None
    home: dict[str, Any] = field(default_factory=dict)  # a spherical joint: 3 values
    description: str | None = None
    gravity: list[float] | None = None
    ignored: dict[str, int] = field(default_factory=dict)
    #: joint couplings: {joint, master, multiplier, offset, _line, _file, _label} (SI)
    couplings: list[dict] = field(default_factory=list)
    #: named sites that look like a tool (tool, tcp, end_effector, ee, ...): default end effector
    tool_sites: list[str] = field(default_factory=list)
    #: a floating base (MJCF free joint): the root link moves, its home pose (xyz, rpy) in SI
    floating: tuple[list[float], list[float]] | None = None


class Sidecar(Spec):
    """``ROBOT.mechkin.yaml`` beside a URDF/MJCF file: what the robot file cannot say.

    ``home`` values are SI (rad, m), like the robot file.
    """

    name: Name | None = None
    description: str | None = None
    cuts: list[CutSpec] = Field(default_factory=list)
    independent: list[Name] | None = None
    end_effector: Name | None = None
    home: dict[str, Num] | None = None
    couplings: list[CouplingSpec] | None = None
    base: Literal["floating", "fixed"] | None = None  # floating: the root link moves (6 DOF)


def _clean(v) -> list[float]:
    return [0.0 if abs(float(x)) < 1e-300 else float(x) for x in v]


def find_sidecar(path: Path, sidecar: str | Path | None) -> Path | None:
    """``--sidecar FILE`` or ``ROBOT.mechkin.yaml`` beside the robot file (None if neither)."""
    if sidecar is not None:
        p = Path(sidecar)
        if not p.exists():
            raise ConfigError(f"{p}: sidecar file not found")
        return p
    cand = path.with_name(path.stem + ".mechkin.yaml")
    return cand if cand.exists() else None


def merge_sidecar(tree: Tree, sidecar: Path | None) -> tuple[Tree, YamlDoc | None]:
    """Merge the sidecar into ``tree`` (the sidecar wins over the robot file's own entries)."""
    if sidecar is None:
        return tree, None
    doc = read_yaml(sidecar)
    data = doc.data if doc.data is not None else {}
    sc = validate_model(doc, Sidecar, data)
    if sc.name:
        tree.name = sc.name
    if sc.description:
        tree.description = sc.description
    if "cuts" in data:
        tree.cuts = [c.model_dump(exclude_none=True) | {"_line": doc.line_of(("cuts", i)),
                                                         "_file": str(sidecar)}
                     for i, c in enumerate(sc.cuts)]
    tree.__dict__["_sidecar_where"] = {
        (k,): doc.where((k,)) for k in data if k in ("independent", "end_effector", "home")}
    if "cuts" in data:
        tree.__dict__["_sidecar_where"].update(
            {("cuts", i): doc.where(("cuts", i)) for i in range(len(sc.cuts))})
    if sc.independent is not None:
        tree.independent = list(sc.independent)
        tree.__dict__["_independent_where"] = doc.where(("independent",))
    if sc.end_effector is not None:
        tree.end_effector = sc.end_effector
        tree.__dict__["_ee_where"] = doc.where(("end_effector",))
    if sc.home:
        for k, v in sc.home.items():
            tree.home[k] = float(v)
        tree.__dict__["_home_where"] = doc.where(("home",))
    if sc.base == "floating" and tree.floating is None:
        tree.floating = ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    elif sc.base == "fixed":
        tree.floating = None
    if sc.couplings is not None:  # the sidecar's list replaces the file's couplings
        tree.couplings = [c.model_dump() | {"_line": doc.line_of(("couplings", i)),
                                            "_file": str(sidecar),
                                            "_label": f"couplings[{i}]"}
                          for i, c in enumerate(sc.couplings)]
    return tree, doc


def _inertia_sum(parts: list[tuple[float, np.ndarray, np.ndarray]]):
    """Lump bodies (mass, com, inertia about own com, all in one frame): parallel-axis theorem."""
    m = sum(p[0] for p in parts)
    if m <= 0:
        return 0.0, np.zeros(3), sum((p[2] for p in parts), np.zeros((3, 3)))
    c = sum(p[0] * p[1] for p in parts) / m
    inertia = np.zeros((3, 3))
    for mi, ci, Ii in parts:
        d = ci - c
        inertia += Ii + mi * (d @ d * np.eye(3) - np.outer(d, d))
    return m, c, inertia


def tree_to_spec(tree: Tree, source_lines: dict | None = None) -> tuple[MechanismSpec, YamlDoc]:
    """Collapse fixed joints into named frames and build the SI MechanismSpec (see module doc).

    Raises ConfigError with ``file:line: ...`` lines for a missing or repeated root, a body with
    two parent joints (a loop: declare it as a cut in the sidecar instead), unknown names in the
    sidecar.
    """
    path = tree.path
    renamed = _rename_unsafe(tree)
    problems: list[str] = []
    links = {lk.name: lk for lk in tree.links}
    parent_joint: dict[str, TreeJoint] = {}
    for j in tree.joints:
        for end in (j.parent, j.child):
            if end not in links:
                problems.append(f"{path}:{j.line}: joint[{j.name}]: unknown link {end!r}")
        if j.child in parent_joint:
            problems.append(
                f"{path}:{j.line}: joint[{j.name}].child: link {j.child!r} is already the "
                f"child of joint {parent_joint[j.child].name!r}: a closed loop is declared as a "
                "cut in the sidecar (ROBOT.mechkin.yaml: cuts:), not as a second parent")
        parent_joint.setdefault(j.child, j)
    roots = [lk.name for lk in tree.links if lk.name not in parent_joint]
    if not tree.links and not problems:
        problems.append(f"{path}:1: robot: the file has no links (a xacro macro file?); fix: "
                        "expand it with xacro and import the expanded URDF")
    elif len(roots) != 1 and not problems:
        problems.append(f"{path}:1: robot: expected one root link (a link that is no joint's "
                        f"child), found {len(roots)}: {', '.join(roots[:10])}")
    if problems:
        raise ConfigError(problems)
    root = roots[0]
    children: dict[str, list[TreeJoint]] = {n: [] for n in links}
    for j in tree.joints:
        children[j.parent].append(j)
    # owner link and pose in it, breadth first from the root
    owner: dict[str, tuple[str, np.ndarray]] = {root: (root, np.eye(4))}
    order = [root]
    queue = [root]
    while queue:
        b = queue.pop(0)
        for j in children[b]:
            if j.kind == "fixed":
                ob, T = owner[b]
                owner[j.child] = (ob, T @ j.T)
            else:
                owner[j.child] = (j.child, np.eye(4))
            order.append(j.child)
            queue.append(j.child)
    for name in links:
        if name not in owner:
            lk = links[name]
            problems.append(f"{path}:{lk.line}: link[{name}]: not connected to the root "
                            f"{root!r} (it lies on a cycle of joints)")
    if problems:
        raise ConfigError(problems)
    doc_order = [root] + [lk.name for lk in tree.links if lk.name != root]  # the file's order
    mech_links = [n for n in doc_order if owner[n][0] == n]
    frames: dict[str, list[dict]] = {n: [] for n in mech_links}
    lines: dict[tuple, int] = {(): 1}
    for n in order:
        ob, T = owner[n]
        if ob != n:
            frames[ob].append({"name": n, "xyz": _clean(T[:3, 3]),
                               "rpy": _clean(rpy_of(T[:3, :3]))})
    for fname, body, Tf, _line in tree.frames:
        if body not in owner:
            problems.append(f"{path}:{_line}: frame[{fname}]: unknown body {body!r}")
            continue
        ob, T = owner[body]
        T = T @ Tf
        frames[ob].append({"name": fname, "xyz": _clean(T[:3, 3]),
                           "rpy": _clean(rpy_of(T[:3, :3]))})
    if problems:
        raise ConfigError(problems)
    # inertials lumped into owners
    parts: dict[str, list] = {n: [] for n in mech_links}
    for n in order:
        lk = links[n]
        if lk.com is None and lk.mass == 0 and lk.inertia is None:
            continue
        ob, T = owner[n]
        com = T[:3, :3] @ (lk.com if lk.com is not None else np.zeros(3)) + T[:3, 3]
        inertia = lk.inertia if lk.inertia is not None else np.zeros((3, 3))
        parts[ob].append((lk.mass, com, T[:3, :3] @ inertia @ T[:3, :3].T))
    visuals: dict[str, list[dict]] = {n: [] for n in mech_links}
    for n in order:  # a fixed body's visuals move onto its link, poses composed
        ob, T = owner[n]
        for v in links[n].visuals:
            Tv = T @ v["T"]
            visuals[ob].append({k: x for k, x in v.items() if k != "T"}
                               | {"xyz": _clean(Tv[:3, 3]), "rpy": _clean(rpy_of(Tv[:3, :3]))})
    spec_links = []
    for i, n in enumerate(mech_links):
        d: dict[str, Any] = {"name": n}
        if frames[n]:
            d["frames"] = frames[n]
        if visuals[n]:
            d["visuals"] = visuals[n]
        if parts[n]:
            m, c, inertia = _inertia_sum(parts[n]) if len(parts[n]) > 1 else parts[n][0]
            d["inertial"] = {"mass": float(m), "com": _clean(c),
                             "inertia": _clean([inertia[0, 0], inertia[1, 1], inertia[2, 2],
                                                inertia[0, 1], inertia[0, 2], inertia[1, 2]])}
        spec_links.append(d)
        lines[("links", i)] = links[n].line
    moving = [j for j in tree.joints if j.kind != "fixed"]
    spec_joints = []
    jnames: set[str] = set()
    components: set[str] = set()  # spherical joints' revolutes, <name>_1.._3
    labels: dict[tuple, str] = {}
    for i, j in enumerate(moving):
        d = {"name": j.name, "type": j.kind, "parent": j.parent, "child": j.child,
             "origin": {"xyz": _clean(j.T[:3, 3]), "rpy": _clean(rpy_of(j.T[:3, :3]))}}
        if j.kind == "spherical":  # x-y-z body axes of the joint frame
            d["axes"] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        else:
            d["axis"] = _clean(j.axis)
        if j.offset:
            d["offset"] = float(j.offset)
        if j.limits is not None:
            d["limits"] = [float(j.limits[0]), float(j.limits[1])]
        for key, v in (("velocity_limit", j.velocity), ("torque_limit", j.effort)):
            if v is not None and v > 0 and np.isfinite(v):
                d[key] = float(v)
        home = tree.home.get(j.name)
        if j.kind == "spherical":  # whole (3 values) or by component (<name>_1.._3)
            h = list(home) if isinstance(home, (list, tuple, np.ndarray)) else [0.0] * 3
            for k in range(3):
                h[k] = float(tree.home.get(f"{j.name}_{k + 1}", h[k]))
            d["home"] = [float(x) for x in h]
            spec_joints.append(d)
            jnames.add(j.name)
            components.update(f"{j.name}_{k + 1}" for k in range(3))
            lines[("joints", i)] = j.line
            labels[("joints", i)] = j.label or f"joint[{j.name}]"
            continue
        if home is None:
            home = 0.0
            if j.limits is not None and not j.limits[0] <= 0.0 <= j.limits[1]:
                home = 0.5 * (j.limits[0] + j.limits[1])
        d["home"] = float(home)
        labels[("joints", i)] = j.label or f"joint[{j.name}]"
        spec_joints.append(d)
        jnames.add(j.name)
        lines[("joints", i)] = j.line
    for k in tree.home:
        if k not in jnames and k not in components:
            problems.append(f"{tree.__dict__.get('_home_where', str(path) + ':1: home')}: "
                            f"unknown joint {k!r} (moving joints: {', '.join(sorted(jnames))})")
    all_frames = set(mech_links) | {f["name"] for fl in frames.values() for f in fl}
    cuts = []
    for i, c in enumerate(tree.cuts):
        where = f"{c.get('_file', path)}:{c.get('_line', 1)}: cuts[{i}]"
        for f in c["frames"]:
            if f not in all_frames:
                problems.append(f"{where}.frames: unknown frame {f!r} (links and frames of "
                                f"{path.name}: {', '.join(sorted(all_frames)[:30])})")
        cuts.append({k: v for k, v in c.items() if not k.startswith("_")})
    if tree.independent is not None:
        for k in tree.independent:
            if k not in jnames and k not in components:
                problems.append(f"{tree.__dict__.get('_independent_where', str(path) + ':1')}: "
                                f"unknown joint {k!r} (moving joints: {', '.join(sorted(jnames))})")
    couplings = []
    for i, c in enumerate(tree.couplings):
        where = f"{c.get('_file', path)}:{c.get('_line', 1)}: {c.get('_label', f'couplings[{i}]')}"
        mimic = str(c.get("_label", "")).endswith(".mimic")  # a URDF <mimic joint=...>
        for key in ("joint", "master"):
            if c[key] not in jnames and c[key] not in components:
                fix = (f"; fix: name the joint it follows, e.g. <mimic joint="
                       f"\"{sorted(jnames)[0]}\"/>" if mimic and key == "master" and jnames
                       else "")
                problems.append(f"{where}.{'joint' if mimic else key}: unknown joint "
                                f"{c[key]!r} (moving joints: "
                                f"{', '.join(sorted(jnames)[:30])}){fix}")
        couplings.append({k: (float(v) if k in ("multiplier", "offset") else v)
                          for k, v in c.items() if not k.startswith("_")})
        lines[("couplings", i)] = c.get("_line", 1)
        labels[("couplings", i)] = c.get("_label", f"couplings[{i}]")
    ee = tree.end_effector
    if ee is not None and ee not in all_frames:
        problems.append(f"{tree.__dict__.get('_ee_where', str(path) + ':1: end_effector')}: "
                        f"unknown frame {ee!r}")
    ee_note = None
    if ee is None:
        ee, ee_note = _default_end_effector(tree, order, children)
    if problems:
        raise ConfigError(problems)
    data: dict[str, Any] = {"name": _safe_name(tree.name), "units": {"length": "m", "angle": "rad"},
                            "links": spec_links, "joints": spec_joints}
    if tree.description:
        data["description"] = tree.description
    if cuts:
        data["cuts"] = cuts
    if couplings:
        data["couplings"] = couplings
    if tree.independent is not None:
        data["independent"] = list(tree.independent)
    if ee is not None:
        data["end_effector"] = ee
    if tree.floating is not None:
        data["base"] = "floating"
        data["base_pose"] = {"xyz": _clean(tree.floating[0]), "rpy": _clean(tree.floating[1])}
    if tree.gravity is not None:
        data["gravity"] = [float(g) for g in tree.gravity]
    if ee_note:
        data["notes"] = ee_note
    doc = RobotDoc(path=path, data=data, lines=lines | (source_lines or {}), labels=labels,
                   sidecar=tree.__dict__.get("_sidecar_where", {}))
    spec = validate_model(doc, MechanismSpec, data)
    if tree.ignored:
        what = ", ".join(f"{v} <{k}>" for k, v in sorted(tree.ignored.items()))
        note_once(path, f"{path.name}: note: ignored {what} (not kinematics)\n")
    if renamed:
        eg = ", ".join(f"{a!r} -> {b!r}" for a, b in list(renamed.items())[:2])
        note_once(path, f"{path.name}: note: renamed {len(renamed)} names that mechkin names "
                         f"cannot hold (letters, digits, _ . - only): {eg}"
                         f"{', ...' if len(renamed) > 2 else ''}\n")
    return spec, doc


def _rename_unsafe(tree: Tree) -> dict[str, str]:
    """Give links, joints and frames whose names mechkin names cannot hold (a vendor's
    ``LFoot/FSR/HeelLeft_sensor``) a safe name (each other character ``_``; a clash gets
    ``_2``, ``_3`` ...), everywhere they are referred to (joints' ends, couplings, cuts, the
    sidecar's keys). Returns {old: new}."""
    import re

    names = ([lk.name for lk in tree.links] + [j.name for j in tree.joints]
             + [f[0] for f in tree.frames])
    bad = [n for n in dict.fromkeys(names) if not re.match(_NAME_OK, n or "")]
    if not bad:
        return {}
    taken = set(names)
    ren: dict[str, str] = {}
    for n in bad:
        base = _safe_name(n)
        new, k = base, 1
        while new in taken:
            k += 1
            new = f"{base}_{k}"
        taken.add(new)
        ren[n] = new

    def r(x: Any) -> Any:
        return ren.get(x, x) if isinstance(x, str) else x

    for lk in tree.links:
        lk.name = r(lk.name)
    for j in tree.joints:
        j.name, j.parent, j.child = r(j.name), r(j.parent), r(j.child)
    tree.frames = [(r(f[0]), r(f[1]), *f[2:]) for f in tree.frames]
    for c in tree.couplings:
        c["joint"], c["master"] = r(c["joint"]), r(c["master"])
    for c in tree.cuts:
        c["frames"] = [r(f) for f in c.get("frames", [])]
    if tree.independent is not None:
        tree.independent = [r(x) for x in tree.independent]
    tree.end_effector = r(tree.end_effector)
    tree.home = {r(k): v for k, v in tree.home.items()}
    tree.tool_sites = [r(x) for x in tree.tool_sites]
    return ren


@dataclass(frozen=True)
class RobotDoc(YamlDoc):
    """The YamlDoc of an imported robot file: key paths of the spec print as the file's own
    elements (``joints[3]`` -> ``joint[panda_finger_joint2]``) at their real lines."""

    labels: dict = field(default_factory=dict)
    #: key paths written in the sidecar: (sidecar where-prefix "file:line: key") by key path
    sidecar: dict = field(default_factory=dict)

    def where(self, key_path) -> str:
        from mechkin.config.load import format_key_path

        kp = tuple(key_path)
        for n in range(len(kp), 0, -1):
            if kp[:n] in self.sidecar:
                rest = format_key_path(kp[n:]) if kp[n:] else ""
                return self.sidecar[kp[:n]] + ("" if not rest else
                                               (rest if rest.startswith("[") else "." + rest))
            if kp[:n] in self.labels:
                rest = format_key_path(kp[n:]) if kp[n:] else ""
                label = self.labels[kp[:n]] + ("" if not rest else
                                               (rest if rest.startswith("[") else "." + rest))
                return f"{self.path}:{self.line_of(kp)}: {label}"
        if kp and kp[0] in SIDECAR_KEYS:  # not in the robot file: say where it goes
            side = self.path.with_name(self.path.stem + ".mechkin.yaml").name
            return (f"{self.path}:{self.line_of(kp)}: {format_key_path(kp)} (not in the robot "
                    f"file: set '{kp[0]}:' in the sidecar {side})")
        return super().where(key_path)


#: keys a sidecar can give (what a robot file cannot say)
SIDECAR_KEYS = ("name", "description", "cuts", "independent", "end_effector", "home",
                "couplings", "base")


#: words that mark a tool frame (strong), or probably one (weak)
_TOOL_STRONG = ("tool", "tcp", "end_effector", "endeffector", "attachment_site")
_TOOL_WEAK = ("ee", "eef", "flange", "gripper", "hand")


def tool_rank(name: str) -> int:
    """2 for a name that reads as a tool frame (contains tool, tcp, end_effector), 1 for a
    likely one (a ``_``-separated word ee, eef, flange, gripper, hand), else 0."""
    import re

    low = name.lower()
    if any(w in low for w in _TOOL_STRONG):
        return 2
    return 1 if any(w in _TOOL_WEAK for w in re.split(r"[^a-z0-9]+", low)) else 0


def _default_end_effector(tree: Tree, order: list[str], children: dict
                          ) -> tuple[str | None, str | None]:
    """(frame, note) of the default end effector, or (None, None): the one site or fixed body
    named like a tool (strong names first), else the last moving body of a single serial chain
    (no body with two moving children, no cuts)."""
    fixed_children = [j.child for js in children.values() for j in js if j.kind == "fixed"]
    names = list(tree.tool_sites) + [n for n in fixed_children if n not in tree.tool_sites]
    for rank in (2, 1):
        hit = [n for n in names if tool_rank(n) == rank]
        if len(hit) == 1:
            what = "site" if hit[0] in tree.tool_sites else "frame"
            return hit[0], f"end effector: default: the {what} named like a tool"
    if tree.cuts:
        return None, None
    moving = {n: [j for j in children[n] if j.kind != "fixed"] for n in children}
    if any(len(v) > 1 for v in moving.values()):
        return None, None
    has_moving_parent = {j.child for js in children.values() for j in js if j.kind != "fixed"}
    ends = [n for n in order if n in has_moving_parent and not moving[n]]
    if len(ends) == 1:
        return ends[0], "end effector: default: the last moving body of the serial chain"
    return None, None


def end_effector_candidates(mech_frames: list[str]) -> list[str]:
    """Frames worth naming as the end effector, tool-like names first."""
    return sorted(mech_frames, key=lambda n: -tool_rank(n))


def _safe_name(name: str) -> str:
    import re

    s = re.sub(r"[^A-Za-z0-9_.\-]", "_", name or "robot")
    return s if re.match(_NAME_OK, s) else "_" + s


def spec_to_yaml_text(spec: MechanismSpec, header: str = "") -> str:
    """The spec as a mechanism YAML file (SI units; the importer's output)."""
    import yaml

    d = spec.model_dump(exclude_none=True, exclude_defaults=True)
    d = {"name": spec.name} | d
    d["units"] = {"length": "m", "angle": "rad"}
    for j in d.get("joints", []):
        if j.get("origin") == {}:
            del j["origin"]
    order = ["name", "description", "notes", "units", "dh_convention", "base", "base_pose",
             "links", "joints", "cuts", "couplings", "independent", "end_effector", "gravity",
             "closed_form"]
    d = {k: d[k] for k in order if k in d}

    class _Dumper(yaml.SafeDumper):
        pass

    def _repr_list(dumper, data):
        flow = all(not isinstance(x, (dict, list)) for x in data)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)

    def _repr_dict(dumper, data):
        flat = all(not isinstance(v, dict) and not (isinstance(v, list) and v and
                                                    isinstance(v[0], (dict, list)))
                   for v in data.values())
        return dumper.represent_mapping("tag:yaml.org,2002:map", data,
                                        flow_style=flat and len(data) <= 4)

    _Dumper.add_representer(list, _repr_list)
    _Dumper.add_representer(dict, _repr_dict)
    body = yaml.dump(d, Dumper=_Dumper, sort_keys=False, width=100)
    return header + body

"""MJCF (MuJoCo XML) kinematic tree -> MechanismSpec, through MuJoCo's own model compiler.

``mujoco.MjModel.from_xml_path`` compiles the file (includes, defaults, degrees, ``fromto``,
frames, ...); this module reads the compiled arrays, never the XML, for the kinematics:

- bodies (``body_parentid``, ``body_pos``, ``body_quat``) and their joints (``jnt_type``,
  ``jnt_axis``, ``jnt_pos``, ``jnt_range`` if ``jnt_limited``, ``qpos0``): a body's frame is
  ``T_parent Trans(pos) Rot(quat) prod_k [Trans(p_k) Rot(a_k, q_k - qpos0_k) Trans(-p_k)]``
  (MuJoCo's mj_kinematics), so each joint is a mechkin joint at its anchor ``p_k`` with
  ``offset = -qpos0_k`` (mechkin q = MuJoCo qpos), and a body whose last joint is not at its
  origin becomes a named frame (the body's name) on a link ``<body>_<joint>``;
- hinge -> revolute, slide -> prismatic, ball -> spherical (three revolutes x-y-z: the same
  positions, another parametrisation than MuJoCo's quaternion);
- bodies without joints, sites -> named frames; inertials (``body_mass``, ``body_ipos``,
  ``body_iquat``, principal ``body_inertia``) -> com and tensor in the body axes;
- ``<equality><connect>`` -> a cut with mask x, y, z between the anchor on body1
  (``eq_data[0:3]``) and the compiled anchor on body2 (``eq_data[3:6]``), or between the two
  sites; ``<weld>`` -> a full cut between ``(relpos, relquat)`` on body1 (``eq_data[3:10]``)
  and the anchor on body2 (``eq_data[0:3]``), MuJoCo's weld error ``xpos1 + R1 relpos -
  (xpos2 + R2 anchor)`` and ``quat1 relquat`` vs ``quat2``; site welds join the site frames;
  a linear ``<joint>`` equality is a coupling ``q1 = c1 q2 + c0 + q1_0 - c1 q2_0`` (MuJoCo's
  is relative to qpos0; nonlinear polycoef terms are refused), ``<tendon>`` and ``<flex>``
  equalities are refused, each with the file's line and the fix;
- a free joint: the body is the root of a floating base (``base: floating``, its home the
  keyframe's pose); ball joints start at the keyframe's quaternion; missing mesh / texture
  files: compiled without them (``mujoco.MjSpec``);
- joint torque (force) limits -> ``torque_limit`` where unambiguous (:func:`joint_efforts`:
  ``actuatorfrcrange``, a single actuator's ``forcerange`` times gear, a motor's ``ctrlrange``
  times gain and gear); MuJoCo has no velocity limit;
- independent joints of a closed chain: the joints driven by actuators (``actuator_trnid``),
  unless the sidecar says otherwise (an open chain: every joint but the coupled ones); home:
  the keyframe named ``home`` if there is one, else ``qpos0``.

May import: config, spatial, errors, numpy, mujoco.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from mechkin.config.load import YamlDoc, note_once
from mechkin.config.schema import FLOATING_JOINTS, MechanismSpec
from mechkin.config.tree_import import (
    Tree,
    TreeJoint,
    TreeLink,
    find_sidecar,
    merge_sidecar,
    tool_rank,
    tree_to_spec,
)
from mechkin.config.visuals_import import attach_mjcf_visuals
from mechkin.errors import ConfigError


def _T(pos, quat=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = pos
    if quat is not None:
        w, x, y, z = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
        T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return T


def read_mjcf_spec(path: str | Path, sidecar: str | Path | None = None
                   ) -> tuple[MechanismSpec, YamlDoc]:
    """Compile an MJCF file with MuJoCo and read its kinematic tree and equality constraints.

    Raises ConfigError for a file MuJoCo rejects (its message, with the line it names), free
    joints, and coupling equalities.
    """
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path}: file not found")
    try:
        import mujoco
    except ImportError:
        raise ConfigError(f"{path}: reading MJCF needs MuJoCo (pip install 'mechkin[mjcf]')"
                          ) from None
    from mechkin.config.guarded_read import check_mjcf_files, redirect_mujoco_log

    redirect_mujoco_log(mujoco)  # never MUJOCO_LOG.TXT in the working directory
    text = check_mjcf_files(path)  # regular files within the limits, includes and meshes too
    bad = _nonfinite(text, path)
    if bad:
        raise ConfigError(bad)

    def line_of(tag: str, name: str) -> int:
        m = re.search(rf"<{tag}\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']", text)
        return text.count("\n", 0, m.start()) + 1 if m else 1

    m, _ = _compile(mujoco, path)
    els = _elements(text)
    obj = mujoco.mjtObj

    def name(kind, i: int, default: str) -> str:
        return mujoco.mj_id2name(m, kind, i) or default

    bodies = [name(obj.mjOBJ_BODY, i, f"body{i}") for i in range(m.nbody)]
    blines = [line_of("body", bodies[i]) if mujoco.mj_id2name(m, obj.mjOBJ_BODY, i)
              else els.pick(els.body, i) for i in range(m.nbody)]
    problems = []
    home_q = m.qpos0.copy()
    for k in range(m.nkey):
        if name(obj.mjOBJ_KEY, k, "") == "home":
            home_q = m.key_qpos[k].copy()
    home: dict[str, object] = {}
    free = [j for j in range(m.njnt) if int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE]
    floating = None
    root_body = 0
    if len(free) > 1:
        for j in free[1:]:
            jl = els.pick(els.joint, j)
            problems.append(f"{path}:{jl}: body[{bodies[int(m.jnt_bodyid[j])]}].freejoint: a "
                            "second free body; mechkin has one floating base (fix: weld this "
                            "body to another, or remove its <freejoint/>)")
        raise ConfigError(problems)
    if free:  # the free body is the root, carried by base_x..base_roll (base: floating)
        root_body = int(m.jnt_bodyid[free[0]])
        qa = int(m.jnt_qposadr[free[0]])
        floating = (home_q[qa:qa + 3].tolist(), _rpy(home_q[qa + 3:qa + 7]))
    links = [TreeLink(bodies[root_body], line=blines[root_body])]
    joints: list[TreeJoint] = []
    skipped: set[int] = set()
    efforts = joint_efforts(mujoco, m)
    for b in range(1, m.nbody):
        bname = bodies[b]
        parent_id = int(m.body_parentid[b])
        if b == root_body or parent_id in skipped or (root_body and parent_id == 0):
            if b != root_body:
                skipped.add(b)  # static bodies of the world beside a floating base
            continue
        parent = bodies[parent_id]
        T_pb = _T(m.body_pos[b], m.body_quat[b])
        inert = dict(mass=float(m.body_mass[b]), com=m.body_ipos[b].copy(),
                     inertia=(lambda R: R @ np.diag(m.body_inertia[b]) @ R.T)(
                         _T(np.zeros(3), m.body_iquat[b])[:3, :3]))
        nj, adr = int(m.body_jntnum[b]), int(m.body_jntadr[b])
        line = blines[b]
        if nj == 0:
            links.append(TreeLink(bname, line=line, **inert))
            joints.append(TreeJoint(f"{bname}_weld", "fixed", parent, bname, T_pb, line=line))
            continue
        prev, prev_p, T_first = parent, np.zeros(3), T_pb
        for k in range(nj):
            j = adr + k
            named = mujoco.mj_id2name(m, obj.mjOBJ_JOINT, j)
            jname = named or f"{bname}_j{k + 1}"
            jline = line_of("joint", jname) if named else els.pick(els.joint, j)
            label = f"joint[{jname}]" if named else f"body[{bname}].joint (unnamed, {k + 1}.)"
            typ = int(m.jnt_type[j])
            p = m.jnt_pos[j].copy()
            last = k == nj - 1
            child = bname if (last and not np.any(p)) else f"{bname}_{jname}"
            links.append(TreeLink(child, line=jline, **(inert if child == bname else {})))
            T = (T_first if k == 0 else np.eye(4)) @ _T(p - prev_p)
            qa = int(m.jnt_qposadr[j])
            if typ == mujoco.mjtJoint.mjJNT_BALL:  # home: the keyframe's quaternion
                joints.append(TreeJoint(jname, "spherical", prev, child, T, line=jline,
                                        label=label))
                home[jname] = _ball_angles(home_q[qa:qa + 4])
            else:
                kind = "revolute" if typ == mujoco.mjtJoint.mjJNT_HINGE else "prismatic"
                lim = (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])) \
                    if m.jnt_limited[j] and m.jnt_range[j, 0] < m.jnt_range[j, 1] else None
                joints.append(TreeJoint(jname, kind, prev, child, T, m.jnt_axis[j].copy(), lim,
                                        offset=-float(m.qpos0[qa]), line=jline, label=label,
                                        effort=efforts.get(j)))
                home[jname] = float(home_q[qa])
            prev, prev_p = child, p
        if prev != bname:  # the body frame sits at -p from the last joint's anchor
            links.append(TreeLink(bname, line=line, **inert))
            joints.append(TreeJoint(f"{bname}_frame", "fixed", prev, bname, _T(-prev_p),
                                    line=line))
    if problems:
        raise ConfigError(problems)
    attach_mjcf_visuals(links, mujoco, path, bodies)  # visible geoms -> links[].visuals
    kept = {bodies[root_body]} | {lk.name for lk in links}
    frames = []
    for s in range(m.nsite):
        sname = name(obj.mjOBJ_SITE, s, f"site{s}")
        if bodies[m.site_bodyid[s]] not in kept:
            continue
        sline = (line_of("site", sname) if mujoco.mj_id2name(m, obj.mjOBJ_SITE, s)
                 else els.pick(els.site, s))
        frames.append((sname, bodies[m.site_bodyid[s]], _T(m.site_pos[s], m.site_quat[s]),
                       sline))
    sites = [f[0] for f in frames]
    site_of = {s: name(obj.mjOBJ_SITE, s, f"site{s}") for s in range(m.nsite)}
    cuts, couplings = [], []
    eq_kinds = {int(mujoco.mjtEq.mjEQ_CONNECT): "connect", int(mujoco.mjtEq.mjEQ_WELD): "weld",
                int(mujoco.mjtEq.mjEQ_JOINT): "joint", int(mujoco.mjtEq.mjEQ_TENDON): "tendon"}
    for e in range(m.neq):
        named = mujoco.mj_id2name(m, obj.mjOBJ_EQUALITY, e)
        typ = int(m.eq_type[e])
        tag = eq_kinds.get(typ, "flex")
        ename = named or f"eq{e}"
        eline = line_of(tag, ename) if named else els.pick(els.equality, e)
        label = f"equality/{tag}[{ename}]" if named else f"equality/{tag} (unnamed, {e + 1}.)"
        where = f"{path}:{eline}: {label}"
        if tag == "tendon" and m.eq_active0[e]:
            c = _tendon_coupling(mujoco, m, e, name)
            if c is not None:  # a fixed tendon of two joints held at a length: linear
                couplings.append(c | {"_line": eline, "_file": str(path), "_label": label})
                continue
        if tag in ("tendon", "flex"):
            problems.append(f"{where}: {tag} equalities are not supported (but a fixed "
                            "tendon of two joints); fix: <joint joint1=\"J\" joint2=\"M\" "
                            "polycoef=\"c0 c1 0 0 0\"/> or sidecar couplings: [{joint: J, "
                            "master: M}]")
            continue
        if not m.eq_active0[e]:
            continue
        o1, o2, d = int(m.eq_obj1id[e]), int(m.eq_obj2id[e]), m.eq_data[e]
        if tag == "joint":
            # MuJoCo: q1 - q1_0 = c0 + c1 (q2 - q2_0) + c2 (q2 - q2_0)^2 + ... (qpos0 refs)
            j1 = name(obj.mjOBJ_JOINT, o1, f"joint{o1}")
            if np.any(np.abs(d[2:5]) > 0):
                problems.append(f"{where}.polycoef: nonlinear coupling (polycoef[2:5] = "
                                f"{' '.join(f'{x:g}' for x in d[2:5])}); mechkin couplings are "
                                "linear; fix: polycoef=\"c0 c1 0 0 0\" (a linear fit) or a "
                                "sidecar couplings: entry")
                continue
            if o2 < 0:
                problems.append(f"{where}.joint2: a joint equality without joint2 locks "
                                f"{j1!r}; fix: remove the joint (weld the body) or give "
                                "joint2")
                continue
            j2 = name(obj.mjOBJ_JOINT, o2, f"joint{o2}")
            y0, x0 = float(m.qpos0[m.jnt_qposadr[o1]]), float(m.qpos0[m.jnt_qposadr[o2]])
            couplings.append({"joint": j1, "master": j2, "multiplier": float(d[1]),
                              "offset": float(d[0] + y0 - d[1] * x0), "_line": eline,
                              "_file": str(path), "_label": label})
            continue
        if int(m.eq_objtype[e]) == obj.mjOBJ_SITE:
            fa, fb = site_of[o1], site_of[o2]
        else:
            fa, fb = f"{ename}_a", f"{ename}_b"
            if tag == "connect":
                Ta, Tb = _T(d[0:3]), _T(d[3:6])
            else:
                Ta, Tb = _T(d[3:6], d[6:10]), _T(d[0:3])
            frames.append((fa, bodies[o1], Ta, eline))
            frames.append((fb, bodies[o2], Tb, eline))
        cut = {"name": ename, "frames": [fa, fb], "_line": eline, "_file": str(path)}
        if tag == "connect":
            cut["mask"] = ["x", "y", "z"]
        cuts.append(cut)
    if problems:
        raise ConfigError(problems)
    independent = None
    act = [name(obj.mjOBJ_JOINT, int(m.actuator_trnid[a, 0]), "")
           for a in range(m.nu) if int(m.actuator_trntype[a]) == mujoco.mjtTrn.mjTRN_JOINT]
    if act and cuts:  # an open chain: every joint but the coupled ones (build's default)
        coupled = {c["joint"] for c in couplings}
        independent = list(dict.fromkeys(a for a in act if a not in coupled))
        if floating is not None:
            independent = [*FLOATING_JOINTS, *independent]
    model_name = path.stem
    mm = re.search(r"<mujoco\b[^>]*\bmodel\s*=\s*[\"']([^\"']+)[\"']", text)
    if mm:
        model_name = mm.group(1)
    tree = Tree(name=model_name, path=path, links=links, joints=joints, frames=frames,
                cuts=cuts, independent=independent, home=home,
                gravity=[float(g) for g in m.opt.gravity], couplings=couplings,
                tool_sites=[s for s in sites if tool_rank(s) > 0], floating=floating)
    tree, _ = merge_sidecar(tree, find_sidecar(path, sidecar))
    return tree_to_spec(tree)


def joint_efforts(mujoco, m) -> dict[int, float]:
    """joint id -> the torque (force) bound of a hinge or slide joint where the model gives
    one unambiguously, as a symmetric magnitude (the smaller of ``|lo|``, ``|hi|``):

    - the joint's ``actuatorfrcrange`` (``actuatorfrclimited``): the bound on the sum of its
      actuators' forces;
    - the one actuator with a joint transmission on it: ``forcerange`` (``forcelimited``) times
      ``|gear[0]|``, and for a plain ``<motor>`` (gain fixed, no bias, no dynamics) its
      ``ctrlrange`` (``ctrllimited``) times ``|gainprm[0] gear[0]|``.

    The smallest of these when several are given; joints with two or more actuators take only
    ``actuatorfrcrange``. MuJoCo has no joint velocity limit, so none is read."""
    def mag(lo: float, hi: float) -> float:
        v = min(abs(float(lo)), abs(float(hi)))
        return v if lo < hi and np.isfinite(v) and v > 0 else np.inf

    bounds: dict[int, list[float]] = {}
    for j in range(m.njnt):
        if getattr(m, "jnt_actfrclimited", None) is not None and m.jnt_actfrclimited[j]:
            bounds.setdefault(j, []).append(mag(*m.jnt_actfrcrange[j]))
    on_joint: dict[int, list[int]] = {}
    for a in range(m.nu):
        if int(m.actuator_trntype[a]) == mujoco.mjtTrn.mjTRN_JOINT:
            on_joint.setdefault(int(m.actuator_trnid[a, 0]), []).append(a)
    for j, acts in on_joint.items():
        if len(acts) != 1:
            continue
        a = acts[0]
        gear = abs(float(m.actuator_gear[a, 0]))
        if m.actuator_forcelimited[a]:
            bounds.setdefault(j, []).append(mag(*m.actuator_forcerange[a]) * gear)
        motor = (int(m.actuator_gaintype[a]) == mujoco.mjtGain.mjGAIN_FIXED
                 and int(m.actuator_biastype[a]) == mujoco.mjtBias.mjBIAS_NONE
                 and int(m.actuator_dyntype[a]) == mujoco.mjtDyn.mjDYN_NONE)
        if motor and m.actuator_ctrllimited[a]:
            gain = abs(float(m.actuator_gainprm[a, 0]))
            bounds.setdefault(j, []).append(mag(*m.actuator_ctrlrange[a]) * gain * gear)
    out = {}
    for j, b in bounds.items():
        v = min(b)
        if np.isfinite(v) and v > 0 and int(m.jnt_type[j]) in (
                mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            out[j] = float(v)
    return out


def _compile(mujoco, path: Path):
    """MjModel of the file; when MuJoCo cannot open an asset file (meshes, textures, height
    fields shipped separately, as is common), compile again through ``mujoco.MjSpec`` with those
    assets dropped and mesh geoms replaced by small spheres (mechkin uses no geometry; the body
    masses then come from the spheres unless the file gives inertials). Returns (model, the
    number of dropped assets)."""

    def fail(exc: Exception):
        msg = " ".join(str(exc).split())
        ln = re.search(r"line (\d+)", msg) or re.search(r"Line number=(\d+)", msg)
        return ConfigError(f"{path}:{ln.group(1) if ln else 1}: MJCF: {msg}")

    try:
        return mujoco.MjModel.from_xml_path(str(path)), 0
    except ValueError as exc:
        if not re.search(r"(?i)(error opening file|could not open|resource not found|"
                         r"file not found|no such file)", str(exc)):
            raise fail(exc) from None
        first = exc
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        G = mujoco.mjtGeom
        for g in spec.geoms:
            if g.type in (G.mjGEOM_MESH, G.mjGEOM_SDF, G.mjGEOM_HFIELD):
                g.type = G.mjGEOM_SPHERE
                g.size = [0.01, 0.0, 0.0]
                g.meshname = ""
                g.hfieldname = ""
        for mat in spec.materials:
            mat.textures = [""] * len(mat.textures)
        n = 0
        for kind in ("meshes", "textures", "hfields", "skins"):
            for x in list(getattr(spec, kind)):
                spec.delete(x)
                n += 1
        model = spec.compile()
    except ValueError:
        raise fail(first) from None
    note_once(path, f"{path.name}: note: compiled without its {n} mesh / texture assets "
                     "(missing on disk; the kinematics need none; visuals still reference them)\n")
    return model, n


class _Elements:
    """Source lines of the MJCF elements in MuJoCo's id order (bodies depth first from the
    world body, each body's joints and sites in file order, equality constraints in file
    order), for elements without a name; empty where the file cannot be parsed (then the
    lines come from the names)."""

    def __init__(self) -> None:
        self.body: list[int] = []
        self.joint: list[int] = []
        self.site: list[int] = []
        self.equality: list[int] = []

    @staticmethod
    def pick(lines: list[int], i: int) -> int:
        return lines[i] if 0 <= i < len(lines) else 1


#: Numeric attributes of MJCF elements that must hold finite numbers (MuJoCo takes ``nan``).
_NUMERIC_ATTRS = {tag: ("pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "axis",
                        "range", "ref", "springref", "size", "mass", "diaginertia",
                        "fullinertia", "fromto", "damping", "armature", "stiffness",
                        "frictionloss", "polycoef")
                  for tag in ("body", "joint", "geom", "site", "inertial", "frame", "camera",
                              "light", "freejoint", "weld", "connect")}


def _nonfinite(text: str, path: Path) -> list[str]:
    """One line per numeric attribute of the main file that is not all finite numbers."""
    try:
        from lxml import etree

        root = etree.fromstring(text.encode("utf-8"))
    except Exception:  # noqa: BLE001 - no lxml, or a file lxml cannot parse: MuJoCo reports it
        return []
    from mechkin.config.urdf_check import nonfinite_numbers

    return nonfinite_numbers(root, path, _NUMERIC_ATTRS)


def _elements(text: str) -> _Elements:
    """The lines of the elements of the main file's text (already read and checked)."""
    out = _Elements()
    try:
        from lxml import etree

        root = etree.fromstring(text.encode("utf-8"))
    except Exception:  # no lxml, or a file MuJoCo parses and lxml does not
        return out

    def own(body):  # direct children, through <frame> elements
        for c in body:
            if not isinstance(c.tag, str):
                continue
            if c.tag == "frame":
                yield from own(c)
            else:
                yield c

    def walk(body):
        out.body.append(body.sourceline)
        kids = list(own(body))
        out.joint += [c.sourceline for c in kids if c.tag in ("joint", "freejoint")]
        out.site += [c.sourceline for c in kids if c.tag == "site"]
        for c in kids:
            if c.tag == "body":
                walk(c)

    for wb in root.iter("worldbody"):
        walk(wb)
        break
    for eq in root.iter("equality"):
        out.equality += [c.sourceline for c in eq if isinstance(c.tag, str)]
    return out


def _ball_angles(quat) -> list[float]:
    """x-y-z angles (a, b, c) with Rx(a) Ry(b) Rz(c) = R(quat): the spherical joint's three
    revolutes (mechkin) from a ball joint's quaternion (MuJoCo qpos, w x y z)."""
    R = _T(np.zeros(3), quat)[:3, :3]
    return [float(np.arctan2(-R[1, 2], R[2, 2])),
            float(np.arctan2(R[0, 2], np.hypot(R[0, 0], R[0, 1]))),
            float(np.arctan2(-R[0, 1], R[0, 0]))]


def _rpy(quat) -> list[float]:
    """URDF roll, pitch, yaw of R(quat) = Rz(yaw) Ry(pitch) Rx(roll)."""
    R = _T(np.zeros(3), quat)[:3, :3]
    return [float(np.arctan2(R[2, 1], R[2, 2])),
            float(np.arctan2(-R[2, 0], np.hypot(R[2, 1], R[2, 2]))),
            float(np.arctan2(R[1, 0], R[0, 0]))]


def _tendon_coupling(mujoco, m, e: int, name) -> dict | None:
    """A tendon equality that is a linear joint coupling, or None: a ``<fixed>`` tendon of two
    joints, ``a q_1 + b q_2``, held at ``L0 + c0`` (MuJoCo: ``L - L0 = c0`` without tendon2, L0
    the length at qpos0) gives ``q_2 = -a/b q_1 + (L0 + c0)/b``."""
    t = int(m.eq_obj1id[e])
    if int(m.eq_obj2id[e]) >= 0 or int(m.tendon_num[t]) != 2:
        return None
    adr = int(m.tendon_adr[t])
    if any(int(m.wrap_type[adr + k]) != int(mujoco.mjtWrap.mjWRAP_JOINT) for k in (0, 1)):
        return None
    a, b = float(m.wrap_prm[adr]), float(m.wrap_prm[adr + 1])
    if b == 0.0:
        return None
    ja, jb = int(m.wrap_objid[adr]), int(m.wrap_objid[adr + 1])
    obj = mujoco.mjtObj.mjOBJ_JOINT
    return {"joint": name(obj, jb, f"joint{jb}"), "master": name(obj, ja, f"joint{ja}"),
            "multiplier": -a / b,
            "offset": (float(m.tendon_length0[t]) + float(m.eq_data[e][0])) / b}

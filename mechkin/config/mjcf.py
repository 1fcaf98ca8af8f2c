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
  positions, another parametrisation than MuJoCo's quaternion); free joints are refused;
- bodies without joints, sites -> named frames; inertials (``body_mass``, ``body_ipos``,
  ``body_iquat``, principal ``body_inertia``) -> com and tensor in the body axes;
- ``<equality><connect>`` -> a cut with mask x, y, z between the anchor on body1
  (``eq_data[0:3]``) and the compiled anchor on body2 (``eq_data[3:6]``), or between the two
  sites; ``<weld>`` -> a full cut between ``(relpos, relquat)`` on body1 (``eq_data[3:10]``)
  and the anchor on body2 (``eq_data[0:3]``), MuJoCo's weld error ``xpos1 + R1 relpos -
  (xpos2 + R2 anchor)`` and ``quat1 relquat`` vs ``quat2``; site welds join the site frames;
  ``<joint>``, ``<tendon>``, ``<flex>`` equalities are refused (couplings, like URDF mimic);
- independent joints: the joints driven by actuators (``actuator_trnid``), unless the sidecar
  says otherwise; home: the keyframe named ``home`` if there is one, else ``qpos0``.

May import: config, spatial, errors, numpy, mujoco.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from mechkin.config.load import YamlDoc
from mechkin.config.schema import MechanismSpec
from mechkin.config.tree_import import (
    Tree,
    TreeJoint,
    TreeLink,
    find_sidecar,
    merge_sidecar,
    tree_to_spec,
)
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

    def line_of(tag: str, name: str) -> int:
        m = re.search(rf"<{tag}\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']", text)
        return text.count("\n", 0, m.start()) + 1 if m else 1

    try:
        m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        msg = " ".join(str(exc).split())
        ln = re.search(r"line (\d+)", msg)
        raise ConfigError(f"{path}:{ln.group(1) if ln else 1}: MJCF: {msg}") from None
    obj = mujoco.mjtObj

    def name(kind, i: int, default: str) -> str:
        return mujoco.mj_id2name(m, kind, i) or default

    bodies = [name(obj.mjOBJ_BODY, i, f"body{i}") for i in range(m.nbody)]
    links = [TreeLink(bodies[0], line=1)]
    joints: list[TreeJoint] = []
    problems = []
    home_q = m.qpos0.copy()
    for k in range(m.nkey):
        if name(obj.mjOBJ_KEY, k, "") == "home":
            home_q = m.key_qpos[k].copy()
    home: dict[str, float] = {}
    for b in range(1, m.nbody):
        bname = bodies[b]
        parent = bodies[m.body_parentid[b]]
        T_pb = _T(m.body_pos[b], m.body_quat[b])
        inert = dict(mass=float(m.body_mass[b]), com=m.body_ipos[b].copy(),
                     inertia=(lambda R: R @ np.diag(m.body_inertia[b]) @ R.T)(
                         _T(np.zeros(3), m.body_iquat[b])[:3, :3]))
        nj, adr = int(m.body_jntnum[b]), int(m.body_jntadr[b])
        line = line_of("body", bname)
        if nj == 0:
            links.append(TreeLink(bname, line=line, **inert))
            joints.append(TreeJoint(f"{bname}_weld", "fixed", parent, bname, T_pb, line=line))
            continue
        prev, prev_p, T_first = parent, np.zeros(3), T_pb
        for k in range(nj):
            j = adr + k
            jname = name(obj.mjOBJ_JOINT, j, f"{bname}_j{k + 1}")
            jline = line_of("joint", jname)
            typ = int(m.jnt_type[j])
            if typ == mujoco.mjtJoint.mjJNT_FREE:
                problems.append(f"{path}:{jline}: joint[{jname}].type: free joints are not "
                                "supported (mechkin's base is fixed; weld the body instead)")
                continue
            p = m.jnt_pos[j].copy()
            last = k == nj - 1
            child = bname if (last and not np.any(p)) else f"{bname}_{jname}"
            links.append(TreeLink(child, line=jline, **(inert if child == bname else {})))
            T = (T_first if k == 0 else np.eye(4)) @ _T(p - prev_p)
            qa = int(m.jnt_qposadr[j])
            if typ == mujoco.mjtJoint.mjJNT_BALL:
                joints.append(TreeJoint(jname, "spherical", prev, child, T, line=jline))
            else:
                kind = "revolute" if typ == mujoco.mjtJoint.mjJNT_HINGE else "prismatic"
                lim = (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])) \
                    if m.jnt_limited[j] and m.jnt_range[j, 0] < m.jnt_range[j, 1] else None
                joints.append(TreeJoint(jname, kind, prev, child, T, m.jnt_axis[j].copy(), lim,
                                        offset=-float(m.qpos0[qa]), line=jline))
                home[jname] = float(home_q[qa])
            prev, prev_p = child, p
        if prev != bname:  # the body frame sits at -p from the last joint's anchor
            links.append(TreeLink(bname, line=line, **inert))
            joints.append(TreeJoint(f"{bname}_frame", "fixed", prev, bname, _T(-prev_p),
                                    line=line))
    if problems:
        raise ConfigError(problems)
    frames = []
    for s in range(m.nsite):
        sname = name(obj.mjOBJ_SITE, s, f"site{s}")
        frames.append((sname, bodies[m.site_bodyid[s]], _T(m.site_pos[s], m.site_quat[s]),
                       line_of("site", sname)))
    sites = [f[0] for f in frames]
    cuts = []
    for e in range(m.neq):
        ename = name(obj.mjOBJ_EQUALITY, e, f"eq{e}")
        typ = int(m.eq_type[e])
        kind = {int(mujoco.mjtEq.mjEQ_CONNECT): "connect", int(mujoco.mjtEq.mjEQ_WELD): "weld"}
        tag = kind.get(typ)
        eline = line_of(tag or r"\w+", ename)
        if tag is None:
            problems.append(f"{path}:{eline}: equality[{ename}]: only <connect> and <weld> "
                            "equalities are loop closures; joint, tendon and flex couplings are "
                            "not supported (mechkin has no joint coupling)")
            continue
        if not m.eq_active0[e]:
            continue
        o1, o2, d = int(m.eq_obj1id[e]), int(m.eq_obj2id[e]), m.eq_data[e]
        if int(m.eq_objtype[e]) == obj.mjOBJ_SITE:
            fa, fb = sites[o1], sites[o2]
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
    if act:
        independent = list(dict.fromkeys(act))
    model_name = path.stem
    mm = re.search(r"<mujoco\b[^>]*\bmodel\s*=\s*[\"']([^\"']+)[\"']", text)
    if mm:
        model_name = mm.group(1)
    tree = Tree(name=model_name, path=path, links=links, joints=joints, frames=frames,
                cuts=cuts, independent=independent, home=home,
                gravity=[float(g) for g in m.opt.gravity])
    tree, _ = merge_sidecar(tree, find_sidecar(path, sidecar))
    return tree_to_spec(tree)

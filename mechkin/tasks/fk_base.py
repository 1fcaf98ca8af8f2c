"""The fk task's moving base (``fk: base:``, kim1995 §5.1 Step 1 ``T_0(t)``): the base
trajectory at the fk times, and the fk outputs re-expressed in the world frame.

Design
------
:func:`base_trajectory` turns the validated :class:`mechkin.config.scenario.BaseSpec` into the
base pose, twist and acceleration at each fk time
(:func:`mechkin.model.moving_base.base_motion`; analytic for generators, a spline through a
table or CSV). :func:`base_into_summary` and :func:`base_into_record` then change a finished
fk run: the end-effector pose, twist and acceleration columns and the summary's final
pose become world-frame values (:func:`mechkin.model.moving_base.in_world`), the base's own
pose and motion are added as ``base_*`` columns and a summary ``base`` block, and the motion
record gets the world -> base transform (the MCAP frame tree gains a world root) with its
stick segments and axis points in world axes. A base that is the identity with zero motion at
every step leaves the existing columns and summary values untouched (nothing to compose; bit
for bit today's numbers).

A floating base (``base: floating``, an MJCF free joint) is another thing: its pose is six
joints of the mechanism (``base_x`` .. ``base_roll``), FK inputs like any joint.
:func:`floating_base_fill` gives the values of those the motion does not name: the constant
``fk: base_pose`` or the mechanism's home base pose.

Imports: config, model, records (via tasks.common).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mechkin.config.scenario import BASE_COORDS, BasePoseSpec, BaseSpec
from mechkin.config.schema import FLOATING_JOINTS
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.model.moving_base import base_motion, in_world

#: CSV column suffixes of base coordinates and their SI factors
_LEN_SUFFIX = {"m": 1.0, "mm": 1e-3}
_ANG_SUFFIX = {"rad": 1.0, "deg": np.pi / 180.0}


@dataclass
class BaseTrajectory:
    """The base at m fk times: ``T`` (m, 4, 4) = T_0(t), ``twist`` (m, 6) ``(omega, v)`` and
    ``accel`` (m, 6) ``(alpha, a)`` in world axes; ``frame`` the world frame's name; ``source``
    which form gave it (pose, motion, table, csv)."""

    frame: str
    source: str
    T: np.ndarray
    twist: np.ndarray
    accel: np.ndarray

    @property
    def static_identity(self) -> bool:
        """True when the base is the world frame at every step and never moves."""
        return bool(np.array_equal(self.T, np.broadcast_to(np.eye(4), self.T.shape))
                    and not self.twist.any() and not self.accel.any())


def _factors(sc: Any) -> np.ndarray:
    fl, fa = length_factor(sc.spec.units.length), angle_factor(sc.spec.units.angle)
    return np.array([fl, fl, fl, fa, fa, fa])


def _interp(t_tab: np.ndarray, x: np.ndarray, t: np.ndarray, where: str
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values, first and second derivatives at t of a spline through (t_tab, x (r, 6)):
    not-a-knot cubic for r >= 4 rows, the interpolating quadratic / line for 3 / 2, constant
    for 1."""
    r = len(t_tab)
    if r > 1 and np.any(np.diff(t_tab) <= 0):
        raise ConfigError(f"{where}: base times must increase strictly")
    if r > 1 and (t[0] < t_tab[0] - 1e-12 or t[-1] > t_tab[-1] + 1e-12):
        raise ConfigError(f"{where}: the base times [{t_tab[0]:g}, {t_tab[-1]:g}] s do not "
                          f"cover the fk times [{t[0]:g}, {t[-1]:g}] s")
    if r == 1:
        z = np.zeros((len(t), x.shape[1]))
        return np.broadcast_to(x[0], z.shape).copy(), z, z.copy()
    from scipy.interpolate import make_interp_spline

    sp = make_interp_spline(t_tab, x, k=min(3, r - 1), axis=0)
    tc = np.clip(t, t_tab[0], t_tab[-1])
    return sp(tc), sp(tc, 1), sp(tc, 2)


def _from_generators(spec: BaseSpec, t: np.ndarray, sc: Any
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    m = len(t)
    x, xd, xdd = (np.zeros((m, 6)) for _ in range(3))
    span = max(t[-1] - t[0], 1e-300) if m else 1.0
    fa = angle_factor(sc.spec.units.angle)
    for k, name in enumerate(BASE_COORDS):
        mo = (spec.motion or {}).get(name)
        if mo is None:
            continue
        if mo.type == "constant":
            x[:, k] = mo.value
        elif mo.type == "ramp":
            x[:, k] = mo.start + (mo.to - mo.start) * (t - t[0]) / span
            xd[:, k] = (mo.to - mo.start) / span
        else:
            w = 2 * np.pi * mo.frequency
            arg = w * t + mo.phase * fa
            x[:, k] = mo.offset + mo.amplitude * np.sin(arg)
            xd[:, k] = mo.amplitude * w * np.cos(arg)
            xdd[:, k] = -mo.amplitude * w * w * np.sin(arg)
    return x, xd, xdd


def _from_table(spec: BaseSpec, t: np.ndarray, sc: Any
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    doc, tab = sc.doc, spec.table
    key = ("fk", "base", "table")
    problems = []
    if "t" not in tab:
        problems.append(f"{doc.where(key)}: missing column 't' (times in s)")
    problems += [f"{doc.where(key + (k,))}: not a base coordinate (expected t, "
                 f"{', '.join(BASE_COORDS)})" for k in tab if k != "t" and k not in BASE_COORDS]
    if problems:
        raise ConfigError(problems)
    check_table_lengths(doc, key, tab)
    t_tab = np.asarray(tab["t"], float)
    x = np.zeros((len(t_tab), 6))
    for k, name in enumerate(BASE_COORDS):
        if name in tab:
            x[:, k] = tab[name]
    return _interp(t_tab, x, t, doc.where(key + ("t",)))


def _from_csv(spec: BaseSpec, t: np.ndarray, sc: Any
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A CSV of base poses: ``t_s`` and any of ``x_m|x_mm``, ``y_*``, ``z_*``,
    ``roll_rad|roll_deg``, ``pitch_*``, ``yaw_*`` (values converted to the file units'
    convention of this module: SI divided by the scenario's factors)."""
    from mechkin.config.table_csv import read_numeric_csv

    where = sc.doc.where(("fk", "base", "csv"))
    path = (sc.doc.path.parent / spec.csv).resolve()
    if not path.is_file():
        raise ConfigError(f"{where}: file not found: {spec.csv} (resolved to {path})")
    cols = read_numeric_csv(path)
    if "t_s" not in cols:
        raise ConfigError(f"{path}:1: missing column 't_s'")
    known = {f"{c}_{u}": (k, f) for k, c in enumerate(BASE_COORDS)
             for u, f in (_LEN_SUFFIX if k < 3 else _ANG_SUFFIX).items()}
    bad = [c for c in cols if c != "t_s" and c not in known]
    if bad:
        raise ConfigError(f"{path}:1: column {bad[0]!r} is not a base coordinate (expected t_s "
                          "and x_m|x_mm, y_m|y_mm, z_m|z_mm, roll_rad|roll_deg, "
                          "pitch_rad|pitch_deg, yaw_rad|yaw_deg)")
    seen: dict[int, str] = {}
    t_tab = np.asarray(cols["t_s"], float)
    x = np.zeros((len(t_tab), 6))
    fac = _factors(sc)
    for c, (k, f) in ((c, known[c]) for c in cols if c in known):
        if k in seen:
            raise ConfigError(f"{path}:1: columns {seen[k]!r} and {c!r} give the same "
                              "coordinate")
        seen[k] = c
        x[:, k] = np.asarray(cols[c], float) * f / fac[k]
    return _interp(t_tab, x, t, f"{path}:1: t_s")


def base_trajectory(sc: Any, mech: Any, t: np.ndarray) -> BaseTrajectory | None:
    """The base T_0(t) of the scenario at the fk times t (None without ``fk: base:``).

    Raises ConfigError (located) for a table or CSV that does not fit, or a world frame name
    that is also a frame of the mechanism."""
    spec: BaseSpec | None = sc.section.base
    if spec is None:
        return None
    if spec.frame in mech.frame_names:
        raise ConfigError(f"{sc.doc.where(('fk', 'base', 'frame'))}: {spec.frame!r} is a frame "
                          "of the mechanism; choose another world frame name")
    t = np.asarray(t, float)
    m = len(t)
    if spec.pose is not None:
        x = np.tile(np.r_[spec.pose.xyz, spec.pose.rpy], (m, 1))
        xd, xdd = np.zeros((m, 6)), np.zeros((m, 6))
        source = "pose"
    elif spec.motion is not None:
        x, xd, xdd = _from_generators(spec, t, sc)
        source = "motion"
    elif spec.table is not None:
        x, xd, xdd = _from_table(spec, t, sc)
        source = "table"
    else:
        x, xd, xdd = _from_csv(spec, t, sc)
        source = "csv"
    f = _factors(sc)
    x, xd, xdd = x * f, xd * f, xdd * f
    T, tw, ac = base_motion(x[:, :3], x[:, 3:], xd[:, :3], xd[:, 3:], xdd[:, :3], xdd[:, 3:])
    return BaseTrajectory(frame=spec.frame, source=source, T=T, twist=tw, accel=ac)


def _ee_columns_in_world(cols: dict[str, Any], base: BaseTrajectory, T_e: np.ndarray,
                         tw: np.ndarray | None, acc: np.ndarray | None) -> None:
    """Replace the ``ee_*`` pose / twist / acceleration columns (base frame) by world ones,
    from the end-effector poses T_e (m, 4, 4), twists and accelerations (m, 6) in the base
    frame (nan rows of failed steps written as 0, as the base-frame columns)."""
    from mechkin.tasks.common import pose_columns

    T_w, tw_w, ac_w = in_world(base.T, base.twist, base.accel, T_e[:, None],
                               None if tw is None else np.nan_to_num(tw, nan=0.0)[:, None],
                               None if acc is None else np.nan_to_num(acc, nan=0.0)[:, None])
    cols.update(pose_columns(T_w[:, 0]))
    if tw is not None and "ee_wx_rad_s" in cols:
        for k, a in enumerate("xyz"):
            cols[f"ee_w{a}_rad_s"] = tw_w[:, 0, k]
            cols[f"ee_v{a}_m_s"] = tw_w[:, 0, 3 + k]
            cols[f"ee_alpha{a}_rad_s2"] = ac_w[:, 0, k]
            cols[f"ee_a{a}_m_s2"] = ac_w[:, 0, 3 + k]


def base_columns(base: BaseTrajectory) -> dict[str, np.ndarray]:
    """CSV columns of the base: pose (``base_x_m`` .. ``base_qz``), twist and acceleration in
    world axes (``base_wx_rad_s`` .. ``base_az_m_s2``)."""
    from mechkin.tasks.common import pose_columns

    cols = pose_columns(base.T, prefix="base_")
    for k, a in enumerate("xyz"):
        cols[f"base_w{a}_rad_s"] = base.twist[:, k]
    for k, a in enumerate("xyz"):
        cols[f"base_v{a}_m_s"] = base.twist[:, 3 + k]
    for k, a in enumerate("xyz"):
        cols[f"base_alpha{a}_rad_s2"] = base.accel[:, k]
    for k, a in enumerate("xyz"):
        cols[f"base_a{a}_m_s2"] = base.accel[:, 3 + k]
    return cols


def base_summary(base: BaseTrajectory) -> dict[str, Any]:
    """The summary's ``base`` block: world frame, source, final pose, peak speeds."""
    return {
        "world_frame": base.frame,
        "source": base.source,
        "final": {"xyz_m": base.T[-1, :3, 3].tolist(), "R": base.T[-1, :3, :3].tolist()},
        "max_speed_m_s": float(np.linalg.norm(base.twist[:, 3:], axis=1).max(initial=0.0)),
        "max_angular_speed_rad_s": float(np.linalg.norm(base.twist[:, :3], axis=1)
                                         .max(initial=0.0)),
        "max_acceleration_m_s2": float(np.linalg.norm(base.accel[:, 3:], axis=1)
                                       .max(initial=0.0)),
    }


def base_into_summary(base: BaseTrajectory | None, summary: dict[str, Any]) -> None:
    """The summary with a moving base: ``final.end_effector`` in the world frame (the base-frame
    pose kept as ``final.end_effector_in_base``) and the ``base`` block."""
    if base is None:
        return
    ee = summary["final"].get("end_effector")
    if ee is not None:
        summary["final"]["end_effector_in_base"] = dict(ee)
    if ee is not None and not base.static_identity:
        T_e = np.eye(4)
        T_e[:3, :3], T_e[:3, 3] = ee["R"], ee["xyz_m"]
        T_w = base.T[-1] @ T_e
        summary["final"]["end_effector"] = {**ee, "xyz_m": T_w[:3, 3].tolist(),
                                            "R": T_w[:3, :3].tolist()}
    summary["base"] = base_summary(base)


def base_into_record(base: BaseTrajectory | None, rec: Any, T_e: np.ndarray | None = None,
                     twist: np.ndarray | None = None, accel: np.ndarray | None = None) -> None:
    """The motion record with a moving base: the end-effector columns in the world frame (from
    ``T_e`` (m, 4, 4), ``twist`` and ``accel`` (m, 6) of the end effector in the base frame),
    the base columns (before ``closure_residual``), the world -> base transform, and the stick
    segments, plates and axis points in world axes."""
    if base is None:
        return
    cols = rec.columns
    if not base.static_identity:
        if T_e is not None:
            _ee_columns_in_world(cols, base, T_e, twist, accel)
        T0 = base.T
        if rec.segments is not None:
            rec.segments = (np.einsum("mij,msej->msei", T0[:, :3, :3], rec.segments)
                            + T0[:, None, None, :3, 3])
        if rec.axis_points is not None:
            rec.axis_points = (np.einsum("mij,mnj->mni", T0[:, :3, :3], rec.axis_points)
                               + T0[:, None, :3, 3])
        rec.plates = {name: np.einsum("mij,mpj->mpi", T0[:, :3, :3], P) + T0[:, None, :3, 3]
                      for name, P in rec.plates.items()}
    keys = list(cols)
    cut = keys.index("closure_residual") if "closure_residual" in keys else len(keys)
    new = {k: cols[k] for k in keys[:cut]}
    new.update(base_columns(base))
    new.update({k: cols[k] for k in keys[cut:]})
    rec.columns = new
    rec.world_frame = base.frame
    rec.T_world_base = base.T


def check_table_lengths(doc: Any, key: tuple, tab: dict) -> None:
    """A ``table:`` (``t`` and one list per column) whose columns differ in length or are
    empty: one located ConfigError (the fk motion table and the base table)."""
    lens = {k: len(v) for k, v in tab.items()}
    if len(set(lens.values())) != 1 or lens["t"] == 0:
        raise ConfigError(f"{doc.where(key)}: columns must have the same non-zero length, "
                          f"got {lens}")


def base_pose_joints(pose: BasePoseSpec, units: Any) -> dict[str, float]:
    """A floating base pose (``xyz`` + URDF ``rpy`` in a file's units) as the values [m, rad]
    of its six joints: base_x, base_y, base_z = xyz; R = Rz(yaw) Ry(pitch) Rx(roll) is the
    chain base_yaw -> base_pitch -> base_roll, so base_yaw = rpy[2], base_roll = rpy[0]."""
    fl, fa = length_factor(units.length), angle_factor(units.angle)
    x, y, z = (float(v) * fl for v in pose.xyz)
    r, p, w = (float(v) * fa for v in pose.rpy)
    return dict(zip(FLOATING_JOINTS, (x, y, z, w, p, r), strict=True))


def no_floating_base(sc: Any, mech: Any, key: tuple,
                     fix: str = "for a fixed base placed in a world frame use fk: base: "
                                "{pose: {xyz: [...], rpy: [...]}}") -> str:
    """The one-line refusal of a ``base_pose`` for a mechanism without a floating base."""
    src = mech.source.name if getattr(mech, "source", None) is not None else mech.name
    return (f"{sc.doc.where(key)}: mechanism {src!r} has no floating base, so there is no base "
            "pose to give; base_pose needs 'base: floating' in the mechanism file (or an MJCF "
            f"free joint); {fix}")


def floating_base_fill(sc: Any, mech: Any, given: Any) -> tuple[dict[int, float], list[str]]:
    """Values [SI] of the floating base's independent joints that the motion, table or CSV does
    not name (``given``: the joint names it names), by index into the independent joints: the
    section's ``base_pose`` or the mechanism's home base pose; and the problems (one line each):
    a ``base_pose`` without a floating base, or with base joints named too."""
    spec = sc.section
    pose = getattr(spec, "base_pose", None)
    key = ("fk", "base_pose")
    if not getattr(mech, "floating", False):
        return {}, ([no_floating_base(sc, mech, key)] if pose is not None else [])
    named = [n for n in FLOATING_JOINTS if n in set(given)]
    problems = []
    if pose is not None and named:
        problems.append(f"{sc.doc.where(key)}: give base_pose or the base joints in the "
                        f"motion, table or csv, not both (named there: {', '.join(named)})")
    values = base_pose_joints(pose, sc.spec.units) if pose is not None else {}
    fill = {}
    for i, n in enumerate(mech.independent_names):
        if n in FLOATING_JOINTS and n not in named:
            fill[i] = values.get(n, float(mech.home[mech.independent[i]]))
    return fill, problems

"""The files of a motion record (fk steps, ik targets): ``<task>.csv`` (or ``<task>.npz`` /
``<task>.parquet``, ``outputs.table``: :mod:`mechkin.io.table_out`), ``joints.png``,
``stick.png``, ``convergence.png`` (ik), ``<task>.mcap`` and its Foxglove layout
``<task>.layout.json``.

fk's ``joints.png`` draws the joints against time; ik's draws them per target (a dot plot on
the target names, with the position and orientation errors below), since ik targets are not a
trajectory. ``/mechkin/state`` has one fixed JSON schema per task (:func:`state_schema`).

Imports: records (types), io.table_out, io.mcap_out, io.foxglove_layout, io.plots (lazily).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from mechkin.io.foxglove_layout import layout, state_path
from mechkin.io.output_dir import OutputDir
from mechkin.io.table_out import write_table
from mechkin.records import MotionRecord, Report

if TYPE_CHECKING:
    from mechkin.io.mcap_out import MotionLog, Scene


#: Targets drawn as spheres all at once in an ik log's /scene, at most (each costs every step).
MAX_TARGET_SPHERES = 200
TARGET_FRAME = "target"
_AXIS_RGBA = ((0.9, 0.15, 0.15, 1.0), (0.15, 0.75, 0.2, 1.0), (0.15, 0.3, 0.95, 1.0))


def target_items(T: np.ndarray, size: float) -> tuple[list[Any], list[Any]]:
    """(lines, spheres) of ik targets ``T`` (m, 4, 4): at each step the axes of that step's
    target (x red, y green, z blue), and every target's position as a sphere (up to
    ``MAX_TARGET_SPHERES``)."""
    from mechkin.io.mcap_out import Lines, Spheres

    length = 0.12 * size
    o = T[:, :3, 3]
    lines = [Lines(np.stack([o, o + length * T[:, :3, i]], axis=1), kind="list",
                   thickness=0.006 * size, rgba=_AXIS_RGBA[i]) for i in range(3)]
    spheres = []
    if len(T) <= MAX_TARGET_SPHERES:
        spheres.append(Spheres(o, radius=0.012 * size, rgba=(0.95, 0.2, 0.6, 0.8)))
    return lines, spheres


def motion_scene(rec: MotionRecord) -> Scene:
    """/scene of a motion: the stick segments and plate outlines as lines and the joint-axis
    points as spheres; for ik, the axes of the current target and every target's position."""
    from mechkin.io.mcap_out import Lines, Scene, Spheres

    seg = rec.segments
    outlines = [np.stack([p, np.roll(p, -1, axis=1)], axis=2) for p in rec.plates.values()]
    if outlines and seg is not None:
        seg = np.concatenate([seg, *outlines], axis=1)
    m = seg.shape[0]
    size = float(np.ptp(seg.reshape(-1, 3), axis=0).max()) if seg.size else 1.0
    size = size if size > 0 else 1.0
    lines = [Lines(seg.reshape(m, -1, 3), kind="list", thickness=0.01 * size,
                   rgba=(0.2, 0.5, 0.9, 1.0))] if seg.shape[1] else []
    spheres = [Spheres(rec.axis_points, radius=0.015 * size)]
    T_t = _finite_targets(rec)
    if T_t is not None:
        t_lines, t_spheres = target_items(T_t, size)
        lines += t_lines
        spheres += t_spheres
    return Scene(lines=tuple(lines), spheres=tuple(spheres))


def _finite_targets(rec: MotionRecord) -> np.ndarray | None:
    T = rec.target_poses
    if T is None or rec.task != "ik" or T.shape != (len(rec.times), 4, 4):
        return None
    return T if np.isfinite(T).all() else None


_NUM, _STR = {"type": "number"}, {"type": "string"}
STATE_FIELDS: dict[str, dict[str, tuple[dict[str, str], str]]] = {
    "fk": {
        "status": (_STR, "ok, or why the step failed"),
        "closure_residual": (_NUM, "norm of the loop-closure residual [m | rad]"),
        "singularity": (_STR, "singularity class of the step (none, actuator, end effector)"),
        "cond_constraint": (_NUM, "condition number of the constraint Jacobian (-1: rank lost)"),
        "cond_reduced": (_NUM, "condition number of the reduced Jacobian (-1: rank lost)"),
    },
    "ik": {
        "status": (_STR, "ok, or why the target failed"),
        "closure_residual": (_NUM, "norm of the loop-closure residual [m | rad]"),
        "target": (_STR, "target name"),
        "position_error": (_NUM, "end-effector position error [m]"),
        "orientation_error": (_NUM, "end-effector orientation error [rad]"),
    },
}


def state_schema(task: str) -> dict[str, Any]:
    """The fixed JSON schema of ``/mechkin/state`` for ``task`` (fk, ik): every field one
    explicit type, never ``null`` (no type inferred from the values)."""
    fields = STATE_FIELDS[task]
    return {"type": "object", "title": f"mechkin.{task}.State",
            "properties": {k: {**t, "description": d} for k, (t, d) in fields.items()},
            "required": ["status", "closure_residual"]}


def motion_layout(rec: MotionRecord) -> dict[str, Any]:
    """Foxglove layout of ``<task>.mcap``: 3D, joint positions, the key residuals."""
    key = [(state_path("closure_residual"), "closure residual [m | rad]")]
    if rec.task == "ik":
        key.append((state_path("position_error"), "position error [m]"))
    return layout(rec.world_frame or rec.frame_root or "world", list(rec.joint_names),
                  [(f"{rec.task}: residuals [m | rad]", key)], motors=rec.motors,
                  robot=rec.robot is not None, title=f"{rec.title} ({rec.mechanism})")


def frame_tree_of(rec: MotionRecord) -> tuple[str | None, list[str], list[str], Any]:
    """The /tf tree of a record: as recorded, or, with a moving base (``rec.world_frame``),
    rooted at the world frame with the base pose T_0(t) as the world -> base transform
    (kim1995 §5.1 Step 1)."""
    if rec.world_frame is None or rec.T_world_base is None or rec.frame_root is None:
        return rec.frame_root, rec.frame_names, rec.frame_parents, rec.T_parent_child
    T = np.asarray(rec.T_world_base, float)[:, None]
    T_pc = (T if rec.T_parent_child is None or not len(rec.frame_names)
            else np.concatenate([T, rec.T_parent_child], axis=1))
    return (rec.world_frame, [rec.frame_root, *rec.frame_names],
            [rec.world_frame, *rec.frame_parents], T_pc)


def robot_text(robot: Any) -> str | None:
    """The URDF of a record's robot model (None without one)."""
    if robot is None:
        return None
    from mechkin.io.urdf_out import robot_urdf

    return robot_urdf(robot)


def motion_log(rec: MotionRecord, effort: np.ndarray | None = None) -> MotionLog:
    from mechkin.io.mcap_out import MotionLog

    times = rec.times
    root, names, parents, T_pc = frame_tree_of(rec)
    T_t = _finite_targets(rec)
    if T_t is not None and root is not None:  # the current target as a /tf frame
        name = TARGET_FRAME
        while name in names or name == root:
            name += "_"
        names, parents = [*names, name], [*parents, root]
        T_pc = np.concatenate([T_pc, T_t[:, None]], axis=1)
    return MotionLog(
        times=times - min(0.0, float(times[0])), root_frame=root,
        frame_names=names, frame_parents=parents,
        T_parent_child=T_pc, joint_names=list(rec.joint_names), q=rec.q, qd=rec.qd,
        effort=effort, scene=motion_scene(rec), state=rec.state,
        state_schema=state_schema(rec.task) if rec.task in STATE_FIELDS else None,
        metadata=rec.metadata, robot_description=robot_text(rec.robot),
    )


def write(od: OutputDir, report: Report, plots: bool) -> None:
    rec: MotionRecord = report.data
    outs = report.outputs
    if outs.csv:  # the table: <task>.csv, or .npz / .parquet (outputs.table)
        write_table(od, rec.task, rec.columns, getattr(outs, "table", rec.table))
    if plots and outs.plots:
        write_plots(od, rec)
    if outs.mcap:
        from mechkin.io.mcap_out import write_mcap

        write_mcap(od.path_for(f"{rec.task}.mcap"), motion_log(rec))
        od.write_json(f"{rec.task}.layout.json", motion_layout(rec))


MAX_STICK_PANELS = 6  # stick.png panels at most (each 3-D panel costs about 0.1 s)
PLATE_COLORS = ("tab:orange", "tab:olive", "tab:purple", "tab:cyan", "tab:pink", "tab:brown")


def _ee_poses(cols: dict[str, Any]) -> np.ndarray | None:
    """End-effector poses (m, 4, 4) from the CSV columns (``ee_x_m`` ... ``ee_qz``)."""
    keys = ("ee_x_m", "ee_y_m", "ee_z_m", "ee_qw", "ee_qx", "ee_qy", "ee_qz")
    if not all(k in cols for k in keys):
        return None
    from mechkin.spatial.rotations import matrix_from_quat

    x, y, z, *e = (np.asarray(cols[k], dtype=float) for k in keys)
    T = np.broadcast_to(np.eye(4), (len(x), 4, 4)).copy()
    T[:, :3, :3] = matrix_from_quat(np.stack(e, axis=-1))
    T[:, :3, 3] = np.stack([x, y, z], axis=-1)
    return T


def stick_items(rec: MotionRecord, k: int, T_E: np.ndarray | None) -> list[Any]:
    """What ``stick.png`` draws for configuration ``k``: the plates (filled), the links joint
    to joint (one colour, joints as dots), the end-effector frame as a triad."""
    from mechkin.io.plots import Plate, Stick, Triad

    items: list[Any] = [Plate(p[k], color=PLATE_COLORS[i % len(PLATE_COLORS)], label=name)
                        for i, (name, p) in enumerate(rec.plates.items())]
    seg = rec.segments
    if seg is not None:
        items += [Stick(s, color="0.15", label="links" if j == 0 else "")
                  for j, s in enumerate(seg[k])]
    if T_E is not None and np.isfinite(T_E[k]).all():
        items.append(Triad(T_E[k], label="end effector (x, y, z)"))
    return items


def stick_snapshots(rec: MotionRecord) -> list[int]:
    """The configurations drawn: ``rec.snapshots``, thinned evenly to ``MAX_STICK_PANELS``."""
    snaps = list(rec.snapshots)
    if len(snaps) <= MAX_STICK_PANELS:
        return snaps
    pick = np.linspace(0, len(snaps) - 1, MAX_STICK_PANELS).round().astype(int)
    return [snaps[i] for i in pick]


def write_plots(od: OutputDir, rec: MotionRecord) -> None:
    """``joints.png`` (over time for fk, per target for ik), ``stick.png``, ``convergence.png``."""
    from mechkin.io.plots import (
        plot_by_target,
        plot_convergence,
        plot_series,
        plot_stick_3d,
    )

    n = len(rec.joint_names)
    labels = [f"{nm} [{u}]" for nm, u in zip(rec.joint_names, rec.joint_units, strict=True)]
    if rec.task == "ik":
        cols = rec.columns
        names = [str(v) for v in cols.get("target", [f"#{k}" for k in range(len(rec.times))])]
        errors = {k: np.asarray(cols[c], float) for k, c in
                  (("position error [m]", "position_error_m"),
                   ("orientation error [rad]", "orientation_error_rad")) if c in cols}
        plot_by_target(od.path_for("joints.png"), names, rec.q, labels if n <= 12 else
                       [""] * n, "q [rad | m]", f"{rec.title}: joint values per target",
                       errors=errors)
    else:
        plot_series(od.path_for("joints.png"), rec.times, rec.q,
                    labels if n <= 12 else [""] * n,
                    "t [s]", "q [rad | m]", f"{rec.title}: joint trajectories")
    if rec.segments is not None and rec.snapshots:
        snaps = stick_snapshots(rec)
        T_E = _ee_poses(rec.columns)
        label_of = dict(zip(rec.snapshots, rec.snapshot_labels, strict=False))
        items = [stick_items(rec, k, T_E) for k in snaps]
        markers = None
        if rec.targets is not None:  # positions (m, 3) as crosses; poses (m, 4, 4) also triads
            tg = np.asarray(rec.targets, dtype=float)
            markers = [tg[k][:3, 3] if tg.ndim == 3 else tg[k] for k in snaps]
            if tg.ndim == 3:
                from mechkin.io.plots import Triad

                for row, k in zip(items, snaps, strict=True):
                    row.append(Triad(tg[k], label="target frame", style="--"))
        plot_stick_3d(od.path_for("stick.png"), items,
                      f"{rec.title} ({rec.mechanism})",
                      labels=[label_of.get(k, f"#{k}") for k in snaps], markers=markers)
    if rec.convergence:
        plot_convergence(od.path_for("convergence.png"), rec.convergence,
                         rec.convergence_ylabel, title=rec.convergence_title)

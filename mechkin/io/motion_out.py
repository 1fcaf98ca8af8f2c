"""The files of a motion record (fk steps, ik targets): ``<task>.csv``, ``joints.png``,
``stick.png``, ``convergence.png`` (ik) and ``<task>.mcap``.

Imports: records (types), io.mcap_out, io.plots (lazily).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.io.mcap_out import Lines, MotionLog, Scene, Spheres, write_mcap
from mechkin.io.output_dir import OutputDir
from mechkin.records import MotionRecord, Report


def motion_scene(rec: MotionRecord) -> Scene:
    """/scene of a motion: the stick segments as lines and the joint-axis points as spheres."""
    seg = rec.segments
    m = seg.shape[0]
    size = float(np.ptp(seg.reshape(-1, 3), axis=0).max()) if seg.size else 1.0
    size = size if size > 0 else 1.0
    return Scene(
        lines=(Lines(seg.reshape(m, -1, 3), kind="list", thickness=0.01 * size,
                     rgba=(0.2, 0.5, 0.9, 1.0)),) if seg.shape[1] else (),
        spheres=(Spheres(rec.axis_points, radius=0.015 * size),),
    )


def motion_log(rec: MotionRecord, effort: np.ndarray | None = None) -> MotionLog:
    times = rec.times
    return MotionLog(
        times=times - min(0.0, float(times[0])), root_frame=rec.frame_root,
        frame_names=rec.frame_names, frame_parents=rec.frame_parents,
        T_parent_child=rec.T_parent_child, joint_names=list(rec.joint_names), q=rec.q, qd=rec.qd,
        effort=effort, scene=motion_scene(rec), state=rec.state, metadata=rec.metadata,
    )


def write(od: OutputDir, report: Report, plots: bool) -> None:
    rec: MotionRecord = report.data
    outs = report.outputs
    if outs.csv:
        od.write_csv(f"{rec.task}.csv", rec.columns)
    if plots and outs.plots:
        from mechkin.io.plots import plot_convergence, plot_series, plot_stick_3d

        n = len(rec.joint_names)
        plot_series(od.path_for("joints.png"), rec.times, rec.q,
                    [f"{nm} [{u}]" for nm, u in zip(rec.joint_names, rec.joint_units,
                                                    strict=True)]
                    if n <= 12 else [""] * n,
                    "t [s]", "q [rad | m]", f"{rec.title}: joint trajectories")
        seg = rec.segments
        snaps: list[Any] = [[s for s in seg[k]] for k in rec.snapshots]
        plot_stick_3d(od.path_for("stick.png"), snaps, f"{rec.title} ({rec.mechanism})",
                      labels=rec.snapshot_labels)
        if rec.convergence:
            plot_convergence(od.path_for("convergence.png"), rec.convergence,
                             rec.convergence_ylabel, title=rec.convergence_title)
    if outs.mcap:
        write_mcap(od.path_for(f"{rec.task}.mcap"), motion_log(rec))

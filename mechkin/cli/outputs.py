"""Motion outputs shared by fk and ik: CSV, plots, MCAP and summary.json, staged atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.io import Lines, MotionLog, OutputDir, Scene, Spheres, write_mcap
from mechkin.model import Mechanism
from mechkin.model.drawing import frame_tree, skeleton_segments
from mechkin.model.kinematics import Kinematics
from mechkin.spatial.rotations import quat_from_matrix


def joint_columns(mech: Mechanism, q: np.ndarray) -> dict[str, np.ndarray]:
    """CSV columns ``<joint>_rad`` / ``<joint>_m`` for q (m, n)."""
    return {f"{name}_{mech.joint_unit(j)}": q[:, j] for j, name in enumerate(mech.joint_names)}


def pose_columns(T: np.ndarray, prefix: str = "ee_") -> dict[str, np.ndarray]:
    """CSV columns of poses (m, 4, 4): xyz [m] and quaternion (w, x, y, z)."""
    e = quat_from_matrix(T[:, :3, :3])
    return {
        f"{prefix}x_m": T[:, 0, 3], f"{prefix}y_m": T[:, 1, 3], f"{prefix}z_m": T[:, 2, 3],
        f"{prefix}qw": e[:, 0], f"{prefix}qx": e[:, 1], f"{prefix}qy": e[:, 2],
        f"{prefix}qz": e[:, 3],
    }


def mechanism_scene(mech: Mechanism, kin: Kinematics) -> Scene:
    seg = skeleton_segments(mech, kin)
    m = seg.shape[0]
    size = float(np.ptp(seg.reshape(-1, 3), axis=0).max()) if seg.size else 1.0
    size = size if size > 0 else 1.0
    return Scene(
        lines=(Lines(seg.reshape(m, -1, 3), kind="list", thickness=0.01 * size,
                     rgba=(0.2, 0.5, 0.9, 1.0)),) if seg.shape[1] else (),
        spheres=(Spheres(kin.axes()[1], radius=0.015 * size),),
    )


def motion_log(
    mech: Mechanism, kin: Kinematics, times: np.ndarray, state: list[dict[str, Any]],
    metadata: dict[str, str], effort: np.ndarray | None = None,
) -> MotionLog:
    root, names, parents, T_pc = frame_tree(mech, kin)
    return MotionLog(
        times=times - min(0.0, float(times[0])), root_frame=root, frame_names=names,
        frame_parents=parents, T_parent_child=T_pc, joint_names=list(mech.joint_names),
        q=kin.q, effort=effort, scene=mechanism_scene(mech, kin), state=state,
        metadata=metadata,
    )


def snapshot_indices(m: int, k: int) -> list[int]:
    return sorted(set(np.linspace(0, m - 1, min(k, m)).round().astype(int).tolist()))


def write_motion_outputs(
    *,
    scenario: Scenario,
    mech: Mechanism,
    kin: Kinematics,
    times: np.ndarray,
    out_dir: Path,
    summary: dict[str, Any],
    step_status: list[str],
    residual: np.ndarray,
    plots: bool,
    task: str,
    extra_columns: dict[str, Any] | None = None,
    extra_state: list[dict[str, Any]] | None = None,
    snapshots: list[int] | None = None,
    snapshot_labels: list[str] | None = None,
    extra_plots: Any = None,
) -> dict[str, Any]:
    """Write ``<task>.csv``, ``joints.png``, ``stick.png``, ``<task>.mcap`` and summary.json."""
    outs = scenario.spec.outputs
    m = len(times)
    summary = dict(summary)
    summary["out_dir"] = str(out_dir)
    with OutputDir(out_dir) as od:
        if outs.csv:
            cols: dict[str, Any] = {"t_s": times}
            cols.update(joint_columns(mech, kin.q))
            if mech.end_effector is not None:
                cols.update(pose_columns(kin.frames(mech, [mech.end_effector])[:, 0]))
            cols["closure_residual"] = residual
            cols.update(extra_columns or {})
            cols["status"] = step_status
            od.write_csv(f"{task}.csv", cols)
        if plots and outs.plots:
            from mechkin.io.plots import plot_series, plot_stick_3d

            ylabel = "q [rad | m]"
            plot_series(od.path_for("joints.png"), times, kin.q,
                        [f"{n} [{mech.joint_unit(j)}]" for j, n in enumerate(mech.joint_names)]
                        if mech.n <= 12 else [""] * mech.n,
                        "t [s]", ylabel, f"{scenario.name}: joint trajectories")
            seg = skeleton_segments(mech, kin)
            idx = snapshots if snapshots is not None else snapshot_indices(
                m, getattr(scenario.section, "snapshots", 4))
            snaps = [[s for s in seg[k]] for k in idx]
            labels = snapshot_labels or [f"t = {times[k]:.3g} s" for k in idx]
            plot_stick_3d(od.path_for("stick.png"), snaps, f"{scenario.name} ({mech.name})",
                          labels=labels)
            if extra_plots is not None:
                extra_plots(od)
        if outs.mcap:
            state = []
            for k in range(m):
                st: dict[str, Any] = {"status": step_status[k],
                                      "closure_residual": float(residual[k])}
                if extra_state is not None:
                    st.update(extra_state[k])
                state.append(st)
            write_mcap(od.path_for(f"{task}.mcap"), motion_log(
                mech, kin, times, state,
                {"scenario": scenario.name, "mechanism": mech.name, "task": task}))
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary

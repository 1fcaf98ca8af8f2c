"""The files of a track run (park §2-§5): ``track.csv``, plots like park Figs. 4-8
(``phase.png``, ``hand_part.png``, ``joint_velocities.png``, ``joint_accelerations.png``,
``joint_jerks.png``, ``torques.png``), ``track.mcap`` (the arm following the part) and its
Foxglove layout ``track.layout.json`` (3D, joint positions, torques against their limits and
the tracking error). ``/mechkin/state`` has a fixed JSON schema (:func:`state_schema`); the
torque limits are in it as ``torque_max_<joint>`` / ``torque_min_<joint>`` so a plot shows
them beside the ``/joint_states`` efforts.

An infeasible plan has no record (``report.data is None``): only summary.json is written.

Imports: records (types), io.atomic, io.mcap_out, io.foxglove_layout, matplotlib (lazily).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mechkin.io.output_dir import OutputDir
from mechkin.records import Report
from mechkin.records.track import TrackRecord, TrackTrajectory


def write(od: OutputDir, report: Report, plots: bool) -> None:
    rec: TrackRecord | None = report.data
    if rec is None:
        return
    outs = report.outputs
    if outs.csv:
        od.write_csv("track.csv", csv_columns(rec))
    if plots and outs.plots:
        _plots(od, rec)
    if outs.mcap:
        _write_mcap(od, rec)
        od.write_json("track.layout.json", track_layout(rec))


# ---- state schema and Foxglove layout ---------------------------------------------------------


def _torque_limits(rec: TrackRecord) -> list[tuple[str, float, float]]:
    """(joint, lower, upper) of the joints with a finite torque limit [N m | N]."""
    lim = rec.limits.get("torque")
    if lim is None:
        return []
    return [(j, float(lim[0][k]), float(lim[1][k])) for k, j in enumerate(rec.joint_names)
            if np.isfinite(lim[0][k]) and np.isfinite(lim[1][k])]


def state_schema(rec: TrackRecord) -> dict[str, Any]:
    """The fixed JSON schema of track's ``/mechkin/state``: every field one explicit type."""
    num = {"type": "number"}
    props: dict[str, Any] = {
        "r": {**num, "description": "path parameter r [-] (park Eq. (1))"},
        "rd_1_s": {**num, "description": "r' [1/s]"},
        "rdd_1_s2": {**num, "description": "r'' [1/s^2]"},
        "phase": {"type": "string", "enum": ["waiting", "transient", "tracking", "moving"],
                  "description": "waiting for the part, transient, tracking, or moving"},
    }
    if rec.trajectory.tracking_error is not None:
        props["tracking_error_m"] = {**num, "description": "|hand - part| [m]"}
        for a in "xyz":
            props[f"tracking_error_{a}_m"] = {**num, "description": f"hand - part, {a} [m]"}
    for j, _, _ in _torque_limits(rec):
        props[f"torque_min_{j}"] = {**num, "description": f"lower torque limit of {j} [N m | N]"}
        props[f"torque_max_{j}"] = {**num, "description": f"upper torque limit of {j} [N m | N]"}
    return {"type": "object", "title": "mechkin.track.State", "properties": props,
            "required": ["r", "rd_1_s", "rdd_1_s2", "phase"]}


def track_layout(rec: TrackRecord) -> dict[str, Any]:
    """Foxglove layout of ``track.mcap``: 3D, joint positions, torques vs limits, error."""
    from mechkin.io.foxglove_layout import joint_path, layout, state_path

    key = [(joint_path(j, "effort"), f"u {j}") for j in rec.joint_names[:6]]
    for j, _, _ in _torque_limits(rec)[:6]:
        key += [(state_path(f"torque_max_{j}"), f"max {j}"),
                (state_path(f"torque_min_{j}"), f"min {j}")]
    err = ([(state_path("tracking_error_m"), "|hand - part| [m]")]
           if rec.trajectory.tracking_error is not None else [])
    return layout(rec.frame_root, list(rec.joint_names),
                  [("torques [N m | N] vs limits", key), ("tracking error [m]", err)])


# ---- CSV --------------------------------------------------------------------------------------


def _filled(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """NaN -> 0 and a per-row flag (1 where every joint's value is defined)."""
    defined = np.all(np.isfinite(a), axis=1)
    return np.where(np.isfinite(a), a, 0.0), defined.astype(int)


def csv_columns(rec: TrackRecord) -> dict[str, Any]:
    """``track.csv``: the trajectory's columns, undefined differences as 0 with their flags,
    and the tracking error's norm."""
    traj = rec.trajectory
    cols: dict[str, Any] = {}
    qdd_f, qdd_ok = _filled(traj.qdd)
    jerk_f, jerk_ok = _filled(traj.jerk)
    filled = TrackTrajectory(traj.t, traj.r, traj.rd, traj.rdd, traj.q, traj.qd, qdd_f, jerk_f,
                             traj.torque, traj.hand, traj.part, traj.tracking_error)
    for k, v in filled.columns(rec.prismatic).items():
        cols[k] = v
    cols["qdd_defined"] = qdd_ok
    cols["jerk_defined"] = jerk_ok
    if traj.tracking_error is not None:
        cols["error_norm_m"] = np.linalg.norm(traj.tracking_error, axis=1)
    return cols


# ---- MCAP -------------------------------------------------------------------------------------


def _phase_labels(traj: TrackTrajectory, t_a: float | None) -> list[str]:
    out = []
    for k in range(traj.t.shape[0]):
        if traj.rd[k] == 0.0 and traj.r[k] == 0.0 and (k + 1 < len(traj.t)
                                                         and traj.r[k + 1] == 0.0):
            out.append("waiting")
        elif t_a is not None and traj.t[k] >= t_a - 1e-12:
            out.append("tracking")
        else:
            out.append("transient" if t_a is not None else "moving")
    return out


def _belt_frame(v: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) with x along the belt velocity and z as close to base z as possible."""
    x = v / np.linalg.norm(v)
    z0 = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(z0, x)
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def _write_mcap(od: OutputDir, rec: TrackRecord) -> None:
    from mechkin.io.mcap_out import Box, Lines, MotionLog, Scene, Spheres, write_mcap

    traj = rec.trajectory
    seg = rec.segments
    m = seg.shape[0]
    size = max(float(np.ptp(seg.reshape(-1, 3), axis=0).max()), 1e-3)
    lines = [Lines(seg.reshape(m, -1, 3), kind="list", thickness=0.01 * size,
                   rgba=(0.2, 0.5, 0.9, 1.0)),
             Lines(rec.ends, kind="strip", thickness=0.004 * size,
                   rgba=(0.95, 0.85, 0.2, 1.0))]
    boxes = []
    state: list[dict[str, Any]] = []
    phases = _phase_labels(traj, rec.t_a_s)
    if rec.belt_velocity is not None and traj.part is not None and rec.part_size is not None:
        psize = rec.part_size
        R = _belt_frame(rec.belt_velocity)
        Tp = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
        Tp[:, :3, :3] = R
        Tp[:, :3, 3] = traj.part - R[:, 2] * (0.5 * psize[2])  # part top at the hand height
        boxes.append(Box(Tp, psize, rgba=(0.9, 0.3, 0.2, 0.9)))
        x_lo = float(np.min(traj.part @ R[:, 0])) - psize[0]
        x_hi = float(np.max(traj.part @ R[:, 0])) + psize[0]
        Tb = np.eye(4)
        Tb[:3, :3] = R
        mid = traj.part[0] + R[:, 0] * (0.5 * (x_lo + x_hi) - float(traj.part[0] @ R[:, 0]))
        Tb[:3, 3] = mid - R[:, 2] * (psize[2] + 0.01)
        boxes.append(Box(Tb, np.array([x_hi - x_lo, 2.0 * psize[1], 0.02]),
                         rgba=(0.35, 0.35, 0.35, 0.8)))
    for k in range(m):
        st: dict[str, Any] = {"r": float(traj.r[k]), "rd_1_s": float(traj.rd[k]),
                              "rdd_1_s2": float(traj.rdd[k]), "phase": phases[k]}
        if traj.tracking_error is not None:
            e = traj.tracking_error[k]
            st["tracking_error_m"] = float(np.linalg.norm(e))
            st.update({f"tracking_error_{a}_m": float(e[i]) for i, a in enumerate("xyz")})
        for j, lo, hi in _torque_limits(rec):
            st[f"torque_min_{j}"], st[f"torque_max_{j}"] = lo, hi
        state.append(st)
    qdd_f, _ = _filled(traj.qdd)
    log = MotionLog(
        times=traj.t, root_frame=rec.frame_root, frame_names=rec.frame_names,
        frame_parents=rec.frame_parents, T_parent_child=rec.T_parent_child,
        joint_names=list(rec.joint_names), q=traj.q, qd=traj.qd, qdd=qdd_f, effort=traj.torque,
        scene=Scene(lines=tuple(lines), spheres=(Spheres(rec.axis_points, radius=0.015 * size),),
                    boxes=tuple(boxes), entity_id="track"),
        state=state, state_schema=state_schema(rec),
        metadata=dict(rec.metadata),
    )
    write_mcap(od.path_for("track.mcap"), log)


# ---- plots (park Figs. 4-8) -------------------------------------------------------------------


def _panels(path: Path, t: np.ndarray, ys: np.ndarray, labels: list[str], ylabel: str,
            title: str, limits: tuple[np.ndarray, np.ndarray] | None,
            steps: bool = False) -> None:
    """One panel per column of ys against t, with that joint's limits dashed; ``steps`` draws
    values that hold over the transition leaving each node (torque, Eq. (32)-(33) differences)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = ys.shape[1]
    fig = Figure(figsize=(7.0, 2.4 * n + 0.6), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for k, ax in enumerate(axes):
        ax.plot(t, ys[:, k], marker=".", markersize=3, linewidth=1.4, label=labels[k],
                drawstyle="steps-post" if steps else "default")
        if limits is not None:
            for v in (limits[0][k], limits[1][k]):
                if np.isfinite(v):
                    ax.axhline(float(v), color="0.4", linestyle="--", linewidth=1.0)
        ax.set_ylabel(f"{labels[k]} [{ylabel}]")
        ax.grid(True, alpha=0.3)
    axes[0].set_title(title)
    axes[-1].set_xlabel("t [s]")
    fig.savefig(path, dpi=110, format="png")


def _plots(od: OutputDir, rec: TrackRecord) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    traj = rec.trajectory
    name = rec.title
    N1, N2 = rec.grid
    # park Fig. 4 / 5: phase plane with the part's reference, and r(t) against the part's r~(t)
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    for other in rec.study:
        ax1.plot(other.r, other.rd, linewidth=1.0, alpha=0.7, label=f"{other.N1}x{other.N2}")
    ax1.plot(traj.r, traj.rd, "k.-", linewidth=1.6, markersize=3, label=f"DP {N1}x{N2}")
    if rec.phase_ref is not None:
        r0, rd = rec.phase_ref
        ax1.axhline(rd, color="tab:red", linestyle="--", label="part x~2 = r~'")
        tt = np.linspace(0.0, float(traj.t[-1]), 200)
        ax2.plot(tt, r0 + rd * tt, color="tab:red", linestyle="--", label="part r~(t)")
    if rec.t_a_s is not None:
        ax2.axvline(rec.t_a_s, color="0.5", linestyle=":", label=f"t_a = {rec.t_a_s:.4g} s")
    ax2.plot(traj.t, traj.r, "k.-", markersize=3, label="hand r(t)")
    ax1.set(xlabel="r = x1 [-]", ylabel="r' = x2 [1/s]", title=f"{name}: phase plane")
    ax2.set(xlabel="t [s]", ylabel="r [-]", title="path parameter", ylim=(-0.6, 1.1))
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    fig.savefig(od.path_for("phase.png"), dpi=110, format="png")
    # park Fig. 5/6: hand vs part positions and the tracking error
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for i, a in enumerate("xyz"):
        if np.ptp(traj.hand[:, i]) > 1e-12 or (traj.part is not None
                                               and np.ptp(traj.part[:, i]) > 1e-12):
            ax1.plot(traj.t, traj.hand[:, i], ".-", markersize=3, label=f"hand {a}")
            if traj.part is not None:
                ax1.plot(traj.t, traj.part[:, i], "--", label=f"part {a}")
    ax1.set(ylabel="position [m]", title=f"{name}: hand and part")
    if traj.tracking_error is not None:
        ax2.plot(traj.t, np.linalg.norm(traj.tracking_error, axis=1), ".-", markersize=3,
                 label="|hand - part|")
    ax2.set(xlabel="t [s]", ylabel="tracking error [m]")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    fig.savefig(od.path_for("hand_part.png"), dpi=110, format="png")
    # park Figs. 6-8: joint velocities, accelerations and jerks, torques, with their limits
    units = ["m" if p else "rad" for p in rec.prismatic]
    jn = list(rec.joint_names)
    lim = rec.limits
    _panels(od.path_for("joint_velocities.png"), traj.t, traj.qd, jn,
            f"{units[0]}/s", f"{name}: joint velocities", lim.get("qd"))
    qdd = np.where(np.isfinite(traj.qdd), traj.qdd, np.nan)
    _panels(od.path_for("joint_accelerations.png"), traj.t, qdd, jn,
            f"{units[0]}/s^2", f"{name}: joint accelerations (Eq. 32)", lim.get("qdd"), steps=True)
    _panels(od.path_for("joint_jerks.png"), traj.t, traj.jerk, jn,
            f"{units[0]}/s^3", f"{name}: joint jerks (Eq. 33)", lim.get("jerk"), steps=True)
    _panels(od.path_for("torques.png"), traj.t, traj.torque, [f"u{j + 1} ({n})"
                                                              for j, n in enumerate(jn)],
            "N m", f"{name}: joint torques", lim.get("torque"), steps=True)

"""The files of a track run (park §2-§5): ``track.csv``, plots like park Figs. 4-8
(``phase.png`` with the limit curve, ``hand_part.png``, ``joint_positions.png``,
``joint_velocities.png``, ``joint_accelerations.png``, ``joint_jerks.png``, ``torques.png``, each
against its limits), ``path_3d.png`` (the hand path in 3-D with hand-frame triads and the arm),
with ``track.cases`` the overlays of park Figs. 5-8 (``cases_phase.png``, ``cases_hand.png``,
``cases_joint_velocities.png``, ``cases_torques.png``: every case on the same axes, legend by
case name), ``track.mcap`` (the arm following the part on the moving belt) and its Foxglove
layout ``track.layout.json`` (3D, joint positions, torques against their limits and the
tracking error). :func:`figures` builds every figure (constrained layout, fixed legend places:
``loc="best"`` searches every point at each draw) without drawing it. ``/mechkin/state`` has
a fixed JSON schema (:func:`state_schema`); the
torque limits are in it as ``torque_max_<joint>`` / ``torque_min_<joint>`` so a plot shows
them beside the ``/joint_states`` efforts.

An infeasible plan has no record (``report.data is None``): only summary.json is written.

Imports: records (types), io.atomic, io.mcap_out, io.foxglove_layout, matplotlib (lazily).
"""

from __future__ import annotations

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
        od.write_table("track", csv_columns(rec))
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

    motors = set(rec.joint_names if rec.motors is None else rec.motors)
    # the motors' torques (up to 6) on; the passive joints' (zero) torques listed but off
    shown = [j for j in rec.joint_names if j in motors][:6]
    passive = [j for j in rec.joint_names if j not in motors][:max(0, 12 - 3 * len(shown))]
    key: list[Any] = [(joint_path(j, "effort"), f"u {j}") for j in shown]
    key += [(joint_path(j, "effort"), f"u {j} (passive)", False) for j in passive]
    for j, _, _ in [lim for lim in _torque_limits(rec) if lim[0] in shown]:
        key += [(state_path(f"torque_max_{j}"), f"max {j}"),
                (state_path(f"torque_min_{j}"), f"min {j}")]
    err = ([(state_path("tracking_error_m"), "|hand - part| [m]")]
           if rec.trajectory.tracking_error is not None else [])
    return layout(rec.frame_root, list(rec.joint_names),
                  [("torques [N m | N] vs limits", key), ("tracking error [m]", err)],
                  motors=rec.motors, robot=rec.robot is not None,
                  title=f"{rec.title} ({rec.mechanism})")


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


#: Stripes drawn across the belt so that its motion shows in the 3D panel.
BELT_STRIPES = 8


def _belt_stripes(t: np.ndarray, v: np.ndarray, R: np.ndarray, centre: np.ndarray,
                  x_lo: float, x_hi: float, psize: np.ndarray, x0: float) -> np.ndarray:
    """Segments ``(m, 2 BELT_STRIPES, 3)`` across the belt's top that move with the belt
    (``|V_b| t`` along it, wrapped to the belt's length): the belt animates like the part."""
    length = x_hi - x_lo
    gap = length / BELT_STRIPES
    shift = np.mod(float(np.linalg.norm(v)) * t[:, None] + np.arange(BELT_STRIPES) * gap, length)
    along = (x_lo + shift) - x0  # (m, s) from the part's start along the belt
    top = centre + R[:, 2] * 0.0101 - R[:, 0] * float(centre @ R[:, 0] - x0)
    base = top[None, None, :] + along[..., None] * R[:, 0]
    half = R[:, 1] * psize[1]
    seg = np.stack([base - half, base + half], axis=2)  # (m, s, 2, 3)
    return seg.reshape(t.shape[0], -1, 3)


def _write_mcap(od: OutputDir, rec: TrackRecord) -> None:
    from mechkin.io.mcap_out import Box, Lines, MotionLog, Scene, Spheres, write_mcap
    from mechkin.io.motion_out import robot_text

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
        lines.append(Lines(_belt_stripes(traj.t, rec.belt_velocity, R, Tb[:3, 3], x_lo, x_hi,
                                         psize, float(traj.part[0] @ R[:, 0])),
                           kind="list", thickness=0.003 * size, rgba=(0.9, 0.9, 0.9, 1.0)))
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
        metadata=dict(rec.metadata), robot_description=robot_text(rec.robot),
    )
    write_mcap(od.path_for("track.mcap"), log)


# ---- plots (park Figs. 4-8) -------------------------------------------------------------------

#: Triads drawn along the path in ``path_3d.png``.
N_TRIADS = 5
#: Line styles of the cases in the overlay figures (with one colour each).
_CASE_STYLES = ("-", "--", "-.", ":")


def _new_figure(figsize: tuple[float, float]) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _panels(t: np.ndarray, ys: np.ndarray, labels: list[str], ylabel: list[str] | str,
            title: str, limits: tuple[np.ndarray, np.ndarray] | None,
            steps: bool = False) -> Any:
    """One panel per column of ys against t, with that joint's limits dashed; ``steps`` draws
    values that hold over the transition leaving each node (torque, Eq. (32)-(33) differences)."""
    from matplotlib.ticker import MaxNLocator

    n = ys.shape[1]
    units = [ylabel] * n if isinstance(ylabel, str) else ylabel
    fig = _new_figure((7.0, (2.0 if n <= 3 else 1.6) * n + 0.8))  # area = drawing time
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for k, ax in enumerate(axes):
        ax.plot(t, ys[:, k], linewidth=1.4, label=labels[k],
                drawstyle="steps-post" if steps else "default")
        if limits is not None:
            drawn = False
            for v in (limits[0][k], limits[1][k]):
                if np.isfinite(v):
                    ax.axhline(float(v), color="0.4", linestyle="--", linewidth=1.0,
                               label=None if drawn else "limit")
                    drawn = True
            if drawn:  # a fixed place: "best" costs a search over every point at each draw
                ax.legend(fontsize="x-small", loc="upper right")
        ax.yaxis.set_major_locator(MaxNLocator(4))  # fewer ticks: the layout sizes each one
        ax.set_ylabel(f"{labels[k]} [{units[k]}]")
        ax.grid(True, alpha=0.3)
    axes[0].set_title(title)
    axes[-1].set_xlabel("t [s]")
    return fig


def _torque_labels(jn: list[str]) -> list[str]:
    return [f"u{j + 1} ({n})" for j, n in enumerate(jn)]


def _unit(prismatic: list[bool], rev: str, pri: str) -> list[str]:
    return [pri if p else rev for p in prismatic]


def _finite_curve(x: np.ndarray, y: np.ndarray | None) -> tuple[np.ndarray, np.ndarray] | None:
    if y is None or not np.any(np.isfinite(y)):
        return None
    ok = np.isfinite(y)
    return x[ok], y[ok]


def phase_figure(rec: TrackRecord) -> Any:
    """park Fig. 4 / 5: the phase plane (with the grid study's traces and the limit curve of the
    torque and velocity limits) and r(t) against the part's r~(t)."""
    traj = rec.trajectory
    N1, N2 = rec.grid
    fig = _new_figure((11.0, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    for other in rec.study:
        ax1.plot(other.r, other.rd, linewidth=1.0, alpha=0.7, label=f"{other.N1}x{other.N2}")
    ax1.plot(traj.r, traj.rd, "k.-", linewidth=1.6, markersize=3, label=f"DP {N1}x{N2}")
    curve = _finite_curve(traj.r, traj.rd_limit)
    top = float(np.max(traj.rd)) if traj.rd.size else 1.0
    if curve is not None:
        ax1.plot(curve[0], curve[1], color="tab:purple", linestyle="-.", linewidth=1.2,
                 label="limit curve (torque, velocity)")
        top = max(top, float(np.min(curve[1])))
    if rec.phase_ref is not None:
        r0, rd = rec.phase_ref
        ax1.axhline(rd, color="tab:red", linestyle="--", label="part x~2 = r~'")
        top = max(top, rd)
        tt = np.linspace(0.0, float(traj.t[-1]), 200)
        ax2.plot(tt, r0 + rd * tt, color="tab:red", linestyle="--", label="part r~(t)")
    ax1.set_ylim(0.0, 1.6 * top)  # a limit curve far above the plan is clipped, not squashed
    if rec.t_a_s is not None:
        ax2.axvline(rec.t_a_s, color="0.5", linestyle=":", label=f"t_a = {rec.t_a_s:.4g} s")
    ax2.plot(traj.t, traj.r, "k.-", markersize=3, label="hand r(t)")
    lo = min(-0.05, float(np.min(traj.r)) - 0.05)
    if rec.phase_ref is not None:
        lo = min(lo, rec.phase_ref[0] - 0.05)
    ax1.set(xlabel="r = x1 [-]", ylabel="r' = x2 [1/s]", title=f"{rec.title}: phase plane")
    ax2.set(xlabel="t [s]", ylabel="r [-]", title="path parameter", ylim=(lo, 1.1))
    for ax, loc in ((ax1, "lower right"), (ax2, "upper left")):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small", loc=loc)
    return fig


def hand_part_figure(rec: TrackRecord) -> Any:
    """park Fig. 5/6: hand and part positions and the tracking error."""
    traj = rec.trajectory
    fig = _new_figure((7.0, 6.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for i, a in enumerate("xyz"):
        if np.ptp(traj.hand[:, i]) > 1e-12 or (traj.part is not None
                                               and np.ptp(traj.part[:, i]) > 1e-12):
            ax1.plot(traj.t, traj.hand[:, i], ".-", markersize=3, label=f"hand {a}")
            if traj.part is not None:
                ax1.plot(traj.t, traj.part[:, i], "--", label=f"part {a}")
    ax1.set(ylabel="position [m]", title=f"{rec.title}: hand and part")
    if traj.tracking_error is not None:
        ax2.plot(traj.t, np.linalg.norm(traj.tracking_error, axis=1), ".-", markersize=3,
                 label="|hand - part|")
    else:
        ax2.plot(traj.t, traj.r, ".-", markersize=3, label="r")
    ax2.set(xlabel="t [s]", ylabel="tracking error [m]" if traj.tracking_error is not None
            else "r [-]")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small", loc="upper right")
    return fig


def path_3d_figure(rec: TrackRecord) -> Any:
    """The hand path in 3-D: the line, the realised hand positions, the hand frame as small
    triads (x red, y green, z blue) at a few samples, the arm at the start, at t_a and at the
    end (stick drawing), and the part's path."""
    traj = rec.trajectory
    fig = _new_figure((7.0, 6.0))
    ax = fig.add_subplot(projection="3d")
    hand = np.zeros((traj.hand.shape[0], 3))
    hand[:, : traj.hand.shape[1]] = traj.hand
    pts = [hand]
    if rec.ends is not None:
        ax.plot(*rec.ends.T, color="0.6", linewidth=3.0, alpha=0.6, label="hand line")
    ax.plot(*hand.T, "k.", markersize=3, label="hand (DP nodes)")
    if traj.part is not None:
        part = np.zeros_like(hand)
        part[:, : traj.part.shape[1]] = traj.part
        ax.plot(*part.T, color="tab:red", linestyle="--", linewidth=1.2, label="part")
        pts.append(part)
    if rec.segments is not None:
        seg = rec.segments
        picks = [(0, "arm at start", "0.35")]
        if rec.t_a_s is not None:
            picks.append((int(np.argmin(np.abs(traj.t - rec.t_a_s))), "arm at t_a",
                          "tab:purple"))
        picks.append((seg.shape[0] - 1, "arm at end", "tab:orange"))
        for k, label, colour in picks:
            s = seg[k]
            xs = np.stack([s[:, 0], s[:, 1], np.full_like(s[:, 0], np.nan)], 1).reshape(-1, 3)
            ax.plot(*xs.T, color=colour, linewidth=1.6, label=label)
            pts.append(s.reshape(-1, 3))
    allp = np.concatenate(pts, axis=0)
    span = float(np.max(np.ptp(allp, axis=0))) or 1.0
    if rec.hand_T is not None:
        L = 0.08 * span
        idx = np.unique(np.linspace(0, rec.hand_T.shape[0] - 1, N_TRIADS).round().astype(int))
        for a, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
            o = rec.hand_T[idx, :3, 3]
            d = rec.hand_T[idx, :3, a] * L
            seg = np.stack([o, o + d, np.full_like(o, np.nan)], 1).reshape(-1, 3)
            ax.plot(*seg.T, color=colour, linewidth=1.8,
                    label=f"hand {'xyz'[a]} ({rec.hand_frame or 'hand'})" if a == 0 else
                    f"hand {'xyz'[a]}")
    mid = 0.5 * (allp.min(axis=0) + allp.max(axis=0))
    half = np.maximum(0.5 * np.ptp(allp, axis=0), 0.15 * span) * 1.1  # equal scale, flat ok
    for setter, c, h in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid, half, strict=True):
        setter(c - h, c + h)
    ax.set_box_aspect(tuple(half / half.max()), zoom=0.9)
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
    ax.set_title(f"{rec.title}: hand path and frames")
    ax.legend(fontsize="x-small", loc="upper left")
    return fig


def _case_axes(fig: Any, n: int) -> Any:
    return fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]


def case_figures(rec: TrackRecord) -> dict[str, Any]:
    """park Figs. 5-8 with every case of ``track.cases`` on the same axes (one colour and line
    style per case, legend by case name): the phase plane with each case's limit curve, the
    hand's position against the part's, the joint velocities and the joint torques with their
    limits."""
    if not rec.cases:
        return {}
    jn = list(rec.joint_names)
    n = len(jn)
    colours = [f"C{k}" for k in range(len(rec.cases))]
    style = {c.name: (colours[k], _CASE_STYLES[k % len(_CASE_STYLES)])
             for k, c in enumerate(rec.cases)}
    out: dict[str, Any] = {}
    # Fig. 5: phase plane
    fig = _new_figure((9.5, 4.8))
    ax = fig.subplots()
    top = max([float(np.max(c.trajectory.rd)) for c in rec.cases]
              + ([rec.phase_ref[1]] if rec.phase_ref is not None else []))
    y_top = 1.5 * top if top > 0 else 1.0
    for c in rec.cases:
        col, ls = style[c.name]
        tr = c.trajectory
        lab = c.name + (f" (t_a = {c.t_a_s:.3g} s)" if c.t_a_s is not None else "")
        ax.plot(tr.r, tr.rd, color=col, linestyle=ls, marker=".", markersize=2.5, label=lab)
        curve = _finite_curve(tr.r, tr.rd_limit)
        if curve is not None:
            low = float(np.min(curve[1]))
            ax.plot(curve[0], curve[1], color=col, linestyle=":", linewidth=1.0, alpha=0.8,
                    label=f"{c.name}: limit curve" + ("" if low < y_top
                                                      else f" (above, >= {low:.3g} /s)"))
    if rec.phase_ref is not None:
        ax.axhline(rec.phase_ref[1], color="tab:red", linestyle="--", linewidth=1.0,
                   label="part x~2 = r~'")
    ax.set_ylim(0.0, y_top)
    ax.set(xlabel="r = x1 [-]", ylabel="r' = x2 [1/s]",
           title=f"{rec.title}: phase plane by case (park Fig. 5)")
    ax.grid(True, alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), fontsize="small", loc="outside right upper")
    out["cases_phase.png"] = fig
    # Fig. 6: hand and part along the line
    fig = _new_figure((9.5, 4.8))
    ax = fig.subplots()
    axis = int(np.argmax(np.ptp(rec.trajectory.hand, axis=0)))
    a = "xyz"[axis]
    for c in rec.cases:
        col, ls = style[c.name]
        tr = c.trajectory
        ax.plot(tr.t, tr.hand[:, axis], color=col, linestyle=ls, label=f"hand {a}: {c.name}")
    part = rec.cases[0].trajectory.part
    if part is not None:
        t_all = np.concatenate([c.trajectory.t for c in rec.cases])
        tt = np.linspace(0.0, float(np.max(t_all)), 100)
        ref = rec.cases[0].trajectory
        slope = (part[-1, axis] - part[0, axis]) / max(ref.t[-1] - ref.t[0], 1e-12)
        ax.plot(tt, part[0, axis] + slope * (tt - ref.t[0]), color="k", linestyle="--",
                linewidth=1.0, label=f"part {a}")
    ax.set(xlabel="t [s]", ylabel=f"{a} [m]",
           title=f"{rec.title}: hand and part by case (park Fig. 6)")
    ax.grid(True, alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), fontsize="small", loc="outside right upper")
    out["cases_hand.png"] = fig
    # Fig. 7 / 8: joint velocities and torques
    for fname, attr, fam, unit, what, steps in (
            ("cases_joint_velocities.png", "qd", "qd", _unit(rec.prismatic, "rad/s", "m/s"),
             "joint velocities (park Fig. 7)", False),
            ("cases_torques.png", "torque", "torque", _unit(rec.prismatic, "N m", "N"),
             "joint torques (park Fig. 8)", True)):
        fig = _new_figure((9.5, (2.2 if n <= 3 else 1.6) * n + 1.0))
        axes = _case_axes(fig, n)
        for k, ax in enumerate(axes):
            for c in rec.cases:
                col, ls = style[c.name]
                tr = c.trajectory
                ax.plot(tr.t, getattr(tr, attr)[:, k], color=col, linestyle=ls, linewidth=1.3,
                        drawstyle="steps-post" if steps else "default", label=c.name)
                lim = c.limits.get(fam)
                if lim is not None:
                    for v in (lim[0][k], lim[1][k]):
                        if np.isfinite(v):
                            ax.axhline(float(v), color=col, linestyle=":", linewidth=0.9)
            ax.set_ylabel(f"{(_torque_labels(jn) if fam == 'torque' else jn)[k]} [{unit[k]}]")
            ax.grid(True, alpha=0.3)
        fig.legend(*axes[0].get_legend_handles_labels(), fontsize="small",
                   title="case (dotted:\nits limits)", title_fontsize="small",
                   loc="outside right upper")
        axes[0].set_title(f"{rec.title}: {what}")
        axes[-1].set_xlabel("t [s]")
        out[fname] = fig
    return out


def figures(rec: TrackRecord) -> dict[str, Any]:
    """Every figure of a track run by file name (constrained layout; nothing is drawn yet). The
    per-joint figures show ``rec.actuated`` (a closed chain's motors) or every joint."""
    traj = rec.trajectory
    cols = list(range(len(rec.joint_names))) if rec.actuated is None else list(rec.actuated)
    jn = [rec.joint_names[j] for j in cols]
    lim = {k: (np.asarray(lo)[cols], np.asarray(hi)[cols]) for k, (lo, hi) in rec.limits.items()}
    pris = [rec.prismatic[j] for j in cols]
    name = rec.title
    out: dict[str, Any] = {"phase.png": phase_figure(rec), "hand_part.png": hand_part_figure(rec)}
    if rec.hand_T is not None or rec.segments is not None:
        out["path_3d.png"] = path_3d_figure(rec)
    out["joint_positions.png"] = _panels(traj.t, traj.q[:, cols], jn, _unit(pris, "rad", "m"),
                                         f"{name}: joint positions (Eq. 9)", lim.get("q"))
    out["joint_velocities.png"] = _panels(traj.t, traj.qd[:, cols], jn,
                                          _unit(pris, "rad/s", "m/s"),
                                          f"{name}: joint velocities", lim.get("qd"))
    out["joint_accelerations.png"] = _panels(
        traj.t, traj.qdd[:, cols], jn, _unit(pris, "rad/s^2", "m/s^2"),
        f"{name}: joint accelerations (Eq. 32)", lim.get("qdd"), steps=True)
    out["joint_jerks.png"] = _panels(traj.t, traj.jerk[:, cols], jn,
                                     _unit(pris, "rad/s^3", "m/s^3"),
                                     f"{name}: joint jerks (Eq. 33)", lim.get("jerk"),
                                     steps=True)
    out["torques.png"] = _panels(traj.t, traj.torque[:, cols], _torque_labels(jn),
                                 _unit(pris, "N m", "N"), f"{name}: joint torques",
                                 lim.get("torque"), steps=True)
    out.update(case_figures(rec))
    return out


def _plots(od: OutputDir, rec: TrackRecord) -> None:
    for fname, fig in figures(rec).items():
        fig.savefig(od.path_for(fname), dpi=110, format="png")

"""``mechkin track SCENARIO.yaml``: conveyor tracking by DP in the phase plane (park §2-§5).

The hand moves on a straight line (park Eq. (7)); the joints follow it by the mechanism's
inverse kinematics (Newton-Raphson on the hand position, continued along the line from the
start solution, on the branch the scenario names); the torques come from the mechanism's
inertial parameters (recursive Newton-Euler, park Eq. (8)); the DP of
:func:`mechkin.solvers.dpct.solve_conveyor_tracking` plans ``r(t)``.

Outputs: ``summary.json``; ``track.csv`` (the realised trajectory at the DP nodes); plots like
park Figs. 4-8 (``phase.png``, ``hand_part.png``, ``joint_velocities.png``,
``joint_accelerations.png``, ``torques.png``); ``track.mcap`` (the arm following the part).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer

from mechkin.cli.common import (
    default_out_dir,
    evaluate_expect,
    handle_errors,
    joint_factor,
    load_task_scenario,
    report,
    report_expect,
)
from mechkin.cli.common import (
    legacy_run_command as run_command,
)
from mechkin.config.scenario import Scenario
from mechkin.config.track_spec import GridSpec, TrackSpec, limits_si, point_si
from mechkin.config.units import length_factor
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.kinematics import forward_kinematics, frame_jacobian, frame_poses
from mechkin.solvers.dpct import (
    ConveyorReference,
    TrackLimits,
    TrackResult,
    TrackStatus,
    TrackTrajectory,
    solve_conveyor_tracking,
)
from mechkin.solvers.dynamics import InverseDynamics
from mechkin.solvers.dynamics_from_mechanism import (
    dynamics_from_mechanism,
    planar_two_link_from_mechanism,
)
from mechkin.solvers.path import IKLinePath

#: Continuation table of the inverse kinematics: r from -IK_MARGIN to 1 + IK_MARGIN.
IK_MARGIN = 0.02
IK_STEP = 0.005
IK_MAX_ITER = 100
CSV_NOTE = ("qdd and jerk are forward differences (park Eq. (32)-(33)); where undefined (qdd at "
            "the last node, jerk at the last two nodes and across the initial wait) they are "
            "written as 0 and flagged 0 in qdd_defined / jerk_defined")




@handle_errors
def _track(scenario: Path, out: Path | None, json_out: bool, plots: bool) -> int:
    sc = load_task_scenario(scenario, "track")
    summary, code = run_track(scenario=sc, out_dir=default_out_dir(sc.name, out), plots=plots)
    line = f"{sc.name}: {summary['status']}; wrote {summary['out_dir']}"
    if summary["status"] == "ok":
        head = (f"t_a = {summary['t_a_s']:.4g} s" if summary["t_a_s"] is not None
                else f"duration {summary['duration_s']:.4g} s")
        peaks = ", ".join(f"{v:.4g}" for v in summary["peak_torque"])
        g = summary["grid"]
        line = (f"{sc.name}: ok, {head}, peak torques [{peaks}], limits "
                f"{'ok' if summary['limits_ok'] else 'EXCEEDED'}, {g['N1']}x{g['N2']} "
                f"grid in {summary['solve_time_s']:.3g} s; wrote {summary['out_dir']}")
    report(summary, json_out, line)
    if summary["status"] != "ok":
        typer.echo(f"{sc.path}: {summary['message']}", err=True)
    return code


# ---- model pieces -----------------------------------------------------------------------------



def _dynamics(sc: Scenario, mech: Mechanism) -> InverseDynamics:
    spec: TrackSpec = sc.section
    if spec.dynamics == "closed_form_2link":
        return planar_two_link_from_mechanism(mech)
    return dynamics_from_mechanism(mech)


class _HandIK:
    """Position inverse kinematics of one frame along a line, on one branch (park Eq. (9)).

    A table ``q(r)`` is built once by continuation (each point's Newton-Raphson starts from the
    previous solution), so the branch chosen at the start is kept; a batch of points is then
    solved by Newton-Raphson from the table interpolated at their r.
    """

    def __init__(self, sc: Scenario, mech: Mechanism, p0: np.ndarray, p1: np.ndarray) -> None:
        spec: TrackSpec = sc.section
        doc = sc.doc
        self.mech, self.p0, self.p1 = mech, p0, p1
        self.dp = p1 - p0
        self.tol = spec.ik.tolerance * length_factor(sc.spec.units.length)
        fname = spec.path.frame
        if fname is None:
            if mech.end_effector is None:
                raise ConfigError(f"{doc.where(('track', 'path'))}: the mechanism has no "
                                  "end_effector; name the hand frame in path.frame")
            self.f = int(mech.end_effector)
        else:
            try:
                self.f = mech.frame_index(fname)
            except KeyError as exc:
                raise ConfigError(f"{doc.where(('track', 'path', 'frame'))}: {exc.args[0]}") \
                    from None
        q0 = np.asarray(mech.home, dtype=float).copy()
        guess = spec.ik.initial_guess or {}
        for name, v in guess.items():
            try:
                j = mech.joint_index(name)
            except KeyError as exc:
                raise ConfigError(f"{doc.where(('track', 'ik', 'initial_guess', name))}: "
                                  f"{exc.args[0]}") from None
            q0[j] = v * joint_factor(mech, j, sc.spec.units)
        branch = spec.ik.branch or {}
        for name in branch:
            try:
                mech.joint_index(name)
            except KeyError as exc:
                raise ConfigError(f"{doc.where(('track', 'ik', 'branch', name))}: "
                                  f"{exc.args[0]}") from None
        q_start, ok, err = self._newton(q0[None, :], p0[None, :], IK_MAX_ITER)
        if not ok:
            raise ConfigError(f"{doc.where(('track', 'path', 'start'))}: the hand cannot reach "
                              f"{p0.tolist()} m from the initial guess (error {err:.3g} m)")
        self.r_tab = np.arange(-IK_MARGIN, 1.0 + IK_MARGIN + IK_STEP / 2, IK_STEP)
        self.r_tab[np.argmin(np.abs(self.r_tab))] = 0.0
        i0 = int(np.argmin(np.abs(self.r_tab)))
        tab = np.empty((len(self.r_tab), mech.n))
        tab[i0] = q_start[0]
        for rng in (range(i0 + 1, len(self.r_tab)), range(i0 - 1, -1, -1)):
            prev = i0
            for i in rng:
                X = (p0 + self.r_tab[i] * self.dp)[None, :]
                q, ok, err = self._newton(tab[prev][None, :], X, IK_MAX_ITER)
                if not ok or np.max(np.abs(q[0] - tab[prev])) > 0.5:
                    raise ConfigError(
                        f"{doc.where(('track', 'path'))}: the hand line leaves the reachable "
                        f"workspace or meets a singularity near r = {self.r_tab[i]:.3g} "
                        f"(point {np.round(X[0], 6).tolist()} m, IK error {err:.3g} m)")
                tab[i] = q[0]
                prev = i
        for name, sign in branch.items():
            j = mech.joint_index(name)
            s = 1.0 if sign == "positive" else -1.0
            qj = np.angle(np.exp(1j * tab[:, j])) if mech.s[j] == 0 else tab[:, j]
            bad = np.flatnonzero(s * qj <= 0.0)
            inside = bad[(self.r_tab[bad] >= 0.0) & (self.r_tab[bad] <= 1.0)]
            if inside.size:
                k = int(inside[0])
                raise ConfigError(
                    f"{doc.where(('track', 'ik', 'branch', name))}: {name} is not {sign} at "
                    f"r = {self.r_tab[k]:.3g} ({name} = {tab[k, j]:.6g} "
                    f"{mech.joint_unit(j)}); change ik.initial_guess to start on that branch")
        self.tab = tab

    def _pos(self, q: np.ndarray) -> np.ndarray:
        return frame_poses(self.mech, q, [self.f])[:, 0, :3, 3]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Hand position Jacobian ``(m, 3, n)``."""
        q = np.asarray(q, dtype=float)
        kin = forward_kinematics(self.mech, q)
        return frame_jacobian(self.mech, kin, self.f)[:, 3:, :]

    def _newton(self, q: np.ndarray, X: np.ndarray, max_iter: int
                ) -> tuple[np.ndarray, bool, float]:
        q = np.array(q, dtype=float)
        err = np.inf
        for _ in range(max_iter):
            e = X - self._pos(q)
            err = float(np.max(np.linalg.norm(e, axis=1)))
            if err <= self.tol:
                return q, True, err
            step = np.einsum("mij,mj->mi", np.linalg.pinv(self.jacobian(q)), e)
            big = np.max(np.abs(step), axis=1, keepdims=True)
            q = q + step * np.minimum(1.0, 0.5 / np.maximum(big, 1e-300))
        return q, err <= self.tol, err

    def __call__(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        r = (X - self.p0) @ self.dp / float(self.dp @ self.dp)
        q0 = np.column_stack([np.interp(r, self.r_tab, self.tab[:, j])
                              for j in range(self.mech.n)])
        q, ok, err = self._newton(q0, X, 30)
        if not ok:
            raise ConfigError(f"track.path: inverse kinematics failed near r = "
                              f"{float(np.max(r)):.4g} (error {err:.3g} m)")
        return q


def _solve(spec: TrackSpec, grid: GridSpec, dyn: InverseDynamics, path: IKLinePath,
           ref: ConveyorReference | None, limits: TrackLimits) -> TrackResult:
    return solve_conveyor_tracking(
        dynamics=dyn, path=path, reference=ref, limits=limits, N1=grid.N1, N2=grid.N2,
        objective=spec.objective, nt_fraction=grid.nt_fraction,
        x2_max=grid.x2_max if spec.objective == "time" else None,
    )


def _grid_record(res: TrackResult) -> dict[str, Any]:
    s = res.summary()
    keys = ("status", "message", "t_a_s", "t_start_s", "duration_s", "peak_torque", "limits_ok",
            "active_limits", "solve_time_s", "cost", "blocked_at_r", "blocking_limits")
    rec = {"N1": res.grid.N1, "N2": res.grid.N2, "Nt": res.grid.Nt,
           "x2_max_1_s": res.grid.x2_max}
    rec.update({k: s[k] for k in keys})
    return rec


# ---- run --------------------------------------------------------------------------------------


def run_track(*, scenario: Scenario, out_dir: Path, plots: bool = True
              ) -> tuple[dict[str, Any], int]:
    """Plan the scenario's tracking (or minimum-time) motion and write every output.

    Returns the summary and the exit code: 0 when the plan exists, every limit holds on the
    realised trajectory and every ``expect:`` holds; 1 otherwise (an infeasible problem has
    status ``infeasible`` and a message naming the blocking limit and where it blocks).
    """
    spec: TrackSpec = scenario.section
    units = scenario.spec.units
    doc = scenario.doc
    mech = load_mechanism(scenario.mechanism_path)
    dyn = _dynamics(scenario, mech)
    lim = limits_si(spec.limits, units, np.asarray(mech.s) == 1)
    for name, (lo, _) in lim.items():
        if lo.shape != (mech.n,):
            raise ConfigError(f"{doc.where(('track', 'limits', name))}: expected {mech.n} "
                              f"values (one per joint: {', '.join(mech.joint_names)}), got "
                              f"{lo.shape[0]}")
    limits = TrackLimits(**lim)
    p0, p1 = point_si(spec.path.start, units), point_si(spec.path.end, units)
    ik = _HandIK(scenario, mech, p0, p1)
    path = IKLinePath(p0=p0, p1=p1, ik=ik, jacobian=ik.jacobian, n=mech.n)
    ref = None
    if spec.conveyor is not None:
        ref = ConveyorReference(part_start=point_si(spec.conveyor.part_start, units),
                                belt_velocity=point_si(spec.conveyor.belt_velocity, units))
        try:
            ref.phase(path)
        except ConfigError as exc:
            raise ConfigError(f"{doc.where(('track', 'conveyor'))}: {exc}") from None

    res = _solve(spec, spec.grid, dyn, path, ref, limits)
    study: list[dict[str, Any]] | None = None
    study_results: list[TrackResult] = []
    if spec.grid_study is not None:
        for g in spec.grid_study:
            study_results.append(res if g == spec.grid
                                 else _solve(spec, g, dyn, path, ref, limits))
        study = [_grid_record(r) for r in study_results]

    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "track",
        "mechanism": mech.name,
        "dynamics": spec.dynamics,
        **res.summary(),
    }
    summary["peak_torque_by_joint"] = (
        None if res.peak_torque is None
        else {n: float(v) for n, v in zip(mech.joint_names, res.peak_torque, strict=True)})
    summary["path"] = {"start_m": p0.tolist(), "end_m": p1.tolist(),
                       "frame": mech.frame_names[ik.f],
                       "length_m": float(np.linalg.norm(p1 - p0))}
    if ref is not None:
        r0, rd = ref.phase(path)
        summary["reference"] = {"r0": r0, "rd_1_s": rd, "t_f_s": (1.0 - r0) / rd}
    summary["limits_si"] = {k: {"min": lo.tolist(), "max": hi.tolist()}
                            for k, (lo, hi) in lim.items()}
    if study is not None:
        summary["grid_study"] = study
    traj = res.trajectory
    if traj is not None:
        summary["n_samples"] = int(traj.t.shape[0])
        summary["csv_notes"] = CSV_NOTE
    checks = evaluate_expect(summary, scenario.spec.expect)
    for c in checks:  # a value missing from the summary (infeasible: t_a_s None) is null, not NaN
        for k in ("actual", "error"):
            if isinstance(c.get(k), float) and not np.isfinite(c[k]):
                c[k] = None
                c.setdefault("message", f"no value at {c['key']!r} in the summary")
    if checks:
        summary["expect"] = checks
    summary = _write_outputs(scenario, mech, res, study_results, spec, out_dir, summary, plots,
                             (p0, p1), ref)
    report_expect(checks, scenario.path)
    ok = res.status is TrackStatus.OK and res.limits_ok and all(c["ok"] for c in checks)
    if study is not None:
        ok = ok and all(r["status"] == "ok" and r["limits_ok"] for r in study)
    return summary, 0 if ok else 1


# ---- outputs ----------------------------------------------------------------------------------


def _filled(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """NaN -> 0 and a per-row flag (1 where every joint's value is defined)."""
    defined = np.all(np.isfinite(a), axis=1)
    return np.where(np.isfinite(a), a, 0.0), defined.astype(int)


def _csv_columns(mech: Mechanism, traj: TrackTrajectory) -> dict[str, Any]:
    pris = [bool(s == 1) for s in mech.s]
    cols: dict[str, Any] = {}
    qdd_f, qdd_ok = _filled(traj.qdd)
    jerk_f, jerk_ok = _filled(traj.jerk)
    filled = TrackTrajectory(traj.t, traj.r, traj.rd, traj.rdd, traj.q, traj.qd, qdd_f, jerk_f,
                             traj.torque, traj.hand, traj.part, traj.tracking_error)
    for k, v in filled.columns(pris).items():
        cols[k] = v
    cols["qdd_defined"] = qdd_ok
    cols["jerk_defined"] = jerk_ok
    if traj.tracking_error is not None:
        cols["error_norm_m"] = np.linalg.norm(traj.tracking_error, axis=1)
    return cols


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


def _write_mcap(od: Any, scenario: Scenario, mech: Mechanism, traj: TrackTrajectory,
                ref: ConveyorReference | None, spec: TrackSpec, t_a: float | None,
                ends: tuple[np.ndarray, np.ndarray]) -> None:
    from mechkin.io import Box, Lines, MotionLog, Scene, Spheres, write_mcap
    from mechkin.model.drawing import frame_tree, skeleton_segments

    kin = forward_kinematics(mech, traj.q)
    root, names, parents, T_pc = frame_tree(mech, kin)
    seg = skeleton_segments(mech, kin)
    m = seg.shape[0]
    size = max(float(np.ptp(seg.reshape(-1, 3), axis=0).max()), 1e-3)
    lines = [Lines(seg.reshape(m, -1, 3), kind="list", thickness=0.01 * size,
                   rgba=(0.2, 0.5, 0.9, 1.0)),
             Lines(np.stack(ends), kind="strip", thickness=0.004 * size,
                   rgba=(0.95, 0.85, 0.2, 1.0))]
    boxes = []
    state: list[dict[str, Any]] = []
    phases = _phase_labels(traj, t_a)
    if ref is not None and traj.part is not None and spec.conveyor is not None:
        psize = point_si(spec.conveyor.part_size, scenario.spec.units)
        R = _belt_frame(ref.belt_velocity)
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
        state.append(st)
    qdd_f, _ = _filled(traj.qdd)
    log = MotionLog(
        times=traj.t, root_frame=root, frame_names=names, frame_parents=parents,
        T_parent_child=T_pc, joint_names=list(mech.joint_names), q=traj.q, qd=traj.qd,
        qdd=qdd_f, effort=traj.torque,
        scene=Scene(lines=tuple(lines), spheres=(Spheres(kin.axes()[1], radius=0.015 * size),),
                    boxes=tuple(boxes), entity_id="track"),
        state=state,
        metadata={"scenario": scenario.name, "mechanism": mech.name, "task": "track"},
    )
    write_mcap(od.path_for("track.mcap"), log)


def _panels(path: Path, t: np.ndarray, ys: np.ndarray, labels: list[str], ylabel: str,
            title: str, limits: tuple[np.ndarray, np.ndarray] | None,
            steps: bool = False) -> None:
    """One panel per column of ys against t, with that joint's limits dashed; ``steps`` draws
    values that hold over the transition leaving each node (torque, Eq. (32)-(33) differences)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = ys.shape[1]
    fig = Figure(figsize=(7.0, 2.4 * n + 0.6))
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
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")


def _plots(od: Any, scenario: Scenario, mech: Mechanism, res: TrackResult,
           phase_ref: tuple[float, float] | None, study_results: list[TrackResult],
           lim: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    traj = res.trajectory
    assert traj is not None
    name = scenario.name
    # park Fig. 4 / 5: phase plane with the part's reference, and r(t) against the part's r~(t)
    fig = Figure(figsize=(11.0, 4.2))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    for other in study_results:
        tr = other.trajectory
        if tr is not None:
            ax1.plot(tr.r, tr.rd, linewidth=1.0, alpha=0.7,
                     label=f"{other.grid.N1}x{other.grid.N2}")
    ax1.plot(traj.r, traj.rd, "k.-", linewidth=1.6, markersize=3,
             label=f"DP {res.grid.N1}x{res.grid.N2}")
    if phase_ref is not None:
        r0, rd = phase_ref
        ax1.axhline(rd, color="tab:red", linestyle="--", label="part x~2 = r~'")
        tt = np.linspace(0.0, float(traj.t[-1]), 200)
        ax2.plot(tt, r0 + rd * tt, color="tab:red", linestyle="--", label="part r~(t)")
    if res.t_a_s is not None:
        ax2.axvline(res.t_a_s, color="0.5", linestyle=":", label=f"t_a = {res.t_a_s:.4g} s")
    ax2.plot(traj.t, traj.r, "k.-", markersize=3, label="hand r(t)")
    ax1.set(xlabel="r = x1 [-]", ylabel="r' = x2 [1/s]", title=f"{name}: phase plane")
    ax2.set(xlabel="t [s]", ylabel="r [-]", title="path parameter", ylim=(-0.6, 1.1))
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(od.path_for("phase.png"), dpi=110, format="png")
    # park Fig. 5/6: hand vs part positions and the tracking error
    fig = Figure(figsize=(7.0, 6.0))
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
    fig.tight_layout()
    fig.savefig(od.path_for("hand_part.png"), dpi=110, format="png")
    # park Figs. 6-8: joint velocities, accelerations and jerks, torques, with their limits
    units = ["m" if s == 1 else "rad" for s in mech.s]
    jn = list(mech.joint_names)
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


def _write_outputs(scenario: Scenario, mech: Mechanism, res: TrackResult,
                   study_results: list[TrackResult], spec: TrackSpec, out_dir: Path,
                   summary: dict[str, Any], plots: bool, ends: tuple[np.ndarray, np.ndarray],
                   ref: ConveyorReference | None) -> dict[str, Any]:
    """Stage track.csv, the plots, track.mcap and summary.json in one OutputDir."""
    from mechkin.io import OutputDir

    outs = scenario.spec.outputs
    summary = dict(summary)
    summary["out_dir"] = str(out_dir)
    traj = res.trajectory
    with OutputDir(out_dir) as od:
        if traj is not None:
            if outs.csv:
                od.write_csv("track.csv", _csv_columns(mech, traj))
            if plots and outs.plots:
                lim_arr = {k: (np.asarray(v["min"]), np.asarray(v["max"]))
                           for k, v in summary["limits_si"].items()}
                rf = summary.get("reference")
                phase_ref = None if rf is None else (rf["r0"], rf["rd_1_s"])
                _plots(od, scenario, mech, res, phase_ref,
                       [r for r in study_results if r is not res], lim_arr)
            if outs.mcap:
                _write_mcap(od, scenario, mech, traj, ref, spec, res.t_a_s, ends)
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary


track_cli = run_command(
    "track",
    "Conveyor tracking (or minimum time) along a straight hand line by DP (park §2-§5).",
    _track,
)

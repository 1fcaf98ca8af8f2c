"""``mechkin ik SCENARIO.yaml``: independent joints that bring {E} onto each precision point."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.cli.common import (
    default_out_dir,
    evaluate_expect,
    handle_errors,
    joint_factor,
    load_task_scenario,
    report,
    report_expect,
    run_command,
)
from mechkin.config.ik_spec import IkSpec, target_matrix
from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.ik import (
    IkOptions,
    IkResult,
    IkStatus,
    pose_errors,
    solve_ik,
    solve_ik_batch,
)

CLOSED_FORMS = ("kim1995_direct_drive", "kim1995_stewart")




@handle_errors
def _ik(scenario: Path, out: Path | None, json_out: bool, plots: bool) -> int:
    sc = load_task_scenario(scenario, "ik")
    if sc.section_name == "biped":  # hwang2023: the closed-form leg classes
        from mechkin.cli.biped_run import run_biped

        summary, code = run_biped(scenario=sc, out_dir=default_out_dir(sc.name, out),
                                  plots=plots)
        report(summary, json_out, f"{sc.name}: {summary.get('status', '?')}; wrote "
               f"{default_out_dir(sc.name, out)}")
        return code
    summary, code = run_ik(scenario=sc, out_dir=default_out_dir(sc.name, out), plots=plots)
    c = summary["counts"]
    report(summary, json_out, f"{sc.name}: {summary['status']} ({c.get('ok', 0)}/"
           f"{summary['n_targets']} targets ok, max errors {summary['max_position_error']:.3g} m, "
           f"{summary['max_orientation_error']:.3g} rad); wrote {summary['out_dir']}")
    return code



def _targets(sc: Scenario, mech: Mechanism) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Precision points (k, 4, 4) [SI], weights (k, 6) and labels."""
    spec: IkSpec = sc.section
    Ts, Ws, names = [], [], []
    for i, t in enumerate(spec.targets):
        Ts.append(target_matrix(t, sc.spec.units))
        Ws.append(t.weights if t.weights is not None else spec.weights)
        names.append(t.name or f"P{i + 1}")
    if spec.random_targets is not None:
        rt = spec.random_targets
        rng = np.random.default_rng(rt.seed)
        iv = mech.independent
        lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -np.pi)
        hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], np.pi)
        qv = rng.uniform(lo, hi, size=(rt.count, len(iv)))
        res = solve_closure(mech, qv, mech.home[mech.dependent][None])
        kin = forward_kinematics(mech, res.q)
        T_E = kin.frames(mech, [mech.end_effector])[:, 0]
        keep = np.flatnonzero(res.ok)
        for k in keep:
            Ts.append(T_E[k])
            Ws.append(spec.weights)
            names.append(f"R{k + 1}")
    return np.array(Ts).reshape(-1, 4, 4), np.array(Ws, dtype=float), names


def _initial(sc: Scenario, mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    qv, qw = mech.home[mech.independent].copy(), mech.home[mech.dependent].copy()
    guess = sc.section.initial_guess or {}
    ind, dep = mech.independent_names, mech.dependent_names
    bad = [k for k in guess if k not in ind and k not in dep]
    if bad:
        raise ConfigError([f"{sc.doc.where(('ik', 'initial_guess', k))}: not a joint of "
                           f"{mech.name} (independent: {', '.join(ind)})" for k in bad])
    for k, v in guess.items():
        val = v * joint_factor(mech, mech.joint_index(k), sc.spec.units)
        if k in ind:
            qv[ind.index(k)] = val
        else:
            qw[dep.index(k)] = val
    return qv, qw


def _closed_form(mech: Mechanism, T: np.ndarray, q_w0: np.ndarray) -> IkResult:
    """kim1995 appendix (direct-drive arm) or leg lengths (Stewart), then the loop closure."""
    t0 = time.perf_counter()
    if mech.name == "kim1995_direct_drive":
        from mechkin.solvers.closed_form.direct_drive import direct_drive_ik

        qv, _ = direct_drive_ik(T[None], tol=1e-4)
    else:
        from mechkin.solvers.closed_form.stewart import leg_lengths, stewart_attachments

        a, b = stewart_attachments(mech)
        qv = leg_lengths(T[None], a, b)
    res = solve_closure(mech, qv, q_w0[None])
    q = res.q[0]
    T_E = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    pe, oe = pose_errors(T_E, T[None])
    ok = bool(res.ok[0]) and pe[0] < 1e-4 and oe[0] < 1e-4
    return IkResult(q_v=q[mech.independent], q_w=q[mech.dependent], q=q,
                    status=IkStatus.OK if ok else IkStatus.UNREACHABLE,
                    position_error=float(pe[0]), orientation_error=float(oe[0]), f=0.0,
                    grad_norm=0.0, iterations=0, evaluations=1,
                    time_s=time.perf_counter() - t0, f_history=np.zeros(1),
                    method="closed-form")


def _clean(v: float) -> float:
    return float(v) if np.isfinite(v) else 0.0


def run_ik(*, scenario: Scenario, out_dir: Path, plots: bool = True) -> tuple[dict[str, Any], int]:
    """Solve every precision point in order (each warm-started from the previous solution,
    kim1995 §5.2 Step 2) and write summary.json, ik.csv, stick.png, convergence.png, ik.mcap.

    Returns the summary and the exit code (0 every target ok and every expect held, else 1).
    """
    from mechkin.cli.outputs import write_motion_outputs

    spec: IkSpec = scenario.section
    mech = load_mechanism(scenario.mechanism_path)
    if mech.end_effector is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: mechanism {mech.name} has no "
                          "end_effector frame")
    if spec.method == "closed-form" and mech.name not in CLOSED_FORMS:
        raise ConfigError(f"{scenario.doc.where(('ik', 'method'))}: no closed form for "
                          f"mechanism {mech.name} (closed forms: {', '.join(CLOSED_FORMS)})")
    T_P, W, labels = _targets(scenario, mech)
    if len(T_P) == 0:
        raise ConfigError(f"{scenario.doc.where(('ik',))}: no targets to solve")
    qv0, qw0 = _initial(scenario, mech)
    tol = spec.tolerances
    L = length_factor(scenario.spec.units.length)
    A = angle_factor(scenario.spec.units.angle)
    opts = IkOptions(
        method="cg-golden" if spec.method == "cg-golden" else "lm", grad_tol=tol.grad,
        max_iter=tol.max_iter, tol_pos=tol.position * L if tol.position else 1e-6,
        tol_ori=tol.orientation * A if tol.orientation else 1e-6, restarts=spec.restarts,
        seed=spec.seed, tol_phi=tol.closure, line_tol=tol.line, cg_restart=spec.cg_restart)
    t0 = time.perf_counter()
    results: list[IkResult] = []
    if spec.batch:
        br = solve_ik_batch(mech, T_P, q_v0=qv0, q_w0=qw0, weights=W, options=opts)
        per = br.time_s / len(T_P)
        for i in range(len(T_P)):
            results.append(IkResult(
                q_v=br.q_v[i], q_w=br.q_w[i], q=br.q[i], status=br.status[i],
                position_error=float(br.position_error[i]),
                orientation_error=float(br.orientation_error[i]), f=float(br.f[i]),
                grad_norm=0.0, iterations=int(br.iterations[i]),
                evaluations=int(br.iterations[i]) + 1, time_s=per,
                f_history=np.array([br.f[i]]), method="lm"))
    else:
        qv, qw = qv0, qw0
        for T, w in zip(T_P, W, strict=False):
            if spec.method == "closed-form":
                r = _closed_form(mech, T, qw)
            else:
                r = solve_ik(mech, T, q_v0=qv, q_w0=qw, weights=w, options=opts)
            results.append(r)
            if spec.warm_start and r.status is not IkStatus.SINGULAR:
                qv, qw = r.q_v, r.q_w
    solve_s = time.perf_counter() - t0
    q = np.array([r.q for r in results])
    q = np.where(np.isfinite(q), q, mech.home)
    kin = forward_kinematics(mech, q)
    T_E = kin.frames(mech, [mech.end_effector])[:, 0]
    pe, oe = pose_errors(T_E, T_P)  # verified by forward kinematics of the model
    phi = closure_residual(mech, kin)
    phin = np.linalg.norm(phi, axis=1) if phi.shape[1] else np.zeros(len(q))
    status = [r.status.value for r in results]
    counts = {s.value: status.count(s.value) for s in IkStatus if s.value in status}
    overall = "ok" if counts.get("ok", 0) == len(results) else next(
        s.value for s in (IkStatus.SINGULAR, IkStatus.UNREACHABLE, IkStatus.AT_LIMIT,
                          IkStatus.NOT_CONVERGED) if s.value in status)
    records = []
    for i, r in enumerate(results):
        rec: dict[str, Any] = {
            "name": labels[i],
            "status": r.status.value,
            "q": {n: float(v) for n, v in zip(mech.joint_names, q[i], strict=False)},
            "q_v": {n: float(q[i, j]) for n, j in zip(mech.independent_names,
                                                       mech.independent, strict=False)},
            "position_error": _clean(pe[i]),
            "orientation_error": _clean(oe[i]),
            "weights": [float(v) for v in W[i]],
            "f": _clean(r.f),
            "grad_norm": _clean(r.grad_norm),
            "iterations": int(r.iterations),
            "evaluations": int(r.evaluations),
            "time_s": float(r.time_s),
            "closure_residual": _clean(phin[i]),
            "joints_at_limit": list(r.at_limit),
            "target": {"xyz_m": T_P[i, :3, 3].tolist(), "R": T_P[i, :3, :3].tolist()},
            "end_effector": {"xyz_m": T_E[i, :3, 3].tolist(), "R": T_E[i, :3, :3].tolist()},
        }
        if r.restarts_used:
            rec["restarts_used"] = int(r.restarts_used)
        records.append(rec)
    times_s = np.array([r.time_s for r in results])
    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "ik",
        "mechanism": mech.name,
        "method": spec.method,
        "status": overall,
        "n_targets": len(results),
        "counts": counts,
        "max_position_error": _clean(float(pe.max())),
        "max_orientation_error": _clean(float(oe.max())),
        "solve_time_s": solve_s,
        "median_time_per_target_s": float(np.median(times_s)),
        "end_effector": mech.frame_names[mech.end_effector],
        "targets": records,
    }
    checks = evaluate_expect(summary, scenario.spec.expect)
    if checks:
        summary["expect"] = checks
    times = np.arange(len(results), dtype=float)  # one second per precision point

    def conv_plot(od: Any) -> None:
        from mechkin.io.plots import plot_convergence

        series = {labels[i]: np.maximum(r.f_history, 0.0) for i, r in enumerate(results[:12])
                  if len(r.f_history)}
        if series:
            plot_convergence(od.path_for("convergence.png"), series, "f = 1/2 x^T W x",
                             title=f"{scenario.name}: {spec.method} (kim1995 Eq. (9))")

    snaps = list(range(len(results))) if len(results) <= 8 else list(
        np.linspace(0, len(results) - 1, 8).round().astype(int))
    extra_cols: dict[str, Any] = {
        "target": labels,
        "position_error_m": pe, "orientation_error_rad": oe,
        "iterations": [r.iterations for r in results],
        "target_x_m": T_P[:, 0, 3], "target_y_m": T_P[:, 1, 3], "target_z_m": T_P[:, 2, 3],
    }
    summary = write_motion_outputs(
        scenario=scenario, mech=mech, kin=kin, times=times, out_dir=out_dir, summary=summary,
        step_status=status, residual=phin, plots=plots, task="ik", extra_columns=extra_cols,
        extra_state=[{"target": labels[i], "position_error": float(pe[i]),
                      "orientation_error": float(oe[i])} for i in range(len(results))],
        snapshots=snaps, snapshot_labels=[labels[k] for k in snaps],
        extra_plots=conv_plot,
    )
    report_expect(checks, scenario.path)
    ok = overall == "ok" and all(c["ok"] for c in checks)
    return summary, 0 if ok else 1


ik_cli = run_command(
    "ik",
    "Inverse kinematics: independent joints for every precision point (kim1995 §5.2).",
    _ik,
)

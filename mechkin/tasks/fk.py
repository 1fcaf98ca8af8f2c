"""The fk task: loop-closure forward kinematics along a motion of the independent joints
(kim1995 §5.1), warm-started step to step. Returns a :class:`mechkin.records.Report`; writes
nothing.

``assembly: all`` adds every assembly mode of the loop closure at the motion's first
configuration (and at the ``assembly_at`` configurations), found by
:func:`mechkin.solvers.assembly.assembly_modes`: summary.json gets ``assembly_modes`` (per mode
``q``, ``q_w``, ``residual``, ``distance_from_guess``, ``within_limits`` and the {E} pose),
``n_assembly_modes``, ``n_assembly_modes_within_limits`` and ``assembly_mode_followed`` (the
index of the mode the motion runs on; the motion is solved as with ``one``), and
``assembly_at`` for the given configurations.

``base:`` (kim1995 §5.1 Step 1, a moving base T_0(t)) re-expresses the end-effector pose,
twist and acceleration, the final pose and the drawings in the world frame and adds the base's
own columns and summary block (:mod:`mechkin.tasks.fk_base`); the loop closure is unchanged.

Imports: config, model, solvers (assembly), records, tasks.common, tasks.fk_base.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from mechkin.config.load import note_once, short_list
from mechkin.config.scenario import FkSpec, Scenario
from mechkin.config.units import angle_factor
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.closure import ClosureStatus
from mechkin.model.continuation import solve_motion, with_limits
from mechkin.model.differential import motion_derivatives
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.model.singularity import constraint_crossings, mark_crossings
from mechkin.records import Report
from mechkin.tasks import budget
from mechkin.tasks.budget import MAX_TIME_S, estimate_time
from mechkin.tasks.common import (
    UNIT_TO_SI,
    check_motion_budget,
    expect_messages,
    joint_factor,
    motion_record,
    output_flags,
    with_expect,
)
from mechkin.tasks.estimates import fk_seconds
from mechkin.tasks.fk_base import (
    base_into_record,
    base_into_summary,
    base_trajectory,
    check_table_lengths,
    floating_base_fill,
)
from mechkin.tasks.fk_batch import (
    is_open_chain,
    open_chain_derivatives,
    status_values,
)
from mechkin.tasks.fk_singularity import (
    singularity_columns,
    singularity_messages,
    singularity_summary,
)

# CSV column suffixes of joint values and their SI factors
SUFFIX_TO_SI = {k: UNIT_TO_SI[k] for k in ("rad", "deg", "m", "mm")}


def independent_motion(sc: Scenario, mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """Times (m,) [s] and independent joint values (m, n_v) in SI from the fk section."""
    t, qv, _, _ = independent_motion_rates(sc, mech)
    return t, qv


def independent_motion_rates(sc: Scenario, mech: Mechanism
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times (m,), independent joints (m, n_v) and their first and second time derivatives:
    analytic for ``constant`` / ``ramp`` / ``sinusoid`` motions, from a twice-differentiable
    spline through the samples (scipy ``CubicSpline``, not-a-knot) for a ``table`` or ``csv``
    (finite differences where the times repeat; zero for a single sample)."""
    spec: FkSpec = sc.section
    doc = sc.doc
    names = mech.independent_names
    problems: list[str] = []
    if spec.motion is not None:
        ts = spec.time
        if ts.stop <= ts.start:
            raise ConfigError(f"{doc.where(('fk', 'time', 'stop'))}: expected stop > start")
        m = int(np.floor((ts.stop - ts.start) / ts.step + 1e-9)) + 1
        if m > 1_000_000:
            raise ConfigError(f"{doc.where(('fk', 'time'))}: {m} steps is more than 1e6")
        t = ts.start + ts.step * np.arange(m)
        for k in spec.motion:
            if k not in names:
                problems.append(f"{doc.where(('fk', 'motion', k))}: not an independent joint "
                                f"(independent: {', '.join(names)})")
        qv = np.zeros((m, len(names)))
        qd = np.zeros((m, len(names)))
        qdd = np.zeros((m, len(names)))
        span = max(t[-1] - t[0], 1e-300)
        fill, bad = floating_base_fill(sc, mech, spec.motion)
        problems += bad
        held: list[str] = []
        for i, name in enumerate(names):
            mo = spec.motion.get(name)
            if i in fill:  # a floating base at fk.base_pose or its home pose
                qv[:, i] = fill[i]
                continue
            if mo is None:  # held at its home value (one note names them all, below)
                h = float(mech.home[mech.independent[i]])
                qv[:, i] = h if np.isfinite(h) else 0.0
                held.append(name)
                continue
            f = joint_factor(mech, mech.independent[i], sc.spec.units)
            if mo.type == "constant":
                qv[:, i] = mo.value * f
            elif mo.type == "ramp":
                qv[:, i] = (mo.start + (mo.to - mo.start) * (t - t[0]) / span) * f
                qd[:, i] = (mo.to - mo.start) / span * f
            else:
                w = 2 * np.pi * mo.frequency
                arg = w * t + mo.phase * angle_factor(sc.spec.units.angle)
                qv[:, i] = (mo.offset + mo.amplitude * np.sin(arg)) * f
                qd[:, i] = mo.amplitude * w * np.cos(arg) * f
                qdd[:, i] = -mo.amplitude * w * w * np.sin(arg) * f
        if held and not problems:
            note_once(doc.path, f"{doc.where(('fk', 'motion'))}: note: {len(held)} independent "
                      f"joint{'s' if len(held) > 1 else ''} without a motion hold "
                      f"{'their' if len(held) > 1 else 'its'} home value: "
                      f"{short_list(held, 120)}")
    elif spec.table is not None:
        tab = spec.table
        if "t" not in tab:
            problems.append(f"{doc.where(('fk', 'table'))}: missing column 't' (times in s)")
        for k in tab:
            if k != "t" and k not in names:
                problems.append(f"{doc.where(('fk', 'table', k))}: not an independent joint "
                                f"(independent: {', '.join(names)})")
        fill, bad = floating_base_fill(sc, mech, tab)
        problems += bad
        for i, name in enumerate(names):
            if name not in tab and i not in fill:
                problems.append(f"{doc.where(('fk', 'table'))}: no column for independent "
                                f"joint {name!r}")
        if problems:
            raise ConfigError(problems)
        check_table_lengths(doc, ("fk", "table"), tab)
        t = np.asarray(tab["t"], dtype=float)
        qv = np.column_stack([
            np.full(len(t), fill[i]) if i in fill else np.asarray(tab[name], dtype=float)
            * joint_factor(mech, mech.independent[i], sc.spec.units)
            for i, name in enumerate(names)
        ])
    else:
        t, qv = _read_motion_csv(sc, mech, names)
    if problems:
        raise ConfigError(problems)
    if np.any(np.diff(t) < 0):
        raise ConfigError(f"{doc.where(('fk',))}: times must be non-decreasing")
    if t[0] < 0:
        raise ConfigError(f"{doc.where(('fk',))}: times must be >= 0")
    if t[-1] > MAX_TIME_S:  # a spline over 1e308 s overflows (issue 28 item 9)
        raise ConfigError(f"{doc.where(('fk',))}: times must be at most {MAX_TIME_S:g} s, got "
                          f"{t[-1]:.3g}")
    if spec.motion is None:
        qd, qdd = sampled_rates(t, qv)
    return t, qv, qd, qdd


def sampled_rates(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives of samples x (m, k) at times t: a not-a-knot cubic spline
    (C2) when the times increase strictly and m >= 4, else second-order differences (m = 3) or
    zeros."""
    m = len(t)
    if m >= 4 and np.all(np.diff(t) > 0):
        from scipy.interpolate import CubicSpline

        sp = CubicSpline(t, x, axis=0)
        return sp(t, 1), sp(t, 2)
    if m >= 3 and np.all(np.diff(t) > 0):
        xd = np.gradient(x, t, axis=0, edge_order=2)
        return xd, np.gradient(xd, t, axis=0, edge_order=2)
    return np.zeros_like(x), np.zeros_like(x)


def _read_motion_csv(sc: Scenario, mech: Mechanism, names: list[str]
                     ) -> tuple[np.ndarray, np.ndarray]:
    from mechkin.config.table_csv import read_numeric_csv

    path = (sc.doc.path.parent / sc.section.csv).resolve()
    where = sc.doc.where(("fk", "csv"))
    if not path.is_file():
        raise ConfigError(f"{where}: file not found: {sc.section.csv} (resolved to {path})")
    cols = read_numeric_csv(path)
    if "t_s" not in cols:
        raise ConfigError(f"{path}:1: missing column 't_s'")
    t = np.asarray(cols["t_s"], dtype=float)
    qv = np.zeros((len(t), len(names)))
    given = {c.rsplit("_", 1)[0] for c in cols if c.rsplit("_", 1)[-1] in SUFFIX_TO_SI}
    fill, bad = floating_base_fill(sc, mech, given)
    if bad:
        raise ConfigError(bad)
    for i, name in enumerate(names):
        hit = [(c, SUFFIX_TO_SI[c.rsplit("_", 1)[1]]) for c in cols
               if c.rsplit("_", 1)[0] == name and c.rsplit("_", 1)[-1] in SUFFIX_TO_SI]
        if i in fill:
            qv[:, i] = fill[i]
            continue
        if not hit:
            raise ConfigError(f"{path}:1: no column for independent joint {name!r} (expected "
                              f"{name}_rad, {name}_deg, {name}_m or {name}_mm)")
        qv[:, i] = np.asarray(cols[hit[0][0]], dtype=float) * hit[0][1]
    return t, qv


def initial_dependent(sc: Scenario, mech: Mechanism) -> np.ndarray:
    q_w0 = mech.home[mech.dependent].copy()
    guess = sc.section.initial_guess or {}
    dep = mech.dependent_names
    bad = [k for k in guess if k not in dep]
    if bad:
        raise ConfigError([f"{sc.doc.where(('fk', 'initial_guess', k))}: not a dependent joint "
                           f"(dependent: {', '.join(dep)})" for k in bad])
    for k, v in guess.items():
        j = mech.joint_index(k)
        q_w0[dep.index(k)] = v * joint_factor(mech, j, sc.spec.units)
    return q_w0


def check_budget(scenario: Scenario) -> None:
    """The run's memory budget check, without solving."""
    mech = load_mechanism(scenario.mechanism_path)
    t, *_ = independent_motion_rates(scenario, mech)
    _check_steps(scenario, mech, len(t))


def _check_steps(scenario: Scenario, mech: Mechanism, m: int) -> None:
    """m fk steps with their rates (qd, qdd, twists) against the memory budget."""
    check_motion_budget(scenario, mech, m, ("fk",), "fk steps", extra_per_item=
                        8.0 * (4 * mech.n + 24 * len(mech.frame_names)))
    estimate_time(scenario.doc.where(("fk",)), fk_seconds(mech, m, scenario.spec.outputs),
                  f"{m} fk steps of {mech.name}")


#: Steps per loop-closure chunk of a long motion (progress and Ctrl-C between chunks).
CHUNK_STEPS = 20_000


#: Steps per chunk under ``--max-time`` (the run may stop between two chunks).
TIMED_CHUNK_STEPS = 1_000


#: Fewest steps per chunk of a motion split over workers (``--workers`` / ``--scheduler``).
SPLIT_MIN_STEPS = 2_000


def _solve_split(mech: Mechanism, qv: np.ndarray, q_w0: np.ndarray, kw: dict[str, Any],
                 ex: Any) -> Any:
    """The loop closure in chunks with overlapping warm starts on the run's workers
    (:func:`mechkin.solvers.distributed.solve_trajectory_chunks`: same assembly mode as one
    process, joints equal within the closure tolerance)."""
    from mechkin.solvers.distributed import solve_trajectory_chunks
    from mechkin.solvers.workspace.sweeps import run_jobs
    from mechkin.tasks.progress import progress_bar

    m = len(qv)
    n = ex.n_workers(1) or 8
    chunk = int(min(CHUNK_STEPS, max(SPLIT_MIN_STEPS, -(-m // (2 * n)))))
    stop = budget.overrun if budget.time_limit() is not None else None  # keep the chunks done
    with progress_bar(ex.progress, f"fk: {m} steps in chunks", deadline=False) as update:
        res, _ = solve_trajectory_chunks(
            mech, qv, q_w0, chunk_steps=chunk, progress=update,
            run_jobs=lambda fn, jobs, prog: run_jobs(fn, jobs, workers=ex.n_workers(1),
                                                     address=ex.address, progress=prog,
                                                     stop=stop),
            **kw)
    return res


def _solve_in_chunks(mech: Mechanism, qv: np.ndarray, q_w0: np.ndarray, tol: Any,
                     progress: bool | None, guess: bool = False) -> Any:
    """The loop closure over the whole motion (:func:`mechkin.model.continuation.solve_motion`:
    the first sample reached from the home assembly by continuation, or from ``q_w0`` when
    ``guess`` (the scenario's ``initial_guess``), then sample to sample); a motion longer than
    :data:`CHUNK_STEPS` is solved chunk by chunk, each continued from the previous chunk's last
    assembled sample, with a progress bar (stderr) when asked."""
    from dataclasses import fields

    from mechkin.tasks.progress import progress_bar

    kw = dict(tol_phi=tol.phi, tol_dq=tol.dq, max_iter=tol.max_iter)
    m = len(qv)
    if mech.n_cuts == 0 and len(mech.dependent) == 0:
        # an open chain has no loop to close: every step is converged with zero iterations,
        # zero residual and cond 1 (what solve_closure returns, without the per-step loop)
        from mechkin.model.closure import ClosureResult

        return ClosureResult(q=mech.assemble(qv, np.zeros((m, 0))),
                             status=np.full(m, ClosureStatus.CONVERGED, dtype=object),
                             iterations=np.zeros(m, dtype=int), residual=np.zeros(m),
                             cond=np.ones(m))
    from mechkin.tasks.distributed import resolve

    ex = resolve(progress=progress)
    if ex.split and m >= 2 * SPLIT_MIN_STEPS:
        # the first sample's assembly as the rest reach it (from home by continuation)
        first = solve_motion(mech, qv[:1], q_w0=q_w0, guess=guess, **kw)
        start_w = first.q[0, mech.dependent] if first.ok[0] else q_w0
        return _solve_split(mech, qv, start_w, kw, ex)
    # under --max-time: shorter chunks, the run stops between two (budget.overrun)
    timed = budget.time_limit() is not None
    size = TIMED_CHUNK_STEPS if timed else CHUNK_STEPS
    if m <= size:
        return solve_motion(mech, qv, q_w0=q_w0, guess=guess, **kw)
    parts = []
    with progress_bar(progress, f"fk: {m} steps", deadline=False) as update:
        start_q = None
        for k in range(0, m, size):
            r = solve_motion(mech, qv[k:k + size], q_w0=q_w0, guess=guess,
                             q_start=start_q, **kw)
            parts.append(r)
            good = np.flatnonzero(r.ok)
            if good.size:
                start_q = r.q[good[-1]]
            if update is not None:
                update(min(k + size, m), m)
            if timed and k + size < m and budget.overrun():
                break  # the run notes the steps done
    first = parts[0]
    # the optional fields (T_links, jacobian) only when every chunk has them
    return type(first)(**{f.name: None if any(getattr(p, f.name) is None for p in parts)
                          else np.concatenate([getattr(p, f.name) for p in parts])
                          for f in fields(first)})


def run(scenario: Scenario, progress: bool | None = None) -> Report:
    """Solve the loop closure along the scenario's motion.

    Returns the report: summary (status per step, closure statistics, final pose), expect
    results and the motion record for CSV, plots and MCAP.
    """
    mech = load_mechanism(scenario.mechanism_path)
    t, qv, qd_v, qdd_v = independent_motion_rates(scenario, mech)
    _check_steps(scenario, mech, len(t))
    base = base_trajectory(scenario, mech, t)  # kim1995 §5.1 Step 1 T_0(t); bad input first
    q_w0 = initial_dependent(scenario, mech)
    assembly_configs(scenario, mech)  # bad input before any work
    tol = scenario.section.tolerances
    t0 = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = _solve_in_chunks(mech, qv, q_w0, tol, progress,
                               guess=bool(scenario.section.initial_guess))
        if len(res.q) < len(t):  # stopped by --max-time: the finished steps only
            k = len(res.q)
            budget.note_done(k, len(t), "steps")
            t, qv, qd_v, qdd_v = t[:k], qv[:k], qd_v[:k], qdd_v[:k]
            base = base_trajectory(scenario, mech, t)
        res = with_limits(mech, _finite_closure(mech, res, q_w0))
        solve_s = time.perf_counter() - t0
        kin = forward_kinematics(mech, res.q)
        phi = closure_residual(mech, kin)
        phin = np.linalg.norm(phi, axis=1) if phi.shape[1] else np.zeros(len(t))
    # overflow (e.g. legs driven to 1e300 m) is a solver failure, never inf in a file
    phin = np.nan_to_num(phin, nan=np.finfo(float).max, posinf=np.finfo(float).max)
    status, by_status = status_values(res.status, ClosureStatus)
    conv = by_status[ClosureStatus.CONVERGED]
    counts = {s.value: int(by_status[s].sum()) for s in ClosureStatus}
    t1 = time.perf_counter()
    ee = [int(mech.end_effector)] if mech.end_effector is not None else []
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if is_open_chain(mech) and conv.all() and np.isfinite(res.q).all():
            # every step converged by construction: the same numbers from the run's own FK
            md = open_chain_derivatives(mech, kin, qd_v, qdd_v, ee)
        else:
            closed = conv | by_status[ClosureStatus.OUTSIDE_LIMITS]  # assembled: rates exist
            q_ok = np.where(closed[:, None], res.q, np.nan)
            md = motion_derivatives(mech, q_ok, qd_v, qdd_v, frames=ee)
    rates_s = time.perf_counter() - t1
    sing = md.singularity
    if mech.is_closed and len(mech.dependent):  # a change point stepped over: flagged too
        sing = mark_crossings(sing, constraint_crossings(
            mech, res.q, conv | by_status[ClosureStatus.OUTSIDE_LIMITS], sing))
    n_ok = int(conv.sum())
    overall = "ok" if n_ok == len(t) else next(
        s for s in ("constraint singularity", "singular", "outside limits", "not converged")
        if counts.get(s))
    lim_lo = res.q < mech.lower - 1e-9
    lim_hi = res.q > mech.upper + 1e-9
    outside = sorted({mech.joint_names[j] for j in np.flatnonzero((lim_lo | lim_hi).any(0))})
    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "fk",
        "mechanism": mech.name,
        "status": overall,
        "n_steps": len(t),
        "steps": {s: counts.get(s, 0) for s in ("converged", "not converged", "singular",
                                                 "constraint singularity", "outside limits")},
        "first_failure_step": None if n_ok == len(t) else int(np.flatnonzero(~conv)[0]),
        "closure": {
            "n_cuts": mech.n_cuts,
            "n_equations": mech.n_equations,
            "max_residual": float(phin.max(initial=0.0)),
            "iterations_mean": float(res.iterations.mean()) if len(t) else 0.0,
            "iterations_max": int(res.iterations.max(initial=0)),
            "max_condition": float(np.max(res.cond[np.isfinite(res.cond)], initial=1.0)),
        },
        "singularity": singularity_summary(sing, t),
        "joints_outside_limits": outside,
        # closed chains: the first sample reached from the home assembly by continuation, or
        # by Newton from fk.initial_guess (mechkin.model.continuation.solve_motion)
        "assembly_start": (None if not (mech.is_closed and len(mech.dependent)) else
                           "initial_guess" if scenario.section.initial_guess else "home"),
        "solve_time_s": solve_s,
        "rates_time_s": rates_s,
        "time_per_step_s": solve_s / max(len(t), 1),
        "t_s": [float(t[0]), float(t[-1])],
        "final": {"q": {n: float(v) for n, v in zip(mech.joint_names, res.q[-1], strict=False)}},
    }
    if mech.end_effector is not None:
        T_e = kin.frames(mech, [mech.end_effector])[:, 0]
        summary["final"]["end_effector"] = {
            "frame": mech.frame_names[mech.end_effector],
            "xyz_m": T_e[-1, :3, 3].tolist(),
            "R": T_e[-1, :3, :3].tolist(),
        }
    if scenario.section.assembly == "all":
        summary.update(assembly_summary(scenario, mech, qv, q_w0, res.q[0] if len(t) else None))
    base_into_summary(base, summary)
    checks = with_expect(summary, scenario)
    extra = rate_columns(mech, md, ee)
    extra.update(singularity_columns(sing))
    state = None
    if scenario.spec.outputs.mcap:  # /mechkin/state messages: only for an MCAP
        state = [{"singularity": lab, "cond_constraint": cc, "cond_reduced": cr}
                 for lab, cc, cr in zip(extra["singularity"],
                                        extra["cond_constraint"].tolist(),
                                        extra["cond_reduced"].tolist(), strict=True)]
    rec = motion_record(scenario=scenario, mech=mech, kin=kin, times=t, step_status=status,
                        residual=phin, task="fk", extra_columns=extra, extra_state=state)
    rec.table = scenario.spec.outputs.table
    rec.qd = np.nan_to_num(md.qd, nan=0.0)
    if base is not None:
        base_into_record(base, rec, T_e=kin.frames(mech, ee)[:, 0] if ee else None,
                         twist=md.twists[:, 0] if ee else None,
                         accel=md.accelerations[:, 0] if ee else None)
    return Report(task="fk", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=overall == "ok", writer="motion", data=rec,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=singularity_messages(summary["singularity"], scenario.path)
                  + expect_messages(checks, scenario.path))


def _modes_record(mech: Mechanism, modes: Any) -> list[dict[str, Any]]:
    e = mech.end_effector
    T_e = (forward_kinematics(mech, modes.q).frames(mech, [e])[:, 0] if e is not None
           and modes.count else None)
    out = []
    for k in range(modes.count):
        rec: dict[str, Any] = {
            "q": {n: float(v) for n, v in zip(mech.joint_names, modes.q[k], strict=True)},
            "q_w": {n: float(modes.q[k, j]) for n, j in zip(mech.dependent_names,
                                                            mech.dependent, strict=True)},
            "residual": float(modes.residual[k]),
            "distance_from_guess": float(modes.distance[k]),
            "within_limits": bool(modes.within_limits[k]),
        }
        if T_e is not None:
            rec["end_effector"] = {"xyz_m": T_e[k, :3, 3].tolist(), "R": T_e[k, :3, :3].tolist()}
        out.append(rec)
    return out


def assembly_summary(sc: Scenario, mech: Mechanism, qv: np.ndarray, q_w0: np.ndarray,
                     q_first: np.ndarray | None) -> dict[str, Any]:
    """``assembly: all``: every assembly mode at the first configuration of the motion (and
    at ``assembly_at``), and the mode the motion follows."""
    from mechkin.solvers.assembly import assembly_modes, mode_of

    spec: FkSpec = sc.section
    out: dict[str, Any] = {}
    if len(qv):
        modes = assembly_modes(mech, qv[0], q_w0=q_w0, starts=spec.assembly_starts)
        followed = (mode_of(mech, modes, q_first) if q_first is not None
                    and np.all(np.isfinite(q_first)) else None)
        out.update({"assembly_modes": _modes_record(mech, modes),
                    "n_assembly_modes": modes.count, "assembly_mode_followed": followed,
                    "assembly_mode_from_home": modes.from_home,
                    "n_assembly_modes_within_limits": int(modes.within_limits.sum()),
                    "assembly_search": {"starts": modes.starts, "converged": modes.converged,
                                        "time_s": modes.time_s}})
    at = []
    for q in assembly_configs(sc, mech):
        modes = assembly_modes(mech, q, q_w0=q_w0, starts=spec.assembly_starts)
        at.append({"q_v": {n: float(v) for n, v in zip(mech.independent_names, q, strict=True)},
                   "n_assembly_modes": modes.count,
                   "n_assembly_modes_within_limits": int(modes.within_limits.sum()),
                   "assembly_mode_from_home": modes.from_home,
                   "assembly_modes": _modes_record(mech, modes)})
    if at:
        out["assembly_at"] = at
    return out


def assembly_configs(sc: Scenario, mech: Mechanism) -> list[np.ndarray]:
    """The ``assembly_at`` configurations (n_v,) in SI; an unknown or missing joint is bad
    input."""
    names = mech.independent_names
    problems = []
    for i, cfg in enumerate(sc.section.assembly_at or []):
        bad = [k for k in cfg if k not in names]
        miss = [k for k in names if k not in cfg]
        problems += [f"{sc.doc.where(('fk', 'assembly_at', i, k))}: not an independent "
                     f"joint (independent: {', '.join(names)})" for k in bad]
        if miss:
            problems.append(f"{sc.doc.where(('fk', 'assembly_at', i))}: missing "
                            f"independent joint(s) {', '.join(miss)}")
    if problems:
        raise ConfigError(problems)
    return [np.array([cfg[n] * joint_factor(mech, mech.independent[k], sc.spec.units)
                      for k, n in enumerate(names)]) for cfg in sc.section.assembly_at or []]


def _finite_closure(mech: Mechanism, res: Any, q_w0: np.ndarray) -> Any:
    """Steps whose closure overflowed or produced non-finite joints: dependent joints back at
    the first guess, status ``not converged`` (a solver failure the summary reports)."""
    bad = ~np.all(np.isfinite(res.q), axis=1) | ~np.isfinite(res.residual)
    if not bad.any():
        return res
    from dataclasses import replace

    q = res.q.copy()
    q[np.ix_(bad, mech.dependent)] = q_w0
    status = res.status.copy()
    status[bad] = ClosureStatus.NOT_CONVERGED
    return replace(res, q=np.nan_to_num(q, nan=0.0, posinf=np.finfo(float).max,
                                        neginf=-np.finfo(float).max), status=status)


def _finite(x: float) -> float:
    """A condition number for CSV/JSON: inf (rank lost) and nan (undefined) as -1."""
    v = float(x)  # float compare (False for nan, inf): ~10x cheaper than scalar np.isfinite
    return v if abs(v) < _INF else -1.0


_INF = float("inf")


def rate_columns(mech: Mechanism, md: Any, ee: list[int]) -> dict[str, np.ndarray]:
    """``<joint>_rad_s``, ``<joint>_rad_s2`` (``_m_s``, ``_m_s2``) for every joint, and the
    end-effector twist (angular velocity, origin velocity; base frame) and acceleration."""
    cols: dict[str, np.ndarray] = {}
    qd = np.nan_to_num(md.qd, nan=0.0)
    qdd = np.nan_to_num(md.qdd, nan=0.0)
    for j, name in enumerate(mech.joint_names):
        u = mech.joint_unit(j)
        cols[f"{name}_{u}_s"] = qd[:, j]
    for j, name in enumerate(mech.joint_names):
        u = mech.joint_unit(j)
        cols[f"{name}_{u}_s2"] = qdd[:, j]
    if ee:
        tw = np.nan_to_num(md.twists[:, 0], nan=0.0)
        ac = np.nan_to_num(md.accelerations[:, 0], nan=0.0)
        for k, ax in enumerate("xyz"):
            cols[f"ee_w{ax}_rad_s"] = tw[:, k]
        for k, ax in enumerate("xyz"):
            cols[f"ee_v{ax}_m_s"] = tw[:, 3 + k]
        for k, ax in enumerate("xyz"):
            cols[f"ee_alpha{ax}_rad_s2"] = ac[:, k]
        for k, ax in enumerate("xyz"):
            cols[f"ee_a{ax}_m_s2"] = ac[:, 3 + k]
    return cols

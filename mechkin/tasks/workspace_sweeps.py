"""The workspace task's sweeps: ``task_space`` (batched ik over poses) and ``joint_sweep``.

``task_space``: a grid (or seeded random set) of task-space poses through the batched ik
(:func:`mechkin.solvers.workspace.sweeps.task_space_sweep`); ``joint_sweep``: the independent
joints on a grid or at random, the loop closure continued from a solved neighbour
(:func:`mechkin.solvers.workspace.joint_sweep.joint_sweep`). Split out of ``workspace.py``
(issue 23: modules that fit in a head).

Imports: config, model, solvers, records, tasks.workspace_common (never io/ or cli/).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.records import Report
from mechkin.records.workspace import WorkspaceOutput
from mechkin.tasks import budget
from mechkin.tasks.workspace_common import (
    MAX_SWEEP_SAMPLES,
    NORMALIZED_DEFINITION,
    _char_length,
    _char_length_entry,
    _head,
    _joint_columns,
    _listed_poses,
    _progress_bar,
    _report,
    _sweep_frame,
)

# --------------------------------------------------------------------------- task space


def _task_poses(sc: Scenario) -> np.ndarray:
    """Target poses (m, 4, 4), SI, of a task_space section."""
    from mechkin.solvers.workspace.sweeps import task_space_grid, task_space_random
    from mechkin.spatial.euler_conventions import euler_matrix
    from mechkin.spatial.rotations import matrix_from_quat

    spec = sc.section
    L = length_factor(sc.spec.units.length)
    A = angle_factor(sc.spec.units.angle)
    o = spec.orientation
    R0: np.ndarray | None = np.eye(3)
    if o is not None and o.euler is not None:
        R0 = euler_matrix(o.euler.convention, np.asarray(o.euler.angles, dtype=float) * A)
    elif o is not None and o.quaternion is not None:
        R0 = matrix_from_quat(np.asarray(o.quaternion, dtype=float))
    elif o is not None and o.random:
        R0 = None
    listed = _listed_poses(sc, ("x", "y", "z"), ("qw", "qx", "qy", "qz"))
    if listed is not None:
        T = np.tile(np.eye(4), (listed.shape[0], 1, 1))
        T[:, :3, 3] = listed[:, :3] * L
        if listed.shape[1] == 7:
            T[:, :3, :3] = matrix_from_quat(listed[:, 3:7])
        else:
            assert R0 is not None
            T[:, :3, :3] = R0
        return T
    axes = [spec.positions[k] for k in "xyz"]
    if spec.method == "grid":
        vals = []
        for a in axes:
            if a.value is not None:
                vals.append(np.array([a.value * L]))
            elif a.n == 1:
                vals.append(np.array([0.5 * (a.range[0] + a.range[1]) * L]))
            else:
                vals.append(np.linspace(a.range[0] * L, a.range[1] * L, a.n))
        total = int(np.prod([v.size for v in vals]))
        if total > MAX_SWEEP_SAMPLES:
            raise ConfigError(f"{sc.doc.where(('workspace', 'positions'))}: the grid has "
                              f"{total} poses, more than {MAX_SWEEP_SAMPLES}")
        assert R0 is not None
        return task_space_grid(vals, R0)
    box = [(a.value * L, a.value * L) if a.value is not None else
           (a.range[0] * L, a.range[1] * L) for a in axes]
    return task_space_random(box, spec.samples, spec.seed, R0)


def _run_task_space(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.model import load_mechanism
    from mechkin.solvers.workspace.sweeps import task_space_summary, task_space_sweep

    spec = sc.section
    if sc.mechanism_path is None:
        raise ConfigError(f"{sc.doc.where(('mechanism',))}: a task_space sweep needs a mechanism")
    mech = load_mechanism(sc.mechanism_path)
    f = _sweep_frame(sc, mech)
    T_P = _task_poses(sc)
    t0 = time.perf_counter()
    n_jobs = max(1, -(-T_P.shape[0] // spec.chunk))
    with _progress_bar(ex, f"{sc.name}: ik chunks", deadline=False) as cb:
        rec = task_space_sweep(sc.mechanism_path, T_P, frame=f, weights=spec.weights,
                               restarts=spec.restarts, seed=spec.seed, max_iter=spec.max_iter,
                               chunk=spec.chunk, workers=ex["workers"], address=ex["address"],
                               progress=cb, length=_char_length(sc), stop=_stop())
    if len(rec.reachable) < T_P.shape[0]:  # stopped by --max-time: the finished chunks
        budget.note_done(len(rec.reachable), T_P.shape[0], "poses")
    summary: dict[str, Any] = {
        **_head(sc, "task_space"),
        "mechanism": mech.name,
        "method": spec.method or "poses",
        "seed": spec.seed,
        "frame": mech.frame_names[f],
        "restarts": spec.restarts,
        **task_space_summary(rec),
        "definition": {
            "reachable": "the batched lm ik (with seeded random restarts) reaches the pose: "
                         "verified errors below 1e-6 m / 1e-6 rad with the joints within "
                         "limits; a lower bound of the reachable set",
            "isotropy": "sigma_min / sigma_max of the frame Jacobian (rows omega, v; SI) "
                        "w.r.t. the independent joints at the solution (closed chains: "
                        "J_v + J_w dq_w/dq_v); 0 at singular or unreached poses",
            "isotropy_position": "the same for the position rows",
            "condition_number": "sigma_max / sigma_min (1/isotropy), capped at 1e16",
            "manipulability": "Yoshikawa w = product of the singular values of that Jacobian",
            "isotropy_normalized": NORMALIZED_DEFINITION,
        },
        "characteristic_length": _char_length_entry(sc, rec.characteristic_length),
        "execution": {"executor": "dask" if ex["address"] else "process", "jobs": n_jobs,
                      "chunk": spec.chunk},
        "compute_time_s": time.perf_counter() - t0,
    }
    title = (f"{mech.name}: task-space sweep of {mech.frame_names[f]} "
             f"({int(rec.reachable.sum())}/{rec.reachable.size} poses reached, "
             f"{spec.method or 'listed poses'})")
    return _report(sc, summary, WorkspaceOutput("task_space", rec, title=title,
                                                joint_columns=_joint_columns(mech),
                                                robot=_snapshot(sc, mech)))


# --------------------------------------------------------------------------- joint sweep


def _sweep_values(sc: Scenario, mech: Any) -> tuple[np.ndarray, list[str]]:
    """Independent joint values (m, n_v) in SI and the names of the swept joints."""
    spec = sc.section
    doc = sc.doc
    names = mech.independent_names
    given = spec.joints or {}
    problems = [f"{doc.where(('workspace', 'joints', k))}: not an independent joint "
                f"(independent: {', '.join(names)})" for k in given if k not in names]
    if problems:
        raise ConfigError(problems)
    # a grid sweeps the joints given with n; monte_carlo sweeps every independent joint (a range
    # given for some keeps the others at their limits, or a full turn if they have none)
    swept = [n for n in names if n in given] if spec.method == "grid" else list(names)
    if not swept:
        raise ConfigError(f"{doc.where(('workspace', 'joints'))}: method grid needs at least "
                          "one joint with n")
    home = mech.home[mech.independent]
    ranges: dict[str, tuple[float, float]] = {}
    for name in swept:
        j = mech.joint_index(name)
        f = length_factor(sc.spec.units.length) if mech.s[j] == 1 else angle_factor(
            sc.spec.units.angle)
        js = given.get(name)
        if js is not None and js.range is not None:
            lo, hi = js.range[0] * f, js.range[1] * f
        else:
            lo, hi = float(mech.lower[j]), float(mech.upper[j])
            if not (math.isfinite(lo) and math.isfinite(hi)) and mech.s[j] == 0:
                lo, hi = -math.pi, math.pi  # a revolute joint without limits: a full turn
            elif not (math.isfinite(lo) and math.isfinite(hi)):
                problems.append(f"{doc.where(('workspace', 'joints', name))}: joint {name!r} "
                                "has no limits; give a range, e.g. "
                                f"'{name}: {{range: [0, 100]}}' (file length unit)")
        ranges[name] = (lo, hi)
        if spec.method == "grid" and (js is None or js.n is None):
            problems.append(f"{doc.where(('workspace', 'joints', name))}: method grid needs n")
    if problems:
        raise ConfigError(problems)
    if spec.method == "grid":
        counts = [given[n].n for n in swept]
        total = int(np.prod(counts, dtype=np.float64))
        if total > MAX_SWEEP_SAMPLES:
            raise ConfigError(f"{doc.where(('workspace', 'joints'))}: the grid has {total} "
                              f"samples, more than {MAX_SWEEP_SAMPLES}")
        axes = [np.linspace(*ranges[n], c) for n, c in zip(swept, counts, strict=True)]
        mesh = np.meshgrid(*axes, indexing="ij")
        qv = np.tile(home, (total, 1))
        for n, g in zip(swept, mesh, strict=True):
            qv[:, names.index(n)] = g.ravel()
    else:
        rng = np.random.default_rng(spec.seed)
        qv = np.tile(home, (spec.samples, 1))
        for n in swept:
            qv[:, names.index(n)] = rng.uniform(*ranges[n], size=spec.samples)
    return qv, swept


def _run_joint_sweep(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.model import load_mechanism
    from mechkin.solvers.workspace.joint_sweep import joint_sweep, point_cloud_volume
    from mechkin.solvers.workspace.maps import sigma_statistics

    spec = sc.section
    if sc.mechanism_path is None:
        raise ConfigError(f"{sc.doc.where(('mechanism',))}: a joint_sweep needs a mechanism")
    mech = load_mechanism(sc.mechanism_path)
    f = _sweep_frame(sc, mech)
    qv, swept = _sweep_values(sc, mech)
    m = qv.shape[0]
    L = length_factor(sc.spec.units.length)
    t0 = time.perf_counter()
    closed = mech.is_closed and len(mech.dependent) > 0
    grid_shape = tuple(spec.joints[n].n for n in swept) if spec.method == "grid" else None
    split = ex["ex"].split
    jobs_kw: dict[str, Any] = {}
    if split:  # jobs of samples / continuation subtrees (mechkin.solvers.workspace.joint_sweep)
        from mechkin.solvers.workspace.sweeps import mechanism_spec, run_jobs

        n_w = ex["workers"] if ex["address"] is None else None
        jobs_kw = {"run_jobs": lambda fn, jobs, prog: run_jobs(
                       fn, jobs, workers=n_w, address=ex["address"], progress=prog),
                   "n_jobs": 4 * (n_w or 4), "mechanism": mechanism_spec(sc.mechanism_path)}
    with _progress_bar(ex, f"{sc.name}: {'jobs' if split else 'samples'}",
                       deadline=split) as cb:
        rec = joint_sweep(mech, qv, f, chunk=spec.chunk, manipulability=spec.manipulability,
                          grid_shape=grid_shape, seed_from=spec.seed_from,
                          mode_jump=spec.mode_jump, progress=cb, length=_char_length(sc),
                          stop=None if split else _stop(), **jobs_kw)
    if len(rec.reachable) < m:  # stopped by --max-time: the evaluated samples
        budget.note_done(len(rec.reachable), m, "samples")
        qv, m, grid_shape = qv[:len(rec.reachable)], len(rec.reachable), None
    reach = rec.reachable
    elapsed = time.perf_counter() - t0
    bbox, volume = point_cloud_volume(rec.position[reach],
                                      spec.voxel * L if spec.voxel is not None else None)
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "task": "workspace",
        "kind": "joint_sweep",
        "mechanism": mech.name,
        "status": "ok",
        "method": spec.method,
        "seed": spec.seed if spec.method == "monte_carlo" else None,
        "swept_joints": swept,
        "full_turn_joints": [n for n in swept if mech.s[mech.joint_index(n)] == 0 and not (
            spec.joints and n in spec.joints and spec.joints[n].range is not None) and not (
            np.isfinite(mech.lower[mech.joint_index(n)])
            and np.isfinite(mech.upper[mech.joint_index(n)]))],
        "frame": mech.frame_names[f],
        "closed_chain": bool(closed),
        "n_samples": int(m),
        "n_reachable": int(reach.sum()),
        "reachable_fraction": float(reach.mean()) if m else 0.0,
        "n_not_converged": int((~rec.converged).sum()),
        "n_outside_limits": int((rec.converged & ~rec.within_limits).sum()),
        "continuation": {
            "seed_from": spec.seed_from if closed else None,
            "mode_jump": spec.mode_jump,
            "n_roots": int((rec.seed < 0).sum()) if closed else 0,
            "n_mode_changes": int(rec.mode_change.sum()),
            "n_closure_failures": int((~rec.converged).sum()),
            "n_reseeded_from_home": int(rec.reseeded.sum()),
            "n_constraint_singularities_crossed": int(rec.crossed.sum()),
        },
        "bounding_box": bbox,
        "volume": volume,
        "definition": {
            "reachable": "loop closure converged (closed chains) and every joint within limits",
            "full_turn_joints": "revolute joints without limits (and no range given), swept "
                                "over a full turn [-pi, pi]",
            "continuation": "closed chains: each sample's loop closure starts from a solved "
                            "neighbour (grid step / nearest neighbour, first-order predictor), "
                            "else from home; mode_change: the dependent joints left that "
                            "predictor by more than mode_jump x the step of the independent "
                            "joints (max norms, SI), i.e. another assembly mode, or the "
                            "sign of det(dphi/dq_w) changed; "
                            "n_constraint_singularities_crossed: sign changes where the joints "
                            "followed the predictor (one smooth branch through a change point)",
            "manipulability": "Yoshikawa w = product of the singular values of the frame "
                              "Jacobian (rows omega, v; SI) w.r.t. the independent joints "
                              "(closed chains: J_v + J_w dq_w/dq_v)",
            "isotropy": "sigma_min / sigma_max of that Jacobian (position rows only for "
                        "isotropy_position); 0 at singular poses",
            "isotropy_normalized": NORMALIZED_DEFINITION,
            "volume": "voxel_m3: occupied cubes of edge voxel_edge_m; convex_hull_m3: hull of "
                      "the reachable points (an upper bound for non-convex workspaces)",
        },
        "compute_time_s": elapsed,
    }
    if split:
        summary["execution"] = ex["ex"].describe(jobs_kw["n_jobs"])
    if spec.manipulability:
        summary["manipulability"] = sigma_statistics(rec.manipulability[reach])
        summary["isotropy"] = sigma_statistics(rec.isotropy[reach])
        summary["isotropy_position"] = sigma_statistics(rec.isotropy_position[reach])
        summary["isotropy_normalized"] = sigma_statistics(rec.isotropy_normalized[reach])
        summary["characteristic_length"] = _char_length_entry(sc, rec.characteristic_length)
    sl = spec.slices
    slices = None if sl is None else {
        "axis": sl.axis, "at": [v * L for v in sl.at] if sl.at else None,
        "thickness": sl.thickness * L if sl.thickness else None}
    title = (f"{mech.name}: reachable positions of {mech.frame_names[f]} "
             f"({reach.sum()}/{m} samples, {spec.method})")
    return _report(sc, summary, WorkspaceOutput("joint_sweep", rec, title=title,
                                                joint_columns=_joint_columns(mech),
                                                slices=slices, robot=_snapshot(sc, mech)))


def _stop() -> Any:
    """The sweep's stop hook under ``--max-time`` (keep the finished chunks), else None."""
    return budget.overrun if budget.time_limit() is not None else None


def _snapshot(sc: Scenario, mech: Any) -> Any:
    """The robot at home for workspace.mcap (None when no MCAP is asked)."""
    from mechkin.tasks.robot import robot_snapshot

    return robot_snapshot(mech) if sc.spec.outputs.mcap else None

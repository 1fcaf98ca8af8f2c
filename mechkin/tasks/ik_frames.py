"""``mechkin ik`` of target sets: targets that name their frame (``frame: left_foot``) are
solved together, one set at a time (:mod:`mechkin.solvers.ik.multi_frame`), each set
warm-started from the previous answer (``warm_start``), every frame verified by forward
kinematics. Called by :func:`mechkin.tasks.ik.run` when the ``ik:`` section has
``target_sets`` or framed ``targets``.

A floating base's ``base_pose`` (the section's, or a set's own): ``free`` (the six base joints
are unknowns) or a known pose held while the rest is solved; each set's summary record says
which (``base_pose``: ``free`` or ``{xyz_m, rpy_rad}``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from mechkin.config.ik_spec import IkSpec, TargetSpec, target_matrix
from mechkin.config.scenario import Scenario
from mechkin.config.schema import FLOATING_JOINTS
from mechkin.errors import ConfigError
from mechkin.model import Mechanism
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.records import Report
from mechkin.solvers.ik.multi_frame import FrameTarget, solve_multi_frame
from mechkin.tasks.common import (
    expect_messages,
    motion_record,
    output_flags,
    with_expect,
)
from mechkin.tasks.fk_base import base_pose_joints, no_floating_base


def has_target_sets(spec: IkSpec) -> bool:
    """Whether the section's targets name their frames (one set) or it has target_sets."""
    return bool(spec.target_sets) or any(t.frame is not None for t in spec.targets)


def _held_base(sc: Scenario, mech: Mechanism, pose: Any, key: tuple
               ) -> tuple[dict[int, float], Any, list[str]]:
    """A set's ``base_pose``: the held independent joints (index -> value [SI]), the summary's
    record of it (``free`` or ``{xyz_m, rpy_rad}``) and the problems (a base pose for a
    mechanism without a floating base)."""
    if pose == "free":
        return {}, "free", []
    if not mech.floating:
        return {}, None, [no_floating_base(sc, mech, key, "remove it (the targets are in "
                                           "the frame of the fixed base)")]
    values = base_pose_joints(pose, sc.spec.units)
    held = {i: values[n] for i, n in enumerate(mech.independent_names) if n in values}
    rec = {"xyz_m": [values[n] for n in FLOATING_JOINTS[:3]],
           "rpy_rad": [values["base_roll"], values["base_pitch"], values["base_yaw"]]}
    return held, rec, []


def _sets(sc: Scenario, mech: Mechanism
          ) -> list[tuple[str, list[FrameTarget], dict[int, float], Any]]:
    spec: IkSpec = sc.section
    raw: list[tuple[str, list[TargetSpec], tuple, Any, tuple]] = (
        [(s.name or f"S{i + 1}", s.targets, ("ik", "target_sets", i, "targets"),
          spec.base_pose if s.base_pose is None else s.base_pose,
          ("ik", "target_sets", i, "base_pose") if s.base_pose is not None
          else ("ik", "base_pose"))
         for i, s in enumerate(spec.target_sets)]
        if spec.target_sets else
        [("S1", spec.targets, ("ik", "targets"), spec.base_pose, ("ik", "base_pose"))])
    problems, out = [], []
    for name, targets, kp, pose, pkey in raw:
        held, base_rec, bad = _held_base(sc, mech, pose, pkey)
        if bad and bad[0] not in problems:
            problems += bad
        ft = []
        for k, t in enumerate(targets):
            if t.frame not in mech.frame_names:
                problems.append(f"{sc.doc.where(kp + (k, 'frame'))}: unknown frame "
                                f"{t.frame!r} (frames of {mech.name}: "
                                f"{', '.join(mech.frame_names[:12])}"
                                f"{', ...' if len(mech.frame_names) > 12 else ''})")
                continue
            w = np.asarray(t.weights if t.weights is not None else spec.weights, dtype=float)
            ft.append(FrameTarget(t.frame, target_matrix(t, sc.spec.units), w))
        out.append((name, ft, held, base_rec))
    if problems:
        raise ConfigError(problems)
    return out


def target_set_problems(sc: Scenario, mech: Mechanism) -> list[str]:
    """What the target sets of ``sc`` refuse before solving (unknown frames, a base pose
    without a floating base): ``mechkin check`` says the same as the run."""
    try:
        _sets(sc, mech)
    except ConfigError as exc:
        return list(exc.problems)
    return []


def run_target_sets(scenario: Scenario, mech: Mechanism, qv0: np.ndarray, qw0: np.ndarray,
                    tol_pos: float, tol_ori: float) -> Report:
    """Solve every target set in order; the report's summary has one record per set with the
    per-frame verified errors."""
    spec: IkSpec = scenario.section
    sets = _sets(scenario, mech)
    t0 = time.perf_counter()
    results = []
    qv, qw = qv0, qw0
    for _, targets, held, _ in sets:
        r = solve_multi_frame(mech, targets, q_v0=qv, q_w0=qw, tol_pos=tol_pos,
                              tol_ori=tol_ori, restarts=max(spec.restarts, 0),
                              seed=spec.seed, held=held)
        results.append(r)
        if spec.warm_start and r.ok:
            qv, qw = r.q_v, r.q_w
    solve_s = time.perf_counter() - t0
    q = np.array([r.q for r in results])
    kin = forward_kinematics(mech, q)
    phi = closure_residual(mech, kin)
    phin = np.linalg.norm(phi, axis=1) if phi.shape[1] else np.zeros(len(q))
    status = [r.status.value for r in results]
    records = []
    for (name, targets, _, base_rec), r in zip(sets, results, strict=True):
        records.append({
            "name": name,
            "status": r.status.value,
            **({"base_pose": base_rec} if mech.floating else {}),
            "q": {n: float(v) for n, v in zip(mech.joint_names, r.q, strict=True)},
            "frames": {t.frame: {"position_error": float(pe), "orientation_error": float(oe),
                                 "weights": t.weights.tolist(),
                                 "target": {"xyz_m": t.T[:3, 3].tolist(),
                                            "R": t.T[:3, :3].tolist()}}
                       for t, pe, oe in zip(targets, r.position_error, r.orientation_error,
                                            strict=True)},
            "closure_residual": float(r.closure_residual),
            "iterations": int(r.iterations),
            "restarts_used": int(r.restarts_used),
            "time_s": float(r.time_s),
        })
    pe_all = np.concatenate([r.position_error for r in results])
    oe_all = np.concatenate([r.orientation_error for r in results])
    overall = "ok" if all(s == "ok" for s in status) else next(s for s in status if s != "ok")
    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "ik",
        "mechanism": mech.name,
        "method": "lm (target sets: mechkin.solvers.ik.multi_frame)",
        "status": overall,
        "n_target_sets": len(results),
        "counts": {s: status.count(s) for s in dict.fromkeys(status)},
        "max_position_error": float(pe_all.max(initial=0.0)),
        "max_orientation_error": float(oe_all.max(initial=0.0)),
        "solve_time_s": solve_s,
        "floating_base": bool(mech.floating),
        "target_sets": records,
    }
    checks = with_expect(summary, scenario)
    m = len(results)
    labels = [s[0] for s in sets]
    snaps = list(range(m)) if m <= 8 else list(np.linspace(0, m - 1, 8).round().astype(int))
    rec = motion_record(
        scenario=scenario, mech=mech, kin=kin, times=np.arange(m, dtype=float),
        step_status=status, residual=phin, task="ik",
        extra_columns={"target_set": labels,
                       "max_position_error_m": [float(r.position_error.max()) for r in results],
                       "max_orientation_error_rad": [float(r.orientation_error.max())
                                                     for r in results]},
        extra_state=[{"target_set": labels[i]} for i in range(m)],
        snapshots=snaps, snapshot_labels=[labels[k] for k in snaps])
    return Report(task="ik", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=overall == "ok", writer="motion", data=rec,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=expect_messages(checks, scenario.path))

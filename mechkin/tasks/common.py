"""Pieces every task shares: scenario loading, unit factors, ``expect:`` checks, motion records.

Imports: config, model, spatial, records (never io/ or cli/).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mechkin.records import MotionRecord, OutputFlags

UNIT_TO_SI = {"rad": 1.0, "deg": np.pi / 180.0, "m": 1.0, "mm": 1e-3, "s": 1.0, "1": 1.0}


def load_task_scenario(path: str | Path, task: str) -> Any:
    """Load a scenario for ``mechkin <task>``; a scenario of another task is bad input."""
    from mechkin.config.scenario import load_scenario
    from mechkin.errors import ConfigError

    sc = load_scenario(Path(path))
    if sc.spec.task != task:
        raise ConfigError(f"{sc.doc.where(('task',))}: expected task {task} for 'mechkin "
                          f"{task}', got {sc.spec.task} (use 'mechkin {sc.spec.task}')")
    return sc


def output_flags(scenario: Any) -> OutputFlags:
    o = scenario.spec.outputs
    return OutputFlags(csv=bool(o.csv), plots=bool(o.plots), mcap=bool(o.mcap),
                       table=str(getattr(o, "table", "csv")))


def joint_factor(mech: Any, j: int, units: Any) -> float:
    """SI factor of joint j's values in a file's units: length for prismatic, angle for
    revolute joints."""
    from mechkin.config.units import angle_factor, length_factor

    return length_factor(units.length) if mech.s[j] == 1 else angle_factor(units.angle)


def lookup(obj: Any, key: str) -> Any:
    """Value at a dot path (``targets.0.q_v.q1``) of nested dicts and lists; KeyError if absent."""
    cur = obj
    for part in key.split("."):
        if isinstance(cur, dict):
            if part not in cur:
                raise KeyError(part)
            cur = cur[part]
        elif isinstance(cur, (list, tuple)):
            try:
                cur = cur[int(part)]
            except (ValueError, IndexError):
                raise KeyError(part) from None
        else:
            raise KeyError(part)
    return cur


def evaluate_expect(summary: dict[str, Any], expects: list[Any]) -> list[dict[str, Any]]:
    """Check each ``expect:`` entry against the summary; values compared in SI."""
    out = []
    for e in expects:
        if isinstance(e.value, str):  # a status word: {key: status, value: unreachable}
            out.append(_status_check(summary, e))
            continue
        f = UNIT_TO_SI[e.unit] if e.unit else 1.0
        rec: dict[str, Any] = {"key": e.key, "unit": e.unit or "SI"}
        if e.value is not None:
            rec.update(expected=e.value, tol=e.tol)
            ref = np.atleast_1d(np.asarray(e.value, dtype=float)) * f
            lo, hi = ref - e.tol * f, ref + e.tol * f
        else:
            rec.update(min=e.min, max=e.max)
            lo = np.atleast_1d(-np.inf if e.min is None else e.min * f)
            hi = np.atleast_1d(np.inf if e.max is None else e.max * f)
            ref = None
        if e.source:
            rec["source"] = e.source
        try:
            actual = lookup(summary, e.key)
            if actual is None:
                raise KeyError(e.key)
            act = np.atleast_1d(np.asarray(actual, dtype=float))
            if not np.all(np.isfinite(act)):
                raise ValueError(e.key)
            if ref is not None and act.shape != ref.shape:
                rec.update(ok=False, actual=actual, message=f"shape {act.shape} != {ref.shape}")
            else:
                ok = bool(np.all(np.isfinite(act)) and np.all(act >= lo) and np.all(act <= hi))
                shown = (act / f).tolist()
                rec.update(ok=ok, actual=shown[0] if len(shown) == 1 else shown)
                if ref is not None:
                    rec["error"] = float(np.max(np.abs(act - ref))) / f if act.size else 0.0
        except (KeyError, TypeError, ValueError):
            rec.update(ok=False, actual=None,
                       message=f"no finite value at {e.key!r} in the summary")
        out.append(rec)
    return out


def _status_check(summary: dict[str, Any], e: Any) -> dict[str, Any]:
    rec: dict[str, Any] = {"key": e.key, "unit": "word", "expected": e.value, "tol": 0}
    if e.source:
        rec["source"] = e.source
    try:
        actual = lookup(summary, e.key)
    except KeyError:
        actual = None
    if not isinstance(actual, str):
        rec.update(ok=False, actual=actual, message=f"no status at {e.key!r} in the summary")
    else:
        rec.update(ok=actual == e.value, actual=actual)
    return rec


def expect_messages(checks: list[dict[str, Any]], scenario_path: Path | None) -> list[str]:
    """One stderr line per failed ``expect:`` entry."""
    lines = []
    for c in checks:
        if not c["ok"]:
            want = (repr(c["expected"]) if c["unit"] == "word"
                    else f"{c['expected']} +- {c['tol']}" if "expected" in c
                    else f"in [{c.get('min')}, {c.get('max')}]")
            msg = c.get("message") or f"expected {want} ({c['unit']}), got {c['actual']}"
            lines.append(f"{scenario_path}: expect {c['key']}: {msg}")
    return lines


def with_expect(summary: dict[str, Any], scenario: Any) -> list[dict[str, Any]]:
    """Evaluate the scenario's ``expect:`` entries on ``summary`` and store them under
    ``summary["expect"]`` when there are any; return them."""
    checks = evaluate_expect(summary, scenario.spec.expect)
    if checks:
        summary["expect"] = checks
    return checks


def motion_bytes(mech: Any, m: int, scenario: Any) -> float:
    """Estimated peak memory [bytes] of m configurations of ``mech`` with the scenario's
    outputs: joints, link and frame poses, the /tf tree and stick segments, CSV text and MCAP
    messages (a factor 2 for temporaries)."""
    outs = scenario.spec.outputs
    nf = len(mech.frame_names)
    per = 8 * 4 * mech.n + 128 * (mech.n_links + nf) + 8 * 6 * max(mech.n_equations, 0)
    if outs.plots or outs.mcap:
        per += 48 * 3 * (mech.n + nf)            # stick segments
    if outs.mcap:
        per += 128 * nf + 24 * mech.n + 200 * nf  # /tf tree, axis points, encoded messages
    if outs.csv:
        per += 25 * (mech.n + 12)
    return 2.0 * per * m


def check_motion_budget(scenario: Any, mech: Any, m: int, key: tuple[str, ...],
                        what: str, extra_per_item: float = 0.0) -> None:
    """Refuse m configurations beyond the memory budget (before any work); ``extra_per_item``
    adds bytes per configuration (e.g. an ik target's summary record)."""
    from mechkin.tasks import budget

    budget.check(scenario.doc.where(key), motion_bytes(mech, m, scenario) + extra_per_item * m,
                 f"{m} {what} of {mech.name} ({mech.n} joints)")


# ---- the motion record of fk and ik runs -----------------------------------------------------


def joint_columns(mech: Any, q: np.ndarray) -> dict[str, np.ndarray]:
    """CSV columns ``<joint>_rad`` / ``<joint>_m`` for q (m, n)."""
    return {f"{name}_{mech.joint_unit(j)}": q[:, j] for j, name in enumerate(mech.joint_names)}


def pose_columns(T: np.ndarray, prefix: str = "ee_") -> dict[str, np.ndarray]:
    """CSV columns of poses (m, 4, 4): xyz [m] and quaternion (w, x, y, z)."""
    from mechkin.spatial.rotations import quat_from_matrix

    e = quat_from_matrix(T[:, :3, :3])
    return {
        f"{prefix}x_m": T[:, 0, 3], f"{prefix}y_m": T[:, 1, 3], f"{prefix}z_m": T[:, 2, 3],
        f"{prefix}qw": e[:, 0], f"{prefix}qx": e[:, 1], f"{prefix}qy": e[:, 2],
        f"{prefix}qz": e[:, 3],
    }


def snapshot_indices(m: int, k: int) -> list[int]:
    return sorted(set(np.linspace(0, m - 1, min(k, m)).round().astype(int).tolist()))


def motion_record(
    *,
    scenario: Any,
    mech: Any,
    kin: Any,
    times: np.ndarray,
    step_status: list[str],
    residual: np.ndarray,
    task: str,
    extra_columns: dict[str, Any] | None = None,
    extra_state: list[dict[str, Any]] | None = None,
    snapshots: list[int] | None = None,
    snapshot_labels: list[str] | None = None,
) -> MotionRecord:
    """The :class:`MotionRecord` of m configurations ``kin`` (CSV columns ``t_s``, joints,
    end-effector pose, ``closure_residual``, extras, ``status``; stick segments and the /tf
    frame tree only when the scenario asks for plots or an MCAP)."""
    from mechkin.model.drawing import frame_tree, stick_drawing

    outs = scenario.spec.outputs
    m = len(times)
    cols: dict[str, Any] = {"t_s": times}
    cols.update(joint_columns(mech, kin.q))
    if mech.end_effector is not None:
        cols.update(pose_columns(kin.frames(mech, [mech.end_effector])[:, 0]))
    cols["closure_residual"] = residual
    cols.update(extra_columns or {})
    cols["status"] = step_status
    rec = MotionRecord(
        task=task, title=scenario.name, mechanism=mech.name, times=np.asarray(times, float),
        q=kin.q, joint_names=list(mech.joint_names),
        joint_units=[mech.joint_unit(j) for j in range(mech.n)], columns=cols,
        metadata={"scenario": scenario.name, "mechanism": mech.name, "task": task},
    )
    if outs.plots or outs.mcap:
        drawing = stick_drawing(mech, kin)  # links joint to joint, plates as polygons
        rec.segments, rec.plates = drawing.segments, drawing.plates
        idx = snapshots if snapshots is not None else snapshot_indices(
            m, getattr(scenario.section, "snapshots", 4))
        rec.snapshots = list(idx)
        rec.snapshot_labels = snapshot_labels or [f"t = {times[k]:.3g} s" for k in idx]
    if outs.mcap:
        from mechkin.tasks.robot import robot_description

        rec.axis_points = kin.axes()[1]
        rec.frame_root, rec.frame_names, rec.frame_parents, rec.T_parent_child = frame_tree(
            mech, kin)
        rec.robot = robot_description(mech)
        rec.motors = [mech.joint_names[i] for i in mech.independent]
        state = []
        for k in range(m):
            st: dict[str, Any] = {"status": step_status[k],
                                  "closure_residual": float(residual[k])}
            if extra_state is not None:
                st.update(extra_state[k])
            state.append(st)
        rec.state = state
    return rec

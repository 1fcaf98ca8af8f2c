"""Pre-solve validation of a scenario against its mechanism: everything a run checks short of
solving, so ``mechkin check`` says ok only for scenarios the run accepts.

DESIGN
------
:func:`validate_scenario` takes the loaded :class:`~mechkin.config.scenario.Scenario` and the
built :class:`~mechkin.model.Mechanism` (None where the task needs none) and raises one
ConfigError listing every problem (``file:line: key.path: message``). Per task:

* fk: the motion / table / csv names exactly the independent joints; time grid (stop > start, at
  most ``MAX_STEPS`` steps); table columns of one non-zero length, times non-decreasing and
  >= 0; the csv file a regular file; ``initial_guess`` names dependent joints;
* ik: an end effector; closed forms only for their mechanisms; ``initial_guess`` names joints;
  every target gives a finite pose;
* ik with ``biped:``: the mechanism's legs are the hwang2023 closed-form legs;
* track: the dynamics can be built (``rnea`` needs a serial chain with inertial data,
  ``closed_form_2link`` a planar 2R arm); limits one value per joint; the hand frame exists;
  ``ik.initial_guess`` and ``ik.branch`` name joints;
* workspace: joint_sweep joints are independent, have ranges (or limits) and grid sizes within
  ``MAX_SWEEP_SAMPLES``; task_space grids within it; the swept frame exists; lee design strokes
  leave l_min < l_max;
* every ``expect:`` key can exist in the task's summary (:func:`expect_problems`).

The run commands should call :func:`validate_scenario` right after building the mechanism (the
solvers then never see such input).
"""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.config.load import short, short_list, short_str
from mechkin.errors import ConfigError, MechkinError
from mechkin.tasks.budget import MAX_TIME_S

MAX_STEPS = 1_000_000
MAX_SWEEP_SAMPLES = 5_000_000
MAX_CSV_BYTES = 256 * 1024 * 1024


def validate_scenario(sc: Any, mech: Any | None, prepared: Any = None) -> None:
    """Raise ConfigError listing every problem of scenario ``sc`` with mechanism ``mech``;
    what the checks compute that the run needs goes into ``prepared``
    (:class:`mechkin.tasks.prepare.Prepared`) when given."""
    problems = scenario_problems(sc, mech, prepared)
    if problems:
        raise ConfigError(problems)


def scenario_problems(sc: Any, mech: Any | None, prepared: Any = None) -> list[str]:
    """Every pre-solve problem of ``sc`` with ``mech`` (empty if the run may start)."""
    task = sc.spec.task
    name = sc.section_name
    out: list[str] = []
    if mech is None and (task in ("fk", "ik", "track")
                         or (task == "workspace" and sc.section.kind != "lee_spherical")):
        return [f"{sc.doc.where(('mechanism',))}: a {task} scenario needs a mechanism"]
    if name == "fk":
        out += fk_problems(sc, mech)
    elif name == "ik":
        out += ik_problems(sc, mech, prepared)
    elif name == "biped":
        out += biped_problems(sc, mech, prepared)
    elif name == "track":
        out += track_problems(sc, mech)
    elif name == "workspace":
        out += workspace_problems(sc, mech)
    out += expect_problems(sc, mech)
    return out


# ---- helpers ----------------------------------------------------------------------------------


def _joint_names(mech: Any) -> list[str]:
    return list(mech.joint_names)


def _unknown_joint(sc: Any, key: tuple, name: str, valid: list[str], what: str) -> str:
    return (f"{sc.doc.where(key)}: {short(name)} is not {what} of {short(mech_name(sc))} "
            f"({what.split()[-1]}s: {short_list(valid) or 'none'})")


def mech_name(sc: Any) -> str:
    return Path(sc.mechanism_path).stem if sc.mechanism_path is not None else "the mechanism"


def _regular_file(path: Path) -> str | None:
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return "file not found"
    if not stat.S_ISREG(st.st_mode):
        return "not a regular file"
    if st.st_size > MAX_CSV_BYTES:
        return f"file is {st.st_size} bytes, more than the limit of {MAX_CSV_BYTES} bytes"
    return None


# ---- fk ---------------------------------------------------------------------------------------


def fk_problems(sc: Any, mech: Any) -> list[str]:
    """What ``mechkin fk`` refuses before the loop closure: the motion names exactly the
    independent joints, the time grid or table is usable, the initial guess names dependent
    joints."""
    from mechkin.tasks.fk_base import floating_base_fill, no_floating_base

    spec = sc.section
    doc = sc.doc
    names = list(mech.independent_names)
    out: list[str] = []
    if spec.motion is not None:
        ts = spec.time
        if ts.stop <= ts.start:
            out.append(f"{doc.where(('fk', 'time', 'stop'))}: expected stop > start")
        else:
            with np.errstate(over="ignore"):
                m = float(np.float64(ts.stop - ts.start) / ts.step) + 1.0  # may be inf
            if not m <= MAX_STEPS:
                out.append(f"{doc.where(('fk', 'time'))}: {m:.4g} steps is more than "
                           f"{MAX_STEPS}")
        if ts.start < 0:
            out.append(f"{doc.where(('fk', 'time', 'start'))}: times must be >= 0")
        for k in spec.motion:
            if k not in names:
                out.append(_unknown_joint(sc, ("fk", "motion", k), k, names,
                                          "an independent joint"))
        fill, bad = floating_base_fill(sc, mech, spec.motion)
        out += bad
    elif spec.table is not None:
        tab = spec.table
        if "t" not in tab:
            out.append(f"{doc.where(('fk', 'table'))}: missing column 't' (times in s)")
        for k in tab:
            if k != "t" and k not in names:
                out.append(_unknown_joint(sc, ("fk", "table", k), k, names,
                                          "an independent joint"))
        fill, bad = floating_base_fill(sc, mech, tab)
        out += bad
        for i, n in enumerate(names):
            if n not in tab and i not in fill:
                out.append(f"{doc.where(('fk', 'table'))}: no column for independent joint "
                           f"{short(n)}")
        lens = {len(v) for v in tab.values()}
        if len(lens) != 1 or 0 in lens:
            out.append(f"{doc.where(('fk', 'table'))}: columns must have the same non-zero "
                       f"length, got lengths {sorted(lens)[:6]}")
        elif "t" in tab:
            t = np.asarray(tab["t"], dtype=float)
            if np.any(np.diff(t) < 0):
                out.append(f"{doc.where(('fk', 'table', 't'))}: times must be non-decreasing")
            if t[0] < 0:
                out.append(f"{doc.where(('fk', 'table', 't'))}: times must be >= 0")
            if t[-1] > MAX_TIME_S:
                out.append(f"{doc.where(('fk', 'table', 't'))}: times must be at most "
                           f"{MAX_TIME_S:g} s, got {t[-1]:.3g}")
    elif spec.csv is not None:
        if spec.base_pose is not None and not getattr(mech, "floating", False):
            out.append(no_floating_base(sc, mech, ("fk", "base_pose")))
        try:
            path = (doc.path.parent / spec.csv).resolve()
        except (OSError, ValueError):
            path = doc.path.parent / "?"
        msg = _regular_file(path)
        if msg:
            out.append(f"{doc.where(('fk', 'csv'))}: {msg}: {short(spec.csv)}")
    dep = list(mech.dependent_names)
    for k in (spec.initial_guess or {}):
        if k not in dep:
            out.append(_unknown_joint(sc, ("fk", "initial_guess", k), k, dep,
                                      "a dependent joint"))
    if spec.base is not None and not out:
        out += _fk_base_problems(sc, mech)
    return out


def _fk_base_problems(sc: Any, mech: Any) -> list[str]:
    """``fk: base:``: the base trajectory can be built at the fk times (table / CSV columns,
    times covering the motion, world frame name)."""
    from mechkin.tasks.fk import independent_motion
    from mechkin.tasks.fk_base import base_trajectory

    try:
        t, _ = independent_motion(sc, mech)
        base_trajectory(sc, mech, t)
    except ConfigError as exc:
        return list(exc.problems)
    return []


# ---- ik ---------------------------------------------------------------------------------------


def ik_problems(sc: Any, mech: Any, prepared: Any = None) -> list[str]:
    """What ``mechkin ik`` refuses before solving: no end effector, a closed form the mechanism
    has not, an initial guess of unknown joints, a target that is not a finite pose."""
    from mechkin.config.ik_spec import target_matrix

    spec = sc.section
    doc = sc.doc
    out: list[str] = []
    framed = bool(spec.target_sets) or any(t.frame is not None for t in spec.targets)
    if framed:
        from mechkin.tasks.ik_frames import target_set_problems

        out += target_set_problems(sc, mech)
    if mech.end_effector is None and not framed:
        from mechkin.model.mechanism import end_effector_hint

        src = (mech.source.name if mech.source is not None and mech.source.suffix.lower() in
               (".urdf", ".xml", ".mjcf") else mech.name)  # a robot file: its file name
        out.append(f"{doc.where(('mechanism',))}: mechanism {short(src)} has no "
                   f"end_effector frame; {end_effector_hint(mech)}")
    if spec.method == "closed-form":
        from mechkin.solvers.closed_form.recognise import (
            ClosedFormMismatch,
            recognise_closed_form,
        )

        try:
            kind = (recognise_closed_form(mech) if prepared is None
                    else prepared.recognise_closed_form())
            if kind is None and not _legs_decompose(mech):
                out.append(f"{doc.where(('ik', 'method'))}: no closed form fits mechanism "
                           f"{short(mech.name)} (declare closed_form: stewart | direct_drive | "
                           "lee_spherical in the mechanism file, give a parallel mechanism "
                           "whose legs decompose, or use method: lm)")
        except ClosedFormMismatch as exc:
            out.append(f"{doc.where(('mechanism',))}: {short_str(str(exc), 200)}")
    if spec.method == "analytic":
        from mechkin.tasks.ik_analytic import analytic_problem

        why = analytic_problem(sc, mech)
        if why:
            out.append(why)
    names = _joint_names(mech)
    for k in (spec.initial_guess or {}):
        if k not in names:
            out.append(_unknown_joint(sc, ("ik", "initial_guess", k), k, names, "a joint"))
    for i, t in enumerate(spec.targets):
        try:
            with np.errstate(all="raise"):
                T = target_matrix(t, sc.spec.units)
            bad = not np.all(np.isfinite(T))
        except (FloatingPointError, ValueError, np.linalg.LinAlgError):
            bad = True
        if bad:
            out.append(f"{doc.where(('ik', 'targets', i))}: the target is not a finite pose")
    return out


def biped_problems(sc: Any, mech: Any, prepared: Any = None) -> list[str]:
    """The mechanism's legs must be the hwang2023 closed-form legs (what ``run_biped`` checks
    first)."""
    from mechkin.solvers.biped.sequence import geometry_from_mechanism

    try:
        with np.errstate(all="raise"):
            model = geometry_from_mechanism(mech)
    except FloatingPointError:
        return [f"{sc.doc.where(('mechanism',))}: the legs' kinematics is not finite"]
    except MechkinError as exc:
        return [f"{sc.doc.where(('mechanism',))}: {_strip_source(str(exc), mech)}"]
    if prepared is not None:
        prepared.biped_model = model
    return []


def _strip_source(msg: str, mech: Any) -> str:
    """``<file>: message`` -> ``message`` (the caller names the scenario's key)."""
    head = f"{mech.source}: "
    first = msg.splitlines()[0] if msg else ""
    return first[len(head):] if first.startswith(head) else first


# ---- track ------------------------------------------------------------------------------------


def track_problems(sc: Any, mech: Any) -> list[str]:
    """What ``mechkin track`` refuses before the DP: dynamics that cannot be built (inertial
    data missing, not a serial chain, not a planar 2R arm for closed_form_2link), limits not
    one per joint, an unknown hand frame, initial guess or branch joints."""
    from mechkin.config.track_spec import limit_count_message, mechanism_limits_si
    from mechkin.solvers.dynamics.from_mechanism import (
        dynamics_from_mechanism,
        planar_two_link_from_mechanism,
    )

    spec = sc.section
    doc = sc.doc
    out: list[str] = []
    try:
        with np.errstate(all="raise"):
            if spec.dynamics == "closed_form_2link":
                planar_two_link_from_mechanism(mech)
            else:
                dynamics_from_mechanism(mech)
    except FloatingPointError:
        out.append(f"{doc.where(('track', 'dynamics'))}: the dynamics is not finite")
    except MechkinError as exc:
        msg = str(exc).splitlines()[0]
        msg = msg[len(mech.name) + 2:] if msg.startswith(f"{mech.name}: ") else msg
        msg = msg[len("dynamics: "):] if msg.startswith("dynamics: ") else msg
        out.append(f"{doc.where(('track', 'dynamics'))}: {spec.dynamics}: {msg}")
    lim = mechanism_limits_si(spec.limits, sc.spec.units, mech)
    for name, (lo, _) in lim.items():
        if lo.shape != (mech.n,):
            out.append(f"{doc.where(('track', 'limits', name))}: "
                       f"{limit_count_message(mech, lo.shape[0])}")
    for k, case in enumerate(spec.cases or []):  # track.cases[k].limits
        if case.limits is None:
            continue
        for name, (lo, _) in mechanism_limits_si(case.limits, sc.spec.units, mech).items():
            if lo.shape != (mech.n,):
                out.append(f"{doc.where(('track', 'cases', k, 'limits', name))}: "
                           f"{limit_count_message(mech, lo.shape[0])}")
    if spec.path.frame is None:
        if mech.end_effector is None:
            from mechkin.model.mechanism import end_effector_hint

            out.append(f"{doc.where(('track', 'path'))}: the mechanism has no end_effector; "
                       f"name the hand frame in path.frame; {end_effector_hint(mech, 3)}")
    elif spec.path.frame not in mech.frame_names:
        out.append(_unknown_joint(sc, ("track", "path", "frame"), spec.path.frame,
                                  list(mech.frame_names), "a frame"))
    names = _joint_names(mech)
    for key in ("initial_guess", "branch"):
        for k in (getattr(spec.ik, key) or {}):
            if k not in names:
                out.append(_unknown_joint(sc, ("track", "ik", key, k), k, names, "a joint"))
    if not out:  # the hand path's start pose and the conveyor, as the run computes them
        from mechkin.tasks.track_preflight import preflight_problems

        out += preflight_problems(sc, mech)
    return out


# ---- workspace --------------------------------------------------------------------------------


def workspace_problems(sc: Any, mech: Any | None) -> list[str]:
    """What ``mechkin workspace`` refuses before sweeping."""
    spec = sc.section
    if spec.kind == "joint_sweep":
        return _joint_sweep_problems(sc, mech)
    if spec.kind == "task_space":
        return _frame_problems(sc, mech) + _task_space_problems(sc)
    return _lee_problems(sc, mech)


def _frame_problems(sc: Any, mech: Any) -> list[str]:
    spec = sc.section
    if spec.frame is not None:
        if spec.frame not in mech.frame_names:
            return [_unknown_joint(sc, ("workspace", "frame"), spec.frame,
                                   list(mech.frame_names), "a frame")]
        return []
    if mech.end_effector is None:
        from mechkin.model.mechanism import end_effector_hint

        return [f"{sc.doc.where(('workspace',))}: the mechanism has no end_effector; give "
                f"workspace.frame; {end_effector_hint(mech, 3)}"]
    return []


def _joint_sweep_problems(sc: Any, mech: Any) -> list[str]:
    spec = sc.section
    doc = sc.doc
    names = list(mech.independent_names)
    given = spec.joints or {}
    out = [_unknown_joint(sc, ("workspace", "joints", k), k, names, "an independent joint")
           for k in given if k not in names]
    out += _frame_problems(sc, mech)
    if out:
        return out
    swept = [n for n in names if n in given] if spec.method == "grid" else names
    if not swept:
        return [f"{doc.where(('workspace', 'joints'))}: method grid needs at least one joint "
                "with n"]
    for n in swept:
        j = mech.joint_index(n)
        js = given.get(n)
        if (js is None or js.range is None) and mech.s[j] == 1 and not (
                math.isfinite(float(mech.lower[j])) and math.isfinite(float(mech.upper[j]))):
            # (a revolute joint without limits is swept over a full turn)
            out.append(f"{doc.where(('workspace', 'joints', n))}: prismatic joint {short(n)} "
                       f"has no limits; give a range, e.g. '{n}: {{range: [0, 100]}}'")
        if spec.method == "grid" and (js is None or js.n is None):
            out.append(f"{doc.where(('workspace', 'joints', n))}: method grid needs n")
    if not out and spec.method == "grid":
        total = math.prod(int(given[n].n) for n in swept)
        if total > MAX_SWEEP_SAMPLES:
            out.append(f"{doc.where(('workspace', 'joints'))}: the grid has {total} samples, "
                       f"more than {MAX_SWEEP_SAMPLES}")
    return out


def _task_space_problems(sc: Any) -> list[str]:
    spec = sc.section
    if spec.method != "grid":
        return []
    total = 1
    for k in "xyz":
        a = spec.positions[k]
        total *= 1 if a.value is not None else int(a.n)
    if total > MAX_SWEEP_SAMPLES:
        return [f"{sc.doc.where(('workspace', 'positions'))}: the grid has {total} poses, more "
                f"than {MAX_SWEEP_SAMPLES}"]
    return []


def _lee_problems(sc: Any, mech: Any | None) -> list[str]:
    spec = sc.section
    dspec = spec.design
    if dspec is None or dspec.parameter not in ("l_min", "l_max"):
        return []
    from mechkin.config.units import length_factor

    L = length_factor(sc.spec.units.length)
    lo, hi = 0.5, 2.0  # lee §3.2
    if mech is not None and "l1" in mech.joint_names:
        j = mech.joint_index("l1")
        if math.isfinite(float(mech.lower[j])) and math.isfinite(float(mech.upper[j])):
            lo, hi = float(mech.lower[j]), float(mech.upper[j])
    par = spec.parameters
    if par is not None and par.stroke is not None:
        lo, hi = float(par.stroke[0]) * L, float(par.stroke[1]) * L
    values = [v * L for v in dspec.values]
    bad = [v for v in values if (v >= hi if dspec.parameter == "l_min" else v <= lo)]
    if bad:
        return [f"{sc.doc.where(('workspace', 'design', 'values'))}: {dspec.parameter} values "
                f"{short([v / L for v in bad])} do not leave l_min < l_max (stroke "
                f"{lo / L:g}..{hi / L:g})"]
    return []


# ---- expect keys ------------------------------------------------------------------------------

_FK_KEYS = {"scenario", "task", "mechanism", "status", "n_steps", "steps", "first_failure_step",
            "closure", "joints_outside_limits", "solve_time_s", "time_per_step_s", "t_s",
            "final", "singularity", "rates_time_s", "assembly_modes", "n_assembly_modes",
            "n_assembly_modes_within_limits", "assembly_mode_followed", "assembly_search",
            "assembly_mode_from_home", "assembly_start",
            "assembly_at", "base"}
_FK_NESTED = {"closure": {"n_cuts", "n_equations", "max_residual", "iterations_mean",
                          "iterations_max", "max_condition"},
              "steps": {"converged", "not converged", "singular", "constraint singularity",
                        "outside limits"},
              "final": {"q", "end_effector", "end_effector_in_base"},
              "base": {"world_frame", "source", "final", "max_speed_m_s",
                       "max_angular_speed_rad_s", "max_acceleration_m_s2"}}
_IK_KEYS = {"scenario", "task", "mechanism", "method", "status", "n_targets", "counts",
            "max_position_error", "max_orientation_error", "solve_time_s",
            "median_time_per_target_s", "end_effector", "targets", "solutions", "methods_used",
            "analytic_structure",
            "n_target_sets", "floating_base", "target_sets"}
_IK_TARGET_KEYS = {"name", "status", "q", "q_v", "position_error", "orientation_error",
                   "weights", "f", "grad_norm", "iterations", "evaluations", "time_s",
                   "closure_residual", "joints_at_limit", "target", "end_effector",
                   "restarts_used", "solutions", "n_solutions", "solutions_source"}
_BIPED_KEYS = {"scenario", "task", "section", "mechanism", "method", "status", "n_steps", "n_ok",
               "n_frames", "geometry", "steps", "motion"}
_TRACK_KEYS = {"scenario", "task", "mechanism", "dynamics", "status", "message", "objective",
               "t_a_s", "t_start_s", "duration_s", "peak_torque", "limits_ok", "active_limits",
               "limit_usage", "grid", "cost", "solve_time_s", "blocked_at_r",
               "blocking_limits", "peak_torque_by_joint", "actuated_joints", "path", "reference",
               "limits_si", "grid_study", "n_samples", "csv_notes", "time_penalty", "dp", "cases",
               "planner", "intercept_r"}
_HEAD = {"scenario", "task", "kind", "status"}
_LEE_KEYS = _HEAD | {"design_source", "mechanism", "r", "R", "center", "stroke", "threshold",
                     "definition", "isotropy", "gamma_range", "compute_time_s"}
_LEE_DESIGN_KEYS = _HEAD | {"design_source", "mechanism", "threshold", "definition", "design",
                            "comparison", "execution", "compute_time_s"}
_TASK_SPACE_KEYS = _HEAD | {"mechanism", "method", "seed", "frame", "restarts", "n_poses",
                            "n_reachable", "reachable_fraction", "status_counts", "isotropy",
                            "isotropy_position", "condition_number", "manipulability",
                            "iterations", "max_position_error_m", "max_orientation_error_rad",
                            "reachable_bounding_box", "definition", "execution",
                            "compute_time_s", "characteristic_length", "isotropy_normalized"}
_JOINT_SWEEP_KEYS = _HEAD | {"mechanism", "method", "seed", "swept_joints", "full_turn_joints",
                             "frame",
                             "closed_chain", "n_samples", "n_reachable", "reachable_fraction",
                             "n_not_converged", "n_outside_limits", "bounding_box", "volume",
                             "definition", "manipulability", "isotropy", "compute_time_s",
                             "sample", "characteristic_length", "continuation",
                             "isotropy_normalized", "isotropy_position"}


#: Keys of every task's summary: a --max-time stop (budget.mark_stopped), the time estimate.
_RUN_KEYS = {"stopped", "estimated_time_s"}


def summary_top_keys(sc: Any) -> set[str]:
    """The top-level keys a run of ``sc`` can put in summary.json before the expects."""
    return _task_top_keys(sc) | _RUN_KEYS


def _task_top_keys(sc: Any) -> set[str]:
    name = sc.section_name
    if name == "fk":
        return _FK_KEYS
    if name == "ik":
        return _IK_KEYS
    if name == "biped":
        return _BIPED_KEYS
    if name == "track":
        return _TRACK_KEYS
    kind = sc.section.kind
    if kind == "lee_spherical":
        return _LEE_DESIGN_KEYS if sc.section.design is not None else _LEE_KEYS
    return _TASK_SPACE_KEYS if kind == "task_space" else _JOINT_SWEEP_KEYS


def expect_problems(sc: Any, mech: Any | None) -> list[str]:
    """``expect:`` keys the summary cannot have: an unknown top-level key, and for fk and ik
    the joint names, target indices and per-target keys the summary is built from."""
    out: list[str] = []
    top = summary_top_keys(sc)
    for i, e in enumerate(sc.spec.expect):
        parts = e.key.split(".")
        kp = ("expect", i, "key")
        if parts[0] not in top:
            out.append(f"{sc.doc.where(kp)}: the summary of this {sc.spec.task} run has no key "
                       f"{short(parts[0])} (keys: {short_list(sorted(top), 80)})")
            continue
        msg = _deep_key_problem(sc, mech, parts)
        if not msg:  # the keys below the top, at any depth (tasks/expect_keys.py)
            from mechkin.tasks.expect_keys import deep_key_problem

            msg = deep_key_problem(sc, mech, parts, word=isinstance(e.value, str))
        if msg:
            out.append(f"{sc.doc.where(kp)}: {msg}")
    return out


def _deep_key_problem(sc: Any, mech: Any | None, parts: list[str]) -> str | None:
    if mech is None:
        return None
    name = sc.section_name
    joints = list(mech.joint_names)
    if name == "fk" and len(parts) >= 2 and parts[0] in _FK_NESTED:
        sub = _FK_NESTED[parts[0]]
        if parts[1] not in sub:
            return (f"{parts[0]} has no key {short(parts[1])} (keys: "
                    f"{short_list(sorted(sub), 80)})")
    if (name == "fk" and parts[0] == "final" and len(parts) >= 3 and parts[1] == "q"
            and parts[2] not in joints):
        return f"final.q has no joint {short(parts[2])} (joints: {short_list(joints)})"
    if name == "ik" and parts[0] == "targets":
        if len(parts) < 2:
            return None
        spec = sc.section
        n_max = len(spec.targets) + (spec.random_targets.count if spec.random_targets else 0)
        if not parts[1].isdigit() or int(parts[1]) >= n_max:
            return (f"targets.{short_str(parts[1])}: expected a target index 0..{n_max - 1} (the "
                    f"scenario has at most {n_max} targets)")
        if len(parts) >= 3 and parts[2] not in _IK_TARGET_KEYS:
            return (f"a target record has no key {short(parts[2])} (keys: "
                    f"{short_list(sorted(_IK_TARGET_KEYS), 80)})")
        if len(parts) >= 4 and parts[2] == "q_v" and parts[3] not in mech.independent_names:
            return (f"q_v has no joint {short(parts[3])} (independent: "
                    f"{short_list(mech.independent_names)})")
        if len(parts) >= 4 and parts[2] == "q" and parts[3] not in joints:
            return f"q has no joint {short(parts[3])} (joints: {short_list(joints)})"
    return None


def _legs_decompose(mech: Any) -> bool:
    """Whether ``method: closed-form`` can solve a mechanism without a named closed form: a
    parallel mechanism whose legs decompose (:mod:`mechkin.solvers.ik.analytic.legs`)."""
    from mechkin.solvers.ik.analytic.legs import legs_for

    return bool(mech.cuts) and mech.end_effector is not None and legs_for(mech) is not None

"""The biped task (``mechkin ik`` with a ``biped:`` section): a hwang2023-type biped on
inclined planes, one case or a walk -> skate -> roll switching sequence.

:func:`run` converts the section to SI steps, solves them with
:func:`mechkin.solvers.biped.sequence.solve_sequence` (closed forms of hwang2023 §2.2-§2.4), checks
every
leg by forward kinematics (the closed-form chain and the mechanism file's model), evaluates the
``expect:`` entries and returns a :class:`~mechkin.records.Report` whose
:class:`~mechkin.records.biped.BipedRecord` ``mechkin.io.biped_out`` writes (``leg_right.csv``,
``leg_left.csv``, ``frames.csv`` with the joint rates per frame, ``biped.png``, ``biped.mcap``).
Writes nothing.

Imports: config, model, solvers, spatial, records, tasks.common.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.config.biped_spec import BipedSpec, StepSpec, body_si, leg_si, plane_si
from mechkin.config.scenario import Scenario
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.drawing import frame_tree
from mechkin.model.kinematics import forward_kinematics
from mechkin.records import Report
from mechkin.records.biped import BipedPlot, BipedRecord
from mechkin.solvers.biped.leg import (
    STATUS_OK,
    InclinedPlane,
    LegSolution,
    LegTask,
    biped_polylines,
    body_transform,
    psi_from_ee_rotation,
)
from mechkin.solvers.biped.sequence import (
    EE_FRAMES,
    SIDES,
    BipedFrame,
    BipedModel,
    BipedStep,
    LegInput,
    StepResult,
    geometry_from_mechanism,
    solve_sequence,
)
from mechkin.spatial.euler_conventions import Side, contact_angles_from_matrix
from mechkin.spatial.rotations import rot_x, rot_y, rot_z
from mechkin.spatial.transforms import T_from
from mechkin.tasks.common import expect_messages, output_flags, with_expect

PLANE_HALF = 0.35  # [m] half side of the drawn plane
ESTIMATED_NOTE = ("HWANG2023_ESTIMATED: lengths, foot extension and blade radius ESTIMATED from "
                  "hwang2023 Table 6 (the paper's link lengths are lost), not published values")


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(float(x)) else None


# --------------------------------------------------------------------------- config -> SI


def _plane(pl: dict[str, Any]) -> InclinedPlane:
    return InclinedPlane(pl["origin"], pl["lam_x"], pl["lam_y"], pl["gam_x"])


def _plane_info(pl: dict[str, Any], plane: InclinedPlane) -> dict[str, Any]:
    return {"lam_x": pl["lam_x"], "lam_y": pl["lam_y"], "gam_x": pl["gam_x"],
            "origin_m": list(pl["origin"]), "normal": plane.normal.tolist()}


def body_pose(position: np.ndarray, angles: tuple[float, float, float]) -> np.ndarray:
    """T_0_G (4, 4) = [Rz(theta_z) Ry(theta_y) Rx(theta_x) | b_0G] (Eq. 1a for theta_x =
    theta_y = 0)."""
    thx, thy, thz = angles
    if thx == 0.0 and thy == 0.0:
        return body_transform(position, thz)
    return T_from(rot_z(thz) @ rot_y(thy) @ rot_x(thx), np.asarray(position, float))


def _step_si(step: StepSpec, spec: BipedSpec, units: Any, k: int) -> tuple[BipedStep, dict]:
    pl = plane_si(step.plane or spec.plane, units)
    plane = _plane(pl)
    pos, ang = body_si(step.body or spec.body, units)
    TG = body_pose(pos, ang)
    legs = {}
    leg_planes: dict[str, dict[str, Any]] = {}
    for side in SIDES:
        t = leg_si(getattr(step.legs, side), units)
        own = None
        if t["plane"] is not None:
            own = _plane(t["plane"])
            leg_planes[side] = _plane_info(t["plane"], own)
        legs[side] = LegInput(t["position"], t["below_hip"], float(t["beta_z"]), t["beta"],
                              t["theta6"], t["branch"], own, t["beta_end"])
    bs = BipedStep(step.mode, plane, TG, legs, step.name or f"{step.mode} {k}",
                   float(step.duration), int(step.frames), step.time_law)
    info = {"plane": _plane_info(pl, plane),
            "body": {"position_m": pos.tolist(), "theta_x": float(ang[0]),
                     "theta_y": float(ang[1]), "theta_z": float(ang[2])},
            "leg_planes": leg_planes}
    return bs, info


# --------------------------------------------------------------------------- summary


def limit_violations(mech: Mechanism, joints: list[int], q: np.ndarray
                     ) -> list[dict[str, Any]]:
    """The joints of one leg whose value q (6,) [rad] lies outside the file's limits."""
    out = []
    for j, v in zip(joints, q, strict=True):
        lo, hi = float(mech.lower[j]), float(mech.upper[j])
        if not lo - 1e-9 <= v <= hi + 1e-9:
            out.append({"joint": mech.joint_names[j], "value": float(v), "min": lo, "max": hi})
    return out


def _limits_text(v: list[dict[str, Any]]) -> str:
    return ", ".join(f"{x['joint']} = {np.rad2deg(x['value']):.4g} deg outside "
                     f"[{np.rad2deg(x['min']):.4g}, {np.rad2deg(x['max']):.4g}] deg" for x in v)


def _model_fk_error(mech: Mechanism, joints: list[int], side: Side, sol: LegSolution,
                    kind: str, TG: np.ndarray) -> float:
    """|E by the mechanism file's forward kinematics - E of the closed form| [m]."""
    q = np.zeros((1, mech.n))
    q[0, joints] = sol.q
    fr = EE_FRAMES[side][0 if kind == "blade" else 1]
    T_model = TG @ forward_kinematics(mech, q).frames(mech, [mech.frame_index(fr)])[0, 0]
    return float(np.linalg.norm(T_model[:3, 3] - sol.T_0_E[:3, 3]))


def _all_solutions(mech: Mechanism, joints: list[int], side: Side,
                   alts: tuple[LegSolution, ...], kind: str, TG: np.ndarray
                   ) -> list[dict[str, Any]]:
    """Every closed-form solution of a leg (``solutions: all``), each verified by the
    mechanism file's forward kinematics."""
    names = [mech.joint_names[j] for j in joints]
    return [{"branch": a.branch, "method": a.method,
             "q": {n: float(v) for n, v in zip(names, a.q, strict=True)},
             "q_rad_list": [float(v) for v in a.q],
             "beta": float(a.beta) if math.isfinite(a.beta) else None,
             "position_error_m": float(a.position_error),
             "orientation_error_rad": float(a.orientation_error),
             "model_fk_error_m": _model_fk_error(mech, joints, side, a, kind, TG)}
            for a in alts if a.ok]


def _leg_record(mech: Mechanism, joints: list[int], side: Side, leg: LegSolution, kind: str,
                plane: InclinedPlane, TG: np.ndarray, task: LegTask, n_alt: int,
                mode: str, own_plane: dict[str, Any] | None = None) -> dict[str, Any]:
    names = [mech.joint_names[j] for j in joints]
    rec: dict[str, Any] = {"status": leg.status, "branch": leg.branch, "method": leg.method,
                           "n_solutions": n_alt}
    if own_plane is not None:
        rec["plane"] = own_plane
    if leg.q_outside is not None:
        rec["limits"] = limit_violations(mech, joints, leg.q_outside)
        rec["q_outside_limits"] = {n: float(v) for n, v in zip(names, leg.q_outside,
                                                                strict=True)}
        rec["message"] = ("the pose needs " + _limits_text(rec["limits"])
                          + " (the mechanism file's joint limits)")
    beta_name = "beta_X" if kind == "foot" else "beta_Y"
    # the task as solved (for a roll: the start state E_a, beta_Ya and the wanted theta6)
    rec["task"] = {"start_position_m" if mode == "roll" else "position_m":
                   list(task.position), "beta_z": task.beta_z, "beta": task.beta,
                   "theta6": task.theta6}
    if not leg.ok:
        return rec
    rec["q"] = {n: float(v) for n, v in zip(names, leg.q, strict=True)}
    rec["q_deg"] = {n: float(np.rad2deg(v)) for n, v in zip(names, leg.q, strict=True)}
    rec["q_rad_list"] = [float(v) for v in leg.q]
    rec["q_deg_list"] = [float(np.rad2deg(v)) for v in leg.q]
    rec["position_error_m"] = float(leg.position_error)
    rec["orientation_error_rad"] = float(leg.orientation_error)
    # independent check: the mechanism file's forward kinematics at the same q
    rec["model_fk_error_m"] = _model_fk_error(mech, joints, side, leg, kind, TG)
    rec["end_effector_m"] = leg.T_0_E[:3, 3].tolist()
    rec["contact_point_m"] = leg.p_contact.tolist()
    n = plane.normal
    rec["contact_plane_distance_m"] = float(n @ (leg.p_contact - np.asarray(plane.origin)))
    up = -leg.T_0_E[:3, 2]
    # angle between the sole / blade normal and the plane normal (atan2: exact near 0, where
    # arccos loses half the digits)
    rec["normal_angle"] = float(np.arctan2(np.linalg.norm(np.cross(up, n)), up @ n))
    rec["beta_kind"] = beta_name
    beta = leg.beta
    if not math.isfinite(beta):
        a = contact_angles_from_matrix(psi_from_ee_rotation(leg.T_0_E[:3, :3], side),
                                       plane.rotation(side), side,
                                       "foot" if kind == "foot" else "blade")
        beta = float(a[1])
    rec["beta"] = float(beta)
    rec["beta_deg"] = float(np.rad2deg(beta))
    rec["theta6_deg"] = float(np.rad2deg(leg.q[5]))
    return rec


def _step_record(mech: Mechanism, joints: Mapping[str, list[int]], k: int, step: BipedStep,
                 info: dict, res: StepResult, t_end: float, all_solutions: bool = False
                 ) -> dict[str, Any]:
    kind = "foot" if step.mode == "walk" else "blade"
    legs = {s: _leg_record(mech, joints[s], s, res.legs[s], kind, step.leg_plane(s),
                           step.T_0_G, res.tasks[s], len(res.alternatives[s]),
                           step.mode, info["leg_planes"].get(s))
            for s in SIDES}
    for s in SIDES:
        if s in res.beta_end:
            legs[s]["task"]["beta_end"] = res.beta_end[s]
        if all_solutions:
            legs[s]["solutions"] = _all_solutions(mech, joints[s], s, res.alternatives[s],
                                                  kind, step.T_0_G)
    return {
        "index": k, "name": step.label, "mode": step.mode, "t_s": t_end, "status": res.status,
        "kind": kind, "plane": info["plane"], "body": info["body"], "legs": legs,
    }


# --------------------------------------------------------------------------- the run


def check_budget(scenario: Scenario) -> None:
    """The run's time estimate before any work (:func:`mechkin.tasks.estimates.biped_seconds`:
    every frame of every step)."""
    from mechkin.tasks import budget
    from mechkin.tasks.estimates import biped_seconds

    steps = scenario.section.steps()
    frames = sum(int(s.frames) for s in steps)
    budget.estimate_time(scenario.doc.where(("biped",)), biped_seconds(frames),
                         f"a biped sequence of {len(steps)} steps, {frames} frames")


def run(scenario: Scenario, prepared: Any = None, **_options: Any) -> Report:
    """Solve the scenario's biped case or switching sequence; the report holds the summary,
    the ``expect:`` results and the :class:`BipedRecord` of every output. ``prepared``
    (:class:`mechkin.tasks.prepare.Prepared`, handed on by :func:`mechkin.tasks.run`): the
    mechanism and the legs the validation read from it."""
    spec: BipedSpec = scenario.section
    units = scenario.spec.units
    if scenario.mechanism_path is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: required key is missing")
    if prepared is not None and prepared.biped_model is not None:
        mech, model = prepared.mechanism, prepared.biped_model
    else:
        mech = load_mechanism(scenario.mechanism_path)
        model = geometry_from_mechanism(mech)
    geometry, joints = model.geometry, model.joints
    check_budget(scenario)

    pairs = [_step_si(s, spec, units, k) for k, s in enumerate(spec.steps())]
    steps = [p[0] for p in pairs]
    from mechkin.tasks import budget

    # --max-time: stop between two steps, keep the steps solved (and their frames)
    results, frames = solve_sequence(
        model, steps, stop=budget.overrun if budget.time_limit() is not None else None)
    if len(results) < len(steps):
        budget.note_done(len(results), len(steps), "steps")
        steps, pairs = steps[:len(results)], pairs[:len(results)]
    t_ends = _step_end_times(steps)
    records = [_step_record(mech, joints, k, steps[k], pairs[k][1], results[k], t_ends[k],
                            spec.solutions == "all")
               for k in range(len(steps))]

    n_ok = sum(r["status"] == STATUS_OK for r in records)
    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "ik",
        "section": "biped",
        "mechanism": mech.name,
        "method": "hwang2023 closed forms (§2.2 known pose, §2.3 unknown blade tilt, §2.4 "
                  "rolling without slipping)",
        "status": "ok" if n_ok == len(records) else next(
            r["status"] for r in records if r["status"] != STATUS_OK),
        "n_steps": len(records),
        "n_ok": n_ok,
        "n_frames": len(frames),
        "geometry": {"lengths_m": list(geometry.lengths),
                     "foot_extension_m": geometry.foot_extension,
                     "wheel_radius_m": geometry.wheel_radius,
                     "hip_offset_m": list(geometry.hip_offset),
                     "estimated": list(geometry.estimated),
                     "source": (ESTIMATED_NOTE if model.estimated
                                else f"read from the mechanism file {Path(str(mech.source)).name}"),
                     "joint_limits_rad": {mech.joint_names[j]: [_num(mech.lower[j]),
                                                                _num(mech.upper[j])]
                                          for s in SIDES for j in joints[s]}},
        "motion": _motion_summary(frames),
        "steps": records,
    }
    checks = with_expect(summary, scenario)
    data = _record(scenario, mech, model, steps, records, frames)
    messages = [f"{scenario.path}: step {r['index']} ({r['name']}): the {s} leg is "
                f"{r['legs'][s]['status']}: {r['legs'][s]['message']}"
                for r in records for s in SIDES if "message" in r["legs"][s]]
    return Report(task="biped", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=summary["status"] == "ok", writer="biped", data=data,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=messages + expect_messages(checks, scenario.path))


def _motion_summary(frames: list[BipedFrame]) -> dict[str, float]:
    """Figures of the whole log (both legs' joints, a failed leg's last good q): the largest
    change of a joint between consecutive frames [rad], the largest joint rate (``frames.csv``)
    [rad/s] and the largest difference of a joint between the last and the first frame [rad]
    (0 when the motion returns to its start pose)."""
    qf = _frame_q(frames)
    q = np.concatenate([qf[s] for s in SIDES], axis=1)
    t = np.array([f.t for f in frames], float)
    step = float(np.abs(np.diff(q, axis=0)).max()) if len(q) > 1 else 0.0
    return {"max_frame_step_rad": step,
            "max_rate_rad_s": float(np.abs(frame_rates(t, q)).max()),
            "end_minus_start_rad": float(np.abs(q[-1] - q[0]).max())}


def _step_end_times(steps: list[BipedStep]) -> list[float]:
    out, t = [], 0.0
    for k, s in enumerate(steps):
        t = t + (s.duration if k > 0 else 0.0)
        out.append(t)
    return out


# --------------------------------------------------------------------------- the record


def _csv_columns(mech: Mechanism, joints: list[int], side: str,
                 records: list[dict[str, Any]]) -> dict[str, list[Any]]:
    names = [mech.joint_names[j] for j in joints]
    cols: dict[str, list[Any]] = {"step": [], "phase": [], "mode": [], "t_s": []}
    for n in names:
        cols[f"{n}_rad"] = []
    for n in names:
        cols[f"{n}_deg"] = []
    for key in ("beta_rad", "beta_deg", "ee_x_m", "ee_y_m", "ee_z_m", "contact_x_m",
                "contact_y_m", "contact_z_m", "position_error_m", "orientation_error_rad",
                "model_fk_error_m", "branch", "status"):
        cols[key] = []
    for r in records:
        leg = r["legs"][side]
        cols["step"].append(r["index"])
        cols["phase"].append(r["name"])
        cols["mode"].append(r["mode"])
        cols["t_s"].append(float(r["t_s"]))
        ok = "q" in leg
        for n in names:
            cols[f"{n}_rad"].append(leg["q"][n] if ok else "")
            cols[f"{n}_deg"].append(leg["q_deg"][n] if ok else "")
        cols["beta_rad"].append(leg["beta"] if ok else "")
        cols["beta_deg"].append(leg["beta_deg"] if ok else "")
        for i, a in enumerate("xyz"):
            cols[f"ee_{a}_m"].append(leg["end_effector_m"][i] if ok else "")
            cols[f"contact_{a}_m"].append(leg["contact_point_m"][i] if ok else "")
        cols["position_error_m"].append(leg["position_error_m"] if ok else "")
        cols["orientation_error_rad"].append(leg["orientation_error_rad"] if ok else "")
        cols["model_fk_error_m"].append(leg["model_fk_error_m"] if ok else "")
        cols["branch"].append(leg["branch"])
        cols["status"].append(leg["status"])
    return cols


def _frame_q(frames: list[BipedFrame]) -> dict[str, np.ndarray]:
    """Per-frame q (m, 6) per leg; a failed leg keeps the last good q (home at first)."""
    out = {s: np.zeros((len(frames), 6)) for s in SIDES}
    for s in SIDES:
        last = np.zeros(6)
        for i, f in enumerate(frames):
            leg = f.legs[s]
            if leg.ok:
                last = leg.q
            out[s][i] = last
    return out


def frame_rates(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Joint rates (m, n) [rad/s] of the frames q (m, n) at the times t (m,) [s]: finite
    differences of the sampled motion (``numpy.gradient``: second-order central differences on
    the non-uniform time grid inside, first-order one-sided at the two ends; zeros for a
    single frame). Inside an animated step (``frames > 1``) the frames sample a smooth motion,
    so these approximate dq/dt to O(dt^2); across a step of one frame they are its jump over
    its duration."""
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if len(t) < 2:
        return np.zeros_like(q)
    return np.gradient(q, t, axis=0)


def _frame_columns(mech: Mechanism, joints: Mapping[str, list[int]], frames: list[BipedFrame],
                   steps: list[BipedStep], t: np.ndarray, q: np.ndarray, qd: np.ndarray
                   ) -> dict[str, list[Any]]:
    """``frames.csv``: one row per frame (a failed leg keeps its last good q, ``status``
    says so): time, step, each leg joint's value [rad] and rate [rad/s], the contact angle."""
    cols: dict[str, list[Any]] = {
        "frame": list(range(len(frames))), "t_s": [float(x) for x in t],
        "step": [int(f.step) for f in frames],
        "phase": [steps[f.step].label for f in frames],
        "mode": [steps[f.step].mode for f in frames]}
    idx = [j for s in SIDES for j in joints[s]]
    for j in idx:
        cols[f"{mech.joint_names[j]}_rad"] = [float(v) for v in q[:, j]]
    for j in idx:
        cols[f"{mech.joint_names[j]}_rad_s"] = [float(v) for v in qd[:, j]]
    for s in SIDES:
        cols[f"beta_{s}_rad"] = [float(f.legs[s].beta) if f.legs[s].ok
                                 and math.isfinite(f.legs[s].beta) else "" for f in frames]
    cols["status"] = [next((f.legs[s].status for s in SIDES if not f.legs[s].ok), STATUS_OK)
                      for f in frames]
    return cols


def _snapshot_label(r: dict[str, Any]) -> str:
    bits = []
    for s in SIDES:
        leg = r["legs"][s]
        if "beta" in leg:
            bits.append(f"{s[0].upper()} {leg['beta_kind'].replace('beta_', 'b')}="
                        f"{leg['beta_deg']:.2f}")
    return f"{r['name']} ({r['mode']}) " + ", ".join(bits)


STATE_FIELDS = ("theta6_{s}_deg", "beta_{s}_deg", "position_error_{s}_m",
                "orientation_error_{s}_rad")


def state_schema() -> dict[str, Any]:
    """The fixed JSON schema of ``/mechkin/state``: every field one explicit type (never
    ``null``); a failed leg's numbers are absent, ``status`` and ``failed_legs`` say why."""
    props: dict[str, Any] = {
        "step": {"type": "integer", "description": "index of the step in the sequence"},
        "phase": {"type": "string", "description": "name of the step"},
        "mode": {"type": "string", "enum": ["walk", "skate", "roll"]},
        "status": {"type": "string", "description": "ok, or the first failed leg's status"},
        "failed_legs": {"type": "string",
                        "description": "the legs without a solution (absent when none)"},
    }
    for s in SIDES:
        for f, desc in zip(STATE_FIELDS, ("ankle angle theta6 (last solved value)",
                                          "foot angle beta_X or blade tilt beta_Y",
                                          "forward-kinematics position error",
                                          "forward-kinematics orientation error"), strict=True):
            props[f.format(s=s)] = {"type": "number", "description": f"{s} leg: {desc}"}
    return {"type": "object", "title": "mechkin.State", "properties": props,
            "required": ["step", "phase", "mode", "status", "theta6_right_deg",
                         "theta6_left_deg"]}


def _state(frames: list[BipedFrame], steps: list[BipedStep],
           qf: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    state = []
    for i, f in enumerate(frames):
        step = steps[f.step]
        st: dict[str, Any] = {"step": int(f.step), "phase": step.label, "mode": step.mode,
                              "status": next((f.legs[s].status for s in SIDES
                                              if not f.legs[s].ok), STATUS_OK)}
        failed = [s for s in SIDES if not f.legs[s].ok]
        if failed:
            st["failed_legs"] = " ".join(failed)
        for s in SIDES:
            leg = f.legs[s]
            st[f"theta6_{s}_deg"] = float(np.rad2deg(qf[s][i, 5]))
            if not leg.ok:
                continue
            for key, v in ((f"beta_{s}_deg", np.rad2deg(leg.beta)),
                           (f"position_error_{s}_m", leg.position_error),
                           (f"orientation_error_{s}_rad", leg.orientation_error)):
                x = _num(v)
                if x is not None:
                    st[key] = x
        state.append(st)
    return state


def _distinct(planes: list[InclinedPlane]) -> list[InclinedPlane]:
    seen: list[np.ndarray] = []
    out = []
    for pln in planes:
        key = np.r_[pln.origin, pln.normal]
        if not any(np.allclose(key, s) for s in seen):
            seen.append(key)
            out.append(pln)
    return out


def _body(f: BipedFrame, steps: list[BipedStep]) -> np.ndarray:
    return steps[f.step].T_0_G if f.T_0_G is None else f.T_0_G


def _plane_pose(p: InclinedPlane) -> np.ndarray:
    return T_from(p.rotation("right"), np.asarray(p.origin, float))


def _record(scenario: Scenario, mech: Mechanism, model: BipedModel, steps: list[BipedStep],
            records: list[dict[str, Any]], frames: list[BipedFrame]) -> BipedRecord:
    geometry, joints = model.geometry, model.joints
    qf = _frame_q(frames)
    polys = [biped_polylines(geometry, _body(f, steps), qf["right"][i], qf["left"][i],
                             kind=f.kind, plane=steps[f.step].leg_plane("right"),
                             plane_half_size=PLANE_HALF)
             for i, f in enumerate(frames)]
    title = (f"{scenario.name} (geometry ESTIMATED)" if model.estimated
             else f"{scenario.name} ({mech.name}, geometry from the mechanism file)")
    rec = BipedRecord(title=scenario.name, mechanism=mech.name,
                      columns={s: _csv_columns(mech, joints[s], s, records) for s in SIDES},
                      plot_title=title, plane_half=PLANE_HALF)
    # plot: one panel per step (its last frame), at most 12
    last = {f.step: i for i, f in enumerate(frames)}
    idx = [last[k] for k in sorted(last)][-12:]
    for i in idx:
        rec.snapshots.append(BipedPlot(polys[i], _snapshot_label(records[frames[i].step])))
    for pln in _distinct([steps[frames[i].step].leg_plane(s) for i in idx for s in SIDES]):
        rec.plot_planes.append((np.asarray(pln.origin, float), pln.normal, 2 * PLANE_HALF))
    m = len(frames)
    q = np.zeros((m, mech.n))
    for s in SIDES:
        q[:, joints[s]] = qf[s]
    rec.q = q
    rec.times = np.array([f.t for f in frames], float)
    rec.qd = frame_rates(rec.times, q)
    rec.frame_columns = _frame_columns(mech, joints, frames, steps, rec.times, q, rec.qd)
    if not scenario.spec.outputs.mcap:
        return rec
    kin = forward_kinematics(mech, q)
    rec.frame_root, rec.frame_names, rec.frame_parents, rec.T_parent_child = frame_tree(
        mech, kin)  # rooted at the body frame
    rec.frame_names, rec.frame_parents = list(rec.frame_names), list(rec.frame_parents)
    from mechkin.tasks.robot import robot_description

    rec.robot = robot_description(mech)
    rec.joint_names = list(mech.joint_names)
    rec.polylines = polys
    rec.T_0_G = np.stack([_body(f, steps) for f in frames])
    two = any(len(_distinct([st.leg_plane(s) for s in SIDES])) > 1 for st in steps)
    rec.T_plane = np.stack([[_plane_pose(steps[f.step].leg_plane(s))
                             for s in (SIDES if two else SIDES[:1])] for f in frames])
    rec.contacts = np.stack([[f.legs[s].p_contact if f.legs[s].ok
                              else polys[i][f"leg_{s}"][-1] for s in SIDES]
                             for i, f in enumerate(frames)])
    rec.label_texts = [f"{steps[f.step].label} ({steps[f.step].mode})" for f in frames]
    rec.state = _state(frames, steps, qf)
    rec.state_schema = state_schema()
    rec.metadata = {"scenario": scenario.name, "mechanism": mech.name, "task": "ik",
                    "section": "biped"}
    return rec

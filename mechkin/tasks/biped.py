"""The biped task (``mechkin ik`` with a ``biped:`` section): a hwang2023-type biped on
inclined planes, one case or a walk -> skate -> roll switching sequence.

:func:`run` converts the section to SI steps, solves them with
:func:`mechkin.solvers.biped.solve_sequence` (closed forms of hwang2023 §2.2-§2.4), checks every
leg by forward kinematics (the closed-form chain and the mechanism file's model), evaluates the
``expect:`` entries and returns a :class:`~mechkin.records.Report` whose
:class:`~mechkin.records.biped.BipedRecord` ``mechkin.io.biped_out`` writes (``leg_right.csv``,
``leg_left.csv``, ``biped.png``, ``biped.mcap``). Writes nothing.

Imports: config, model, solvers, spatial, records, tasks.common.
"""

from __future__ import annotations

import math
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
from mechkin.solvers.biped import (
    EE_FRAMES,
    SIDES,
    BipedFrame,
    BipedStep,
    LegInput,
    StepResult,
    check_mechanism,
    solve_sequence,
)
from mechkin.solvers.closed_form.biped_leg import (
    HWANG2023_ESTIMATED,
    STATUS_OK,
    BipedGeometry,
    InclinedPlane,
    LegSolution,
    LegTask,
    biped_polylines,
    body_transform,
    psi_from_ee_rotation,
)
from mechkin.spatial.euler_conventions import Side, contact_angles_from_matrix
from mechkin.spatial.transforms import T_from
from mechkin.tasks.common import expect_messages, output_flags, with_expect

PLANE_HALF = 0.35  # [m] half side of the drawn plane


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(float(x)) else None


# --------------------------------------------------------------------------- config -> SI


def _step_si(step: StepSpec, spec: BipedSpec, units: Any, k: int) -> tuple[BipedStep, dict]:
    pl = plane_si(step.plane or spec.plane, units)
    plane = InclinedPlane(pl["origin"], pl["lam_x"], pl["lam_y"], pl["gam_x"])
    pos, thz = body_si(step.body or spec.body, units)
    TG = body_transform(pos, thz)
    legs = {}
    for side in SIDES:
        t = leg_si(getattr(step.legs, side), units)
        legs[side] = LegInput(t["position"], t["below_hip"], float(t["beta_z"]), t["beta"],
                              t["theta6"], t["branch"])
    bs = BipedStep(step.mode, plane, TG, legs, step.name or f"{step.mode} {k}",
                   float(step.duration), int(step.frames))
    info = {"plane": {"lam_x": pl["lam_x"], "lam_y": pl["lam_y"], "gam_x": pl["gam_x"],
                      "origin_m": list(pl["origin"]), "normal": plane.normal.tolist()},
            "body": {"position_m": pos.tolist(), "theta_z": float(thz)}}
    return bs, info


# --------------------------------------------------------------------------- summary


def _leg_record(mech: Mechanism, joints: list[int], side: Side, leg: LegSolution, kind: str,
                plane: InclinedPlane, TG: np.ndarray, task: LegTask, n_alt: int,
                mode: str) -> dict[str, Any]:
    names = [mech.joint_names[j] for j in joints]
    rec: dict[str, Any] = {"status": leg.status, "branch": leg.branch, "method": leg.method,
                           "n_solutions": n_alt}
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
    q = np.zeros((1, mech.n))
    q[0, joints] = leg.q
    fr = EE_FRAMES[side][0 if kind == "blade" else 1]
    T_model = TG @ forward_kinematics(mech, q).frames(mech, [mech.frame_index(fr)])[0, 0]
    rec["model_fk_error_m"] = float(np.linalg.norm(T_model[:3, 3] - leg.T_0_E[:3, 3]))
    rec["end_effector_m"] = leg.T_0_E[:3, 3].tolist()
    rec["contact_point_m"] = leg.p_contact.tolist()
    n = plane.normal
    rec["contact_plane_distance_m"] = float(n @ (leg.p_contact - np.asarray(plane.origin)))
    up = -leg.T_0_E[:3, 2]
    rec["normal_angle"] = float(np.arccos(np.clip(up @ n, -1.0, 1.0)))
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


def _step_record(mech: Mechanism, joints: dict[str, list[int]], k: int, step: BipedStep,
                 info: dict, res: StepResult, t_end: float) -> dict[str, Any]:
    kind = "foot" if step.mode == "walk" else "blade"
    return {
        "index": k, "name": step.label, "mode": step.mode, "t_s": t_end, "status": res.status,
        "kind": kind, "plane": info["plane"], "body": info["body"],
        "legs": {s: _leg_record(mech, joints[s], s, res.legs[s], kind, step.plane,
                                step.T_0_G, res.tasks[s], len(res.solution.alternatives[s]),
                                step.mode)
                 for s in SIDES},
    }


# --------------------------------------------------------------------------- the run


def run(scenario: Scenario, **_options: Any) -> Report:
    """Solve the scenario's biped case or switching sequence; the report holds the summary,
    the ``expect:`` results and the :class:`BipedRecord` of every output."""
    spec: BipedSpec = scenario.section
    units = scenario.spec.units
    geometry = HWANG2023_ESTIMATED
    if scenario.mechanism_path is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: required key is missing")
    mech = load_mechanism(scenario.mechanism_path)
    joints = check_mechanism(mech, geometry)

    pairs = [_step_si(s, spec, units, k) for k, s in enumerate(spec.steps())]
    steps = [p[0] for p in pairs]
    results, frames = solve_sequence(geometry, steps)
    t_ends = _step_end_times(steps)
    records = [_step_record(mech, joints, k, steps[k], pairs[k][1], results[k], t_ends[k])
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
                     "estimated": list(geometry.estimated)},
        "steps": records,
    }
    checks = with_expect(summary, scenario)
    data = _record(scenario, mech, joints, geometry, steps, records, frames)
    return Report(task="biped", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=summary["status"] == "ok", writer="biped", data=data,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=expect_messages(checks, scenario.path))


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


def _snapshot_label(r: dict[str, Any]) -> str:
    bits = []
    for s in SIDES:
        leg = r["legs"][s]
        if "beta" in leg:
            bits.append(f"{s[0].upper()} {leg['beta_kind'].replace('beta_', 'b')}="
                        f"{leg['beta_deg']:.2f}")
    return f"{r['name']} ({r['mode']}) " + ", ".join(bits)


def _state(frames: list[BipedFrame], steps: list[BipedStep],
           qf: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    state = []
    for i, f in enumerate(frames):
        step = steps[f.step]
        st: dict[str, Any] = {"step": int(f.step), "phase": step.label, "mode": step.mode,
                              "status": next((f.legs[s].status for s in SIDES
                                              if not f.legs[s].ok), STATUS_OK)}
        for s in SIDES:
            leg = f.legs[s]
            st[f"theta6_{s}_deg"] = float(np.rad2deg(qf[s][i, 5]))
            st[f"beta_{s}_deg"] = _num(np.rad2deg(leg.beta)) if leg.ok else None
            st[f"position_error_{s}_m"] = _num(leg.position_error) if leg.ok else None
            st[f"orientation_error_{s}_rad"] = _num(leg.orientation_error) if leg.ok else None
        state.append(st)
    return state


def _record(scenario: Scenario, mech: Mechanism, joints: dict[str, list[int]],
            geometry: BipedGeometry, steps: list[BipedStep], records: list[dict[str, Any]],
            frames: list[BipedFrame]) -> BipedRecord:
    qf = _frame_q(frames)
    polys = [biped_polylines(geometry, steps[f.step].T_0_G, qf["right"][i], qf["left"][i],
                             kind=f.kind, plane=steps[f.step].plane, plane_half_size=PLANE_HALF)
             for i, f in enumerate(frames)]
    rec = BipedRecord(title=scenario.name, mechanism=mech.name,
                      columns={s: _csv_columns(mech, joints[s], s, records) for s in SIDES},
                      plot_title=f"{scenario.name} (geometry ESTIMATED)", plane_half=PLANE_HALF)
    # plot: one panel per step (its last frame), at most 12
    last = {f.step: i for i, f in enumerate(frames)}
    idx = [last[k] for k in sorted(last)][-12:]
    seen: list[np.ndarray] = []
    for i in idx:
        rec.snapshots.append(BipedPlot(polys[i], _snapshot_label(records[frames[i].step])))
    for i in idx:
        pln = steps[frames[i].step].plane
        key = np.r_[pln.origin, pln.normal]
        if not any(np.allclose(key, s) for s in seen):
            seen.append(key)
            rec.plot_planes.append((np.asarray(pln.origin, float), pln.normal, 2 * PLANE_HALF))
    if not scenario.spec.outputs.mcap:
        return rec
    m = len(frames)
    q = np.zeros((m, mech.n))
    for s in SIDES:
        q[:, joints[s]] = qf[s]
    kin = forward_kinematics(mech, q)
    rec.frame_root, rec.frame_names, rec.frame_parents, rec.T_parent_child = frame_tree(
        mech, kin)  # rooted at the body frame
    rec.frame_names, rec.frame_parents = list(rec.frame_names), list(rec.frame_parents)
    rec.joint_names = list(mech.joint_names)
    rec.q = q
    rec.times = np.array([f.t for f in frames], float)
    rec.polylines = polys
    rec.T_0_G = np.stack([steps[f.step].T_0_G for f in frames])
    rec.T_plane = np.stack([T_from(steps[f.step].plane.rotation("right"),
                                   np.asarray(steps[f.step].plane.origin, float))
                            for f in frames])[:, None]
    rec.contacts = np.stack([[f.legs[s].p_contact if f.legs[s].ok
                              else polys[i][f"leg_{s}"][-1] for s in SIDES]
                             for i, f in enumerate(frames)])
    rec.label_texts = [f"{steps[f.step].label} ({steps[f.step].mode})" for f in frames]
    rec.state = _state(frames, steps, qf)
    rec.metadata = {"scenario": scenario.name, "mechanism": mech.name, "task": "ik",
                    "section": "biped"}
    return rec

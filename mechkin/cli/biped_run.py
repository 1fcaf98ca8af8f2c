"""``mechkin ik`` with a ``biped:`` section: the hwang2023 biped on an inclined plane.

:func:`run_biped` solves one case or a walk -> skate -> roll switching sequence with the closed
forms of :mod:`mechkin.solvers.closed_form.biped_leg` (§2.2 known pose, §2.3 unknown blade tilt,
§2.4 rolling), checks every leg by forward kinematics (the closed-form chain and the mechanism
file's model), evaluates the ``expect:`` entries and writes, staged so that a failure writes
nothing: ``summary.json``, ``leg_right.csv``, ``leg_left.csv`` (one row per step), ``biped.png``
(the biped standing on its plane, like hwang2023 Figs. 7/8) and ``biped.mcap`` (/tf, /scene with
the plane, body, legs, feet or blades and the phase, /joint_states, /mechkin/state).

The leg geometry is :data:`HWANG2023_ESTIMATED` (ESTIMATED from Table 6; the paper's lengths are
lost); the mechanism file must describe the same legs (checked by forward kinematics).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.cli.common import evaluate_expect, report_expect
from mechkin.config.biped_spec import BipedSpec, StepSpec, body_si, leg_si, plane_si
from mechkin.config.scenario import Scenario
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.drawing import frame_tree
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.biped_leg import (
    HWANG2023_ESTIMATED,
    STATUS_OK,
    STATUS_UNREACHABLE,
    BipedGeometry,
    InclinedPlane,
    LegSolution,
    LegTask,
    biped_polylines,
    body_transform,
    contact_below_hip,
    leg_fk,
    psi_from_ee_rotation,
    solve_biped_case,
)
from mechkin.spatial.euler_conventions import Side, contact_angles_from_matrix
from mechkin.spatial.transforms import T_from

SIDES: tuple[Side, Side] = ("right", "left")
EE_FRAMES = {"right": ("e6_r", "foot_r"), "left": ("e6_l", "foot_l")}
MODEL_TOL = 1e-9  # [m] mechanism file vs closed-form chain
PLANE_HALF = 0.35  # [m] half side of the drawn plane
_ROT_TOL = 1e-9


# --------------------------------------------------------------------------- mechanism


def _leg_joints(mech: Mechanism, frame: str) -> list[int]:
    """Joint indices from the body to ``frame``'s link, in chain order."""
    try:
        link = int(mech.frame_link[mech.frame_index(frame)])
    except KeyError as exc:
        raise ConfigError(f"{mech.source}: the biped needs a frame {frame!r}: {exc}") from None
    out: list[int] = []
    while mech.link_parent_joint[link] >= 0:
        j = int(mech.link_parent_joint[link])
        out.append(j)
        link = int(mech.joint_parent_link[j])
    return out[::-1]


def check_mechanism(mech: Mechanism, geometry: BipedGeometry) -> dict[str, list[int]]:
    """Joint indices of each leg; ConfigError unless the file's legs equal the closed-form ones
    (E and the sole point at random joint angles, to ``MODEL_TOL``)."""
    joints = {s: _leg_joints(mech, EE_FRAMES[s][0]) for s in SIDES}
    bad = [s for s in SIDES if len(joints[s]) != 6]
    if bad:
        raise ConfigError(f"{mech.source}: expected 6 joints from the body to "
                          f"{EE_FRAMES[bad[0]][0]}, got {len(joints[bad[0]])}")
    rng = np.random.default_rng(6)
    qs = rng.uniform(-1.0, 1.0, (3, 6))
    q = np.zeros((3, mech.n))
    for s in SIDES:
        q[:, joints[s]] = qs
    kin = forward_kinematics(mech, q)
    for s in SIDES:
        idx = [mech.frame_index(f) for f in EE_FRAMES[s]]
        T = kin.frames(mech, idx)
        for k, kind in enumerate(("blade", "foot")):
            ref = leg_fk(geometry, s, qs, np.eye(4), kind)[:, :3, 3]
            err = float(np.abs(T[:, k, :3, 3] - ref).max())
            if err > MODEL_TOL:
                raise ConfigError(
                    f"{mech.source}: the {s} leg to frame {EE_FRAMES[s][k]!r} differs from the "
                    f"hwang2023 closed-form leg by {err:.3g} m (expected the legs of Eq. 1 "
                    "with the HWANG2023_ESTIMATED geometry)")
    return joints


# --------------------------------------------------------------------------- solving


def _failed(status: str, method: str, branch: str) -> LegSolution:
    return LegSolution(np.full(6, np.nan), status, math.inf, math.inf, branch, method=method)


def _pick(alts: tuple[LegSolution, ...], branch: str | None,
          prev: np.ndarray | None) -> LegSolution:
    ok = [a for a in alts if a.ok and (branch is None or a.branch == branch)]
    if not ok:
        if branch is not None and any(a.ok for a in alts):
            return _failed(STATUS_UNREACHABLE, alts[0].method, branch)
        return alts[0]
    if prev is None:
        return ok[0]
    return min(ok, key=lambda r: float(np.linalg.norm(r.q - prev)))


def _start_state(geometry: BipedGeometry, plane: InclinedPlane, side: Side, q: np.ndarray,
                 TG: np.ndarray) -> tuple[np.ndarray, float]:
    """E_a and beta_Ya of the blade of the previous step's q (for a roll that follows it)."""
    T = leg_fk(geometry, side, q[None], TG, "blade")[0]
    _, beta, _ = contact_angles_from_matrix(psi_from_ee_rotation(T[:3, :3], side),
                                            plane.rotation(side), side, "blade")
    return T[:3, 3], float(beta)


def _solve_step(geometry: BipedGeometry, step: StepSpec, plane: InclinedPlane, TG: np.ndarray,
                units: Any, prev_q: dict[str, np.ndarray] | None,
                theta6_override: dict[str, float] | None = None) -> dict[str, Any]:
    tasks: dict[str, LegTask] = {}
    branches: dict[str, str | None] = {}
    for side in SIDES:
        t: dict[str, Any] = leg_si(getattr(step.legs, side), units)
        branches[side] = t["branch"]  # type: ignore[assignment]
        beta = t["beta"]
        if t["position"] is not None:
            p = np.asarray(t["position"])
        elif t["below_hip"] is not None:
            p = contact_below_hip(geometry, plane, TG, side, t["below_hip"])
        elif step.mode == "roll" and prev_q is not None and np.all(np.isfinite(prev_q[side])):
            p, beta0 = _start_state(geometry, plane, side, prev_q[side], TG)
            beta = beta0 if beta is None else beta
        else:
            p = contact_below_hip(geometry, plane, TG, side)
        theta6 = t["theta6"]
        if theta6_override is not None:
            theta6 = theta6_override[side]
        if step.mode == "walk" or step.mode == "roll":
            beta = 0.0 if beta is None else beta
        elif beta is None and theta6 is None:
            beta = 0.0
        tasks[side] = LegTask(tuple(float(v) for v in p), float(t["beta_z"]),  # type: ignore
                              None if beta is None else float(beta),
                              None if theta6 is None else float(theta6))
    sol = solve_biped_case(plane, step.mode, T_0_G=TG, right=tasks["right"],
                           left=tasks["left"], geometry=geometry, previous=prev_q)
    legs = {s: _pick(sol.alternatives[s], branches[s], None if prev_q is None else prev_q[s])
            for s in SIDES}
    return {"solution": sol, "legs": legs, "tasks": tasks, "branches": branches}


# --------------------------------------------------------------------------- records


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(float(x)) else None


def _leg_record(geometry: BipedGeometry, mech: Mechanism, joints: list[int], side: Side,
                leg: LegSolution, kind: str, plane: InclinedPlane, TG: np.ndarray,
                task: LegTask, n_alt: int, mode: str) -> dict[str, Any]:
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


# --------------------------------------------------------------------------- the run


def run_biped(*, scenario: Scenario, out_dir: Path, plots: bool = True
              ) -> tuple[dict[str, Any], int]:
    """Solve the scenario's biped case or switching sequence and write every output.

    Returns the summary and the exit code (0: every leg of every step solved and every
    ``expect:`` held; 1 otherwise, the outputs still written).
    """
    spec: BipedSpec = scenario.section
    units = scenario.spec.units
    geometry = HWANG2023_ESTIMATED
    if scenario.mechanism_path is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: required key is missing")
    mech = load_mechanism(scenario.mechanism_path)
    joints = check_mechanism(mech, geometry)

    steps = spec.steps()
    frames: list[dict[str, Any]] = []  # one per MCAP step
    records: list[dict[str, Any]] = []
    prev_q: dict[str, np.ndarray] | None = None
    t = 0.0
    for k, step in enumerate(steps):
        pl = plane_si(step.plane or spec.plane, units)
        plane = InclinedPlane(pl["origin"], pl["lam_x"], pl["lam_y"], pl["gam_x"])  # type: ignore
        pos, thz = body_si(step.body or spec.body, units)
        TG = body_transform(pos, thz)
        t_end = t + (step.duration if k > 0 else 0.0)
        label = step.name or f"{step.mode} {k}"
        kind = "foot" if step.mode == "walk" else "blade"
        if (step.mode == "roll" and step.frames > 1 and prev_q is not None
                and all(np.all(np.isfinite(prev_q[s])) for s in SIDES)):
            first = _solve_step(geometry, step, plane, TG, units, prev_q)
            t6b = {s: first["tasks"][s].theta6 for s in SIDES}
            t6a = {s: float(prev_q[s][5]) for s in SIDES}
            # every frame rolls from the same start state (E_a, beta_Ya: prev_q's blade) to an
            # intermediate ankle angle (Eq. 37 is path independent); the last frame is the step
            sub_prev = prev_q
            for j in range(1, step.frames + 1):
                f = j / step.frames
                if j < step.frames:
                    t6 = {s: t6a[s] + (t6b[s] - t6a[s]) * f for s in SIDES}
                    r = _solve_step(geometry, step, plane, TG, units, prev_q, t6)
                    r["legs"] = {s: _pick(r["solution"].alternatives[s],
                                          r["branches"][s], sub_prev[s]) for s in SIDES}
                else:
                    r = first
                frames.append({"t": t + (t_end - t) * f, "legs": r["legs"], "TG": TG,
                               "plane": plane, "kind": kind, "label": label, "step": k,
                               "mode": step.mode})
                if all(r["legs"][s].ok for s in SIDES):
                    sub_prev = {s: r["legs"][s].q for s in SIDES}
            res = first
        else:
            res = _solve_step(geometry, step, plane, TG, units, prev_q)
            frames.append({"t": t_end, "legs": res["legs"], "TG": TG, "plane": plane,
                           "kind": kind, "label": label, "step": k, "mode": step.mode})
        t = t_end
        legs = res["legs"]
        status = next((legs[s].status for s in SIDES if not legs[s].ok), STATUS_OK)
        records.append({
            "index": k, "name": label, "mode": step.mode, "t_s": t_end, "status": status,
            "kind": kind,
            "plane": {"lam_x": pl["lam_x"], "lam_y": pl["lam_y"], "gam_x": pl["gam_x"],
                      "origin_m": list(pl["origin"]), "normal": plane.normal.tolist()},  # type: ignore
            "body": {"position_m": pos.tolist(), "theta_z": float(thz)},
            "legs": {s: _leg_record(geometry, mech, joints[s], s, legs[s], kind, plane, TG,
                                    res["tasks"][s], len(res["solution"].alternatives[s]),
                                    step.mode)
                     for s in SIDES},
        })
        if all(legs[s].ok for s in SIDES):
            prev_q = {s: legs[s].q for s in SIDES}

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
    checks = evaluate_expect(summary, scenario.spec.expect)
    if checks:
        summary["expect"] = checks
    summary = _write_outputs(scenario, mech, joints, geometry, records, frames, summary,
                             out_dir, plots)
    report_expect(checks, scenario.path)
    ok = summary["status"] == "ok" and all(c["ok"] for c in checks)
    return summary, 0 if ok else 1


# --------------------------------------------------------------------------- outputs


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


def _frame_q(frames: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Per-frame q (m, 6) per leg; a failed leg keeps the last good q (home at first)."""
    out = {s: np.zeros((len(frames), 6)) for s in SIDES}
    for s in SIDES:
        last = np.zeros(6)
        for i, f in enumerate(frames):
            leg = f["legs"][s]
            if leg.ok:
                last = leg.q
            out[s][i] = last
    return out


def _polylines(geometry: BipedGeometry, frames: list[dict[str, Any]],
               qf: dict[str, np.ndarray]) -> list[dict[str, np.ndarray]]:
    out = []
    for i, f in enumerate(frames):
        pl = biped_polylines(geometry, f["TG"], qf["right"][i], qf["left"][i], kind=f["kind"],
                             plane=f["plane"], plane_half_size=PLANE_HALF)
        out.append(pl)
    return out


def _stack_contact(polys: list[dict[str, np.ndarray]], frames: list[dict[str, Any]],
                   prefix: str, side: str, other: str) -> np.ndarray:
    """(m, p, 3) of the ``prefix`` outline (foot/blade); collapsed to a point where the frame
    uses the other contact (so one Lines item with a fixed vertex count serves every step)."""
    key = f"{prefix}_{side}"
    p = next((len(pl[key]) for pl in polys if key in pl), None)
    if p is None:
        return np.zeros((0,))
    out = np.empty((len(polys), p, 3))
    for i, pl in enumerate(polys):
        if key in pl:
            out[i] = pl[key]
        else:
            out[i] = pl[f"{other}_{side}"][0]
    return out


def _write_outputs(scenario: Scenario, mech: Mechanism, joints: dict[str, list[int]],
                   geometry: BipedGeometry, records: list[dict[str, Any]],
                   frames: list[dict[str, Any]], summary: dict[str, Any], out_dir: Path,
                   plots: bool) -> dict[str, Any]:
    from mechkin.io import OutputDir

    outs = scenario.spec.outputs
    summary = dict(summary)
    summary["out_dir"] = str(out_dir)
    qf = _frame_q(frames)
    polys = _polylines(geometry, frames, qf)
    with OutputDir(out_dir) as od:
        if outs.csv:
            for s in SIDES:
                od.write_csv(f"leg_{s}.csv", _csv_columns(mech, joints[s], s, records))
        if plots and outs.plots:
            _plot(od.path_for("biped.png"), scenario, geometry, records, frames, polys)
        if outs.mcap:
            _mcap(od.path_for("biped.mcap"), scenario, mech, joints, geometry, frames, qf, polys)
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary


def _plot(path: Path, scenario: Scenario, geometry: BipedGeometry,
          records: list[dict[str, Any]], frames: list[dict[str, Any]],
          polys: list[dict[str, np.ndarray]]) -> None:
    from mechkin.io.plots import Stick, plot_stick_3d

    # one panel per step (its last frame), at most 12
    last = {f["step"]: i for i, f in enumerate(frames)}
    idx = [last[k] for k in sorted(last)][-12:]
    snaps, labels, planes = [], [], []
    for i in idx:
        pl = polys[i]
        items = [Stick(pl["body"], color="k", linewidth=2.5, label="body"),
                 Stick(pl["leg_right"], color="C3", label="right leg"),
                 Stick(pl["leg_left"], color="C0", label="left leg")]
        for s, c in (("right", "C3"), ("left", "C0")):
            for pre in ("foot", "blade"):
                if f"{pre}_{s}" in pl:
                    items.append(Stick(pl[f"{pre}_{s}"], color=c, linewidth=1.5, marker=""))
        snaps.append(items)
        r = records[frames[i]["step"]]
        bits = []
        for s in SIDES:
            leg = r["legs"][s]
            if "beta" in leg:
                bits.append(f"{s[0].upper()} {leg['beta_kind'].replace('beta_', 'b')}="
                            f"{leg['beta_deg']:.2f}")
        labels.append(f"{r['name']} ({r['mode']}) " + ", ".join(bits))
    seen: list[np.ndarray] = []
    for i in idx:
        pln: InclinedPlane = frames[i]["plane"]
        key = np.r_[pln.origin, pln.normal]
        if not any(np.allclose(key, s) for s in seen):
            seen.append(key)
            planes.append((np.asarray(pln.origin, float), pln.normal, 2 * PLANE_HALF))
    plot_stick_3d(path, snaps, f"{scenario.name} (geometry ESTIMATED)",
                  labels=labels, planes=planes, view=(18.0, -70.0))


def _mcap(path: Path, scenario: Scenario, mech: Mechanism, joints: dict[str, list[int]],
          geometry: BipedGeometry, frames: list[dict[str, Any]], qf: dict[str, np.ndarray],
          polys: list[dict[str, np.ndarray]]) -> None:
    from mechkin.io import Box, Label, Lines, MotionLog, Scene, Spheres, write_mcap

    m = len(frames)
    q = np.zeros((m, mech.n))
    for s in SIDES:
        q[:, joints[s]] = qf[s]
    kin = forward_kinematics(mech, q)
    root, names, parents, T_pc = frame_tree(mech, kin)  # rooted at the body frame
    TG = np.stack([f["TG"] for f in frames])
    T_plane = np.stack([T_from(f["plane"].rotation("right"), np.asarray(f["plane"].origin, float))
                        for f in frames])
    all_names = ["plane", root] + list(names)
    all_parents = ["world", "world"] + list(parents)
    T_all = np.concatenate([T_plane[:, None], TG[:, None], T_pc], axis=1)

    lines = [Lines(np.stack([p["body"] for p in polys]), rgba=(0.1, 0.1, 0.1, 1.0),
                   thickness=0.012),
             Lines(np.stack([p["leg_right"] for p in polys]), rgba=(0.85, 0.25, 0.2, 1.0),
                   thickness=0.01),
             Lines(np.stack([p["leg_left"] for p in polys]), rgba=(0.2, 0.4, 0.85, 1.0),
                   thickness=0.01)]
    for s in SIDES:
        for pre, other, rgba in (("foot", "blade", (0.4, 0.3, 0.2, 1.0)),
                                 ("blade", "foot", (0.7, 0.7, 0.75, 1.0))):
            pts = _stack_contact(polys, frames, pre, s, other)
            if pts.size:
                lines.append(Lines(pts, rgba=rgba, thickness=0.006))
    contacts = np.stack([[f["legs"][s].p_contact if f["legs"][s].ok
                          else polys[i][f"leg_{s}"][-1] for s in SIDES]
                         for i, f in enumerate(frames)])
    plane_box = Box(T_plane @ T_from(np.eye(3), np.array([0.0, 0.0, -0.001])),
                    np.array([2 * PLANE_HALF, 2 * PLANE_HALF, 0.002]), rgba=(0.4, 0.6, 0.85, 0.35))
    texts = [f"{f['label']} ({f['mode']})" for f in frames]
    label = Label(TG[:, :3, 3] + np.array([0.0, 0.0, 0.12]), texts, font_size=0.04)
    scene = Scene(lines=tuple(lines), spheres=(Spheres(contacts, radius=0.008),),
                  boxes=(plane_box,), labels=(label,), entity_id="biped")
    state = []
    for i, f in enumerate(frames):
        st: dict[str, Any] = {"step": int(f["step"]), "phase": f["label"], "mode": f["mode"],
                              "status": next((f["legs"][s].status for s in SIDES
                                              if not f["legs"][s].ok), STATUS_OK)}
        for s in SIDES:
            leg = f["legs"][s]
            st[f"theta6_{s}_deg"] = float(np.rad2deg(qf[s][i, 5]))
            st[f"beta_{s}_deg"] = _num(np.rad2deg(leg.beta)) if leg.ok else None
            st[f"position_error_{s}_m"] = _num(leg.position_error) if leg.ok else None
            st[f"orientation_error_{s}_rad"] = _num(leg.orientation_error) if leg.ok else None
        state.append(st)
    times = np.array([f["t"] for f in frames], float)
    write_mcap(path, MotionLog(
        times=times, root_frame="world", frame_names=all_names, frame_parents=all_parents,
        T_parent_child=T_all, joint_names=list(mech.joint_names), q=q, scene=scene,
        state=state, metadata={"scenario": scenario.name, "mechanism": mech.name,
                               "task": "ik", "section": "biped"}))

"""Four-bar change points and limit positions (issue 24): flagged, and no silent branch jump.

Link lengths typed in here (planar, pin cut with mask [x, y], crank-driven):

* ``parallelogram``: ground 0.5, crank 0.2, coupler 0.5, rocker 0.2 m (Grashof equality
  s + l = p + q: 0.2 + 0.5 = 0.2 + 0.5). At crank angles 0 and pi every link is in line: the
  parallelogram and the anti-parallelogram modes cross (a constraint singularity and a
  bifurcation). Closed form of the mode connected to home: q_coupler = -q_crank,
  q_rocker = q_crank (the coupler stays parallel to the ground).
* ``change_point``: ground 0.5, crank 0.2, coupler 0.4, rocker 0.3 m (0.2 + 0.5 = 0.4 + 0.3): at
  crank angle pi the coupler and rocker lie along the ground line and the two circle
  intersections (open and crossed modes) touch. The solution curve through that point is
  analytic in the crank angle and changes side there: the closed form is the circle
  intersection on the side ``-sign(cos(q_crank / 2))`` (home at 90 deg on side -1, the side
  flipping at every odd multiple of pi: a 4 pi periodic branch).
* ``triple_rocker``: ground 2.0, input 1.0, coupler 1.2, output 1.1 m (non-Grashof,
  1.0 + 2.0 > 1.2 + 1.1): the input rocks between its limit positions where coupler and output
  are in line, |A - O4| = 2.3 m, i.e. cos q = (1 + 4 - 2.3^2) / 4.

What mechkin does, and what is tested: through a change point the motion stays on the smooth
continuation of the branch it comes from (the mode connected to home along the path; a sample
exactly at the change point is reached over, never used as a base for the next step) and the fk
task labels the crossing (``constraint singularity`` at a sample on it, ``constraint singularity
crossed`` at the first sample past it). At a limit position the path stops: status
``constraint singularity`` for every requested value beyond it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import mechkin
from mechkin.model.closure import ClosureStatus
from mechkin.model.continuation import solve_motion
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load

FOURBAR = """
name: {name}
units: {{length: m, angle: deg}}
links:
  - name: ground
    frames:
      - {{name: rocker_pivot, xyz: [{g}, 0, 0]}}
  - name: crank
  - name: coupler
    frames:
      - {{name: coupler_end, xyz: [{b}, 0, 0]}}
  - name: rocker
    frames:
      - {{name: rocker_end, xyz: [{c}, 0, 0]}}
joints:
  - {{name: q_crank, type: revolute, parent: ground, child: crank, home: {h0}}}
  - {{name: q_coupler, type: revolute, parent: crank, child: coupler,
     origin: {{xyz: [{a}, 0, 0]}}, home: {h1}}}
  - {{name: q_rocker, type: revolute, parent: rocker_pivot, child: rocker, home: {h2}}}
cuts:
  - {{name: pin, frames: [coupler_end, rocker_end], mask: [x, y]}}
independent: [q_crank]
end_effector: coupler_end
"""
PARALLELOGRAM = FOURBAR.format(name="parallelogram", g=0.5, a=0.2, b=0.5, c=0.2,
                               h0=60, h1=-60, h2=60)
CHANGE_POINT = FOURBAR.format(name="change_point", g=0.5, a=0.2, b=0.4, c=0.3,
                              h0=90, h1=-78, h2=111)
TRIPLE_ROCKER = FOURBAR.format(name="triple_rocker", g=2.0, a=1.0, b=1.2, c=1.1,
                               h0=0, h1=59, h2=110)
TRIPLE_LIMIT = np.arccos((1.0 + 4.0 - 2.3**2) / 4.0)  # 94.157 deg


def fourbar_closed_form(th, g, a, b, c, side):
    """(m, 3) joints of the four-bar at crank angles th (m,), the circle intersection on
    ``side`` (m,) of cross(B - A, O4 - B)."""
    th = np.asarray(th, float).reshape(-1)
    A = a * np.column_stack([np.cos(th), np.sin(th)])
    O4 = np.broadcast_to([g, 0.0], A.shape)
    B = np.empty_like(A)
    for s in (1.0, -1.0):
        hit = np.asarray(side) == s
        if hit.any():
            B[hit] = M.circle_meet(A[hit], b, O4[hit], c, s)
    return np.column_stack([th, M.wrap(M.ang(B - A) - th), M.ang(B - O4)])


def parallelogram_ref(th):
    th = np.asarray(th, float).reshape(-1)
    return np.column_stack([th, -th, th])


def change_point_ref(th):
    th = np.asarray(th, float).reshape(-1)
    return fourbar_closed_form(th, 0.5, 0.2, 0.4, 0.3, -np.sign(np.cos(th / 2)))


def err(q, ref):
    return np.abs(M.wrap(q - ref)).max(axis=1)


# the other mode at the same crank angles (the anti-parallelogram; the crossed four-bar)
OTHER = {"parallelogram": lambda th: fourbar_closed_form(th, 0.5, 0.2, 0.5, 0.2,
                                                         np.sign(np.sin(th))),
         "change_point": lambda th: fourbar_closed_form(th, 0.5, 0.2, 0.4, 0.3,
                                                        np.sign(np.cos(th / 2)))}


@pytest.mark.parametrize("text, ref", [(PARALLELOGRAM, parallelogram_ref),
                                       (CHANGE_POINT, change_point_ref)],
                         ids=["parallelogram", "change_point"])
def test_rows_across_change_points_stay_on_the_smooth_branch(tmp_path, text, ref):
    mech, _ = load(tmp_path, text)
    th = np.random.default_rng(24).uniform(-3 * np.pi, 3 * np.pi, 100)
    res = mechkin.fk(mech, th[:, None])
    assert res.status == ["converged"] * 100
    assert err(res.q, ref(th)).max() <= 1e-10
    # the other mode is another answer at these rows (the check can fail)
    assert err(res.q, OTHER[mech.name](th)).min() > 1e-3


@pytest.mark.parametrize("step_deg", [7.0, 7.5, 15.0, 45.0])
@pytest.mark.parametrize("text, ref", [(PARALLELOGRAM, parallelogram_ref),
                                       (CHANGE_POINT, change_point_ref)],
                         ids=["parallelogram", "change_point"])
def test_motion_through_change_points_does_not_jump(tmp_path, text, ref, step_deg):
    # 7.5, 15 and 45 deg land exactly on the change points (0, +-180, ...): the step after such
    # a sample used to follow the minimum-norm tangent there onto the other mode
    mech, _ = load(tmp_path, text)
    h0 = 60.0 if "parallelogram" in text else 90.0
    th = np.radians(np.arange(h0, h0 - 730.0, -step_deg))
    res = solve_motion(mech, th[:, None])
    assert all(s is ClosureStatus.CONVERGED for s in res.status)
    e = err(res.q, ref(th))
    on_point = np.isclose(np.cos(th) ** 2, 1.0, atol=1e-12)  # a double root: sqrt(tol) digits
    assert e[~on_point].max() <= 1e-9 and e[on_point].max(initial=0.0) <= 1e-5


def _fk_task(tmp_path, text, start, stop, n, name):
    (tmp_path / f"{name}.yaml").write_text(text)
    sc = tmp_path / f"{name}_fk.yaml"
    sc.write_text(f"name: {name}_fk\ntask: fk\nmechanism: {name}.yaml\n"
                  "units: {length: m, angle: deg}\n"
                  f"fk:\n  time: {{start: 0, stop: 1, step: {1.0 / (n - 1)!r}}}\n"
                  f"  motion:\n    q_crank: {{type: ramp, from: {start}, to: {stop}}}\n"
                  "outputs: {csv: false, plots: false, mcap: false}\n")
    return mechkin.run(sc)


@pytest.mark.parametrize("n", [101, 121])
def test_fk_task_flags_the_change_points(tmp_path, n):
    # 60 -> -300 deg: the change points 0 and -180 stepped over (n = 101, 3.6 deg) or sampled
    # exactly (n = 121, 3 deg)
    rep = _fk_task(tmp_path, PARALLELOGRAM, 60, -300, n, "para")
    th = np.radians(np.linspace(60, -300, n))
    labels = np.array(rep.data.columns["singularity"])
    assert rep.summary["status"] == "ok" and rep.exit_code == 0
    assert err(np.asarray(rep.data.q), parallelogram_ref(th)).max() <= 1e-5
    flagged = np.flatnonzero([lab.startswith("constraint singularity") for lab in labels])
    # the first sample at or past each change point
    want = [int(np.argmax(th <= 1e-12)), int(np.argmax(th <= -np.pi + 1e-12))]
    assert flagged.tolist() == want
    if n == 121:  # exactly on the change points
        assert all(labels[k].startswith("constraint singularity") for k in want)
        assert not any("crossed" in labels[k] for k in want)
    else:
        assert all(labels[k].startswith("constraint singularity crossed") for k in want)
    assert rep.summary["singularity"]["first_singular_step"] == want[0]
    assert any("passes a singularity" in m for m in rep.messages)


def test_fk_task_on_a_crank_rocker_flags_nothing(tmp_path):
    # the Grashof crank-rocker of tests/data/fourbar.yaml (0.3, 1.0, 0.8, ground 1.0) turns its
    # crank fully without a change point: no false crossing
    from pathlib import Path

    text = (Path(__file__).parents[1] / "data" / "fourbar.yaml").read_text()
    rep = _fk_task(tmp_path, text, 60, 420, 97, "crank_rocker")
    assert rep.summary["status"] == "ok"
    assert set(rep.data.columns["singularity"]) <= {"regular",
                                                          "near inverse-kinematic singularity"}


def test_change_point_four_bar_crossings_flagged(tmp_path):
    rep = _fk_task(tmp_path, CHANGE_POINT, 90, 630, 101, "cp")  # crosses 180 and 540 deg
    th = np.radians(np.linspace(90, 630, 101))
    labels = rep.data.columns["singularity"]
    flagged = [k for k, lab in enumerate(labels) if lab.startswith("constraint singularity")]
    assert flagged == [int(np.argmax(th >= np.pi)), int(np.argmax(th >= 3 * np.pi))]
    assert rep.summary["status"] == "ok"


def test_triple_rocker_limit_position_stops_the_motion(tmp_path):
    rep = _fk_task(tmp_path, TRIPLE_ROCKER, 0, 120, 121, "tr")
    th = np.radians(np.linspace(0, 120, 121))
    beyond = th > TRIPLE_LIMIT
    st = np.array(rep.data.columns["status"])
    s = rep.summary
    assert s["status"] == "constraint singularity" and rep.exit_code == 1
    assert s["steps"]["constraint singularity"] == int(beyond.sum()) == 26
    assert s["steps"]["converged"] == int((~beyond).sum())
    assert s["first_failure_step"] == int(np.argmax(beyond))
    if st.size:
        assert (st[beyond] == "constraint singularity").all()
    mech, _ = load(tmp_path, TRIPLE_ROCKER, "tr2.yaml")
    side = np.sign(M.cross2(np.array([0.615, 1.0305]), np.array([0.385, -1.0305])))
    inside = th[~beyond]
    res = mechkin.fk(mech, inside[:, None])
    assert res.status == ["converged"] * len(inside)
    ref = fourbar_closed_form(inside, 2.0, 1.0, 1.2, 1.1, np.full(len(inside), side))
    assert err(res.q, ref).max() <= 1e-10
    out = mechkin.fk(mech, [[TRIPLE_LIMIT + 0.05], [-TRIPLE_LIMIT - 0.2]])
    assert out.status == ["constraint singularity"] * 2
    # stopped at the limit position, not somewhere else
    assert np.allclose(np.abs(out.q[:, 0]), TRIPLE_LIMIT, atol=1e-4)
    json.dumps(rep.summary["singularity"])


def test_chunked_motion_through_change_points_matches_one_run(tmp_path):
    # the fk split over workers (mechkin.solvers.distributed): chunks and the coarse warm-start
    # pass go through the same branch checks; 3 deg steps sample the change points exactly
    from mechkin.solvers.distributed import solve_trajectory_chunks
    from mechkin.solvers.workspace.sweeps import run_jobs

    mech, _ = load(tmp_path, PARALLELOGRAM)
    th = np.radians(np.arange(60.0, 60.0 - 3 * 600, -3.0))
    res, info = solve_trajectory_chunks(
        mech, th[:, None], mech.home[mech.dependent], chunk_steps=100,
        run_jobs=lambda fn, jobs, prog: run_jobs(fn, jobs, workers=1, progress=prog))
    assert info["chunks"] == 6
    assert all(s is ClosureStatus.CONVERGED for s in res.status)
    e = err(res.q, parallelogram_ref(th))
    on_point = np.isclose(np.cos(th) ** 2, 1.0, atol=1e-12)
    assert e[~on_point].max() <= 1e-9 and e[on_point].max() <= 1e-5


def _multiples_between(a_deg, b_deg, period_deg, first_deg):
    """Change points (first + k period) strictly between a and b (neither end on one)."""
    lo, hi = min(a_deg, b_deg), max(a_deg, b_deg)
    k = np.arange(np.ceil((lo - first_deg) / period_deg), np.floor((hi - first_deg)
                                                                   / period_deg) + 1)
    pts = first_deg + k * period_deg
    return int(np.sum((pts > lo) & (pts < hi)))


@pytest.mark.parametrize("text, home, first, period", [(PARALLELOGRAM, 60.0, 0.0, 180.0),
                                                       (CHANGE_POINT, 90.0, 180.0, 360.0)],
                         ids=["parallelogram", "change_point"])
def test_api_fk_flags_rows_reached_across_a_change_point(tmp_path, text, home, first, period):
    # mechkin.fk reaches each row from home along q_v; a row whose path passes a change point
    # is converged (on the smooth branch) and flagged singularity_crossed, alone or in a batch
    mech, _ = load(tmp_path, text)
    th = np.random.default_rng(5).uniform(-250.0, 350.0, 60)
    th = th[np.abs((th - first) / period - np.round((th - first) / period)) * period > 1.0]
    res = mechkin.fk(mech, np.radians(th)[:, None])
    want = [_multiples_between(home, t, period, first) > 0 for t in th]
    assert res.status == ["converged"] * len(th)
    assert 10 <= sum(want) <= len(th) - 10
    assert res.singularity_crossed == want
    alone = [mechkin.fk(mech, [np.radians(t)]).singularity_crossed[0] for t in th[:12]]
    assert alone == want[:12]
    # a guess per row: Newton from it, no path, no crossing claimed
    g = mechkin.fk(mech, np.radians(th)[:, None], q_w0=res.q[:, mech.dependent])
    assert g.singularity_crossed == [False] * len(th)


def test_track_path_ik_counts_the_change_point_it_passes(tmp_path):
    # the parallelogram's coupler end held to y only (mask [y]) along y 0.1 -> -0.1 m: the
    # crank goes 30 -> -30 deg on the parallelogram branch through the change point at 0
    from mechkin.solvers.track.closed_path_ik import ClosedHandLineIK

    mech, _ = load(tmp_path, PARALLELOGRAM)
    f = mech.frame_index("coupler_end")
    q0 = mechkin.fk(mech, [[np.radians(30.0)]]).q[0]
    ik = ClosedHandLineIK(mech, f, np.array([0.0, 0.1, 0.0]), np.array([0.0, -0.1, 0.0]), q0,
                          1e-9, mask=["y"])
    r = np.linspace(0.0, 1.0, 11)
    th = np.arcsin(np.linspace(0.1, -0.1, 11) / 0.2)
    assert err(ik.q(r), parallelogram_ref(th)).max() <= 1e-7
    assert ik.singularities_crossed() == 1
    short = ClosedHandLineIK(mech, f, np.array([0.0, 0.1, 0.0]), np.array([0.0, 0.05, 0.0]),
                             q0, 1e-9, mask=["y"])
    assert short.singularities_crossed() == 0


def test_joint_sweep_labels_change_point_crossings(tmp_path):
    # a crank grid stepping over the parallelogram's change point (between -4 and 4 deg) and
    # sampling the change-point four-bar's (180 deg) exactly; the crank-rocker none
    from pathlib import Path

    from mechkin.solvers.workspace.joint_sweep import joint_sweep

    cases = [(PARALLELOGRAM, np.linspace(-172.0, 172.0, 44), [4.0], parallelogram_ref),
             (CHANGE_POINT, np.linspace(90.0, 300.0, 43), [180.0], change_point_ref),
             ((Path(__file__).parents[1] / "data" / "fourbar.yaml").read_text(),
              np.linspace(60.0, 400.0, 35), [], None)]
    for i, (text, th_deg, want, ref) in enumerate(cases):
        mech, _ = load(tmp_path, text, f"m{i}.yaml")
        th = np.radians(th_deg)
        f = mech.end_effector
        rec = joint_sweep(mech, th[:, None], f, grid_shape=(len(th),), manipulability=False)
        assert rec.converged.all()
        assert np.degrees(th[rec.crossed]).round(6).tolist() == want
        assert not (rec.crossed & ~rec.mode_change).any()
        if ref is not None:  # stayed on the smooth branch (the flag is a crossing, not a jump)
            assert err(rec.q, ref(th)).max() <= 1e-6


def test_workspace_task_counts_change_point_crossings(tmp_path):
    (tmp_path / "para.yaml").write_text(PARALLELOGRAM)
    sc = tmp_path / "sweep.yaml"
    sc.write_text("name: para_sweep\ntask: workspace\nmechanism: para.yaml\n"
                  "units: {length: m, angle: deg}\nworkspace:\n  kind: joint_sweep\n"
                  "  method: grid\n  joints:\n    q_crank: {range: [-172, 172], n: 44}\n"
                  "  manipulability: false\n"
                  "outputs: {csv: false, plots: false, mcap: false}\n")
    rep = mechkin.run(sc)
    c = rep.summary["continuation"]
    assert c["n_constraint_singularities_crossed"] == 1 and c["n_mode_changes"] == 1
    assert rep.summary["n_reachable"] == 44

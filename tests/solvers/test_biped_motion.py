"""Issue 12: a continuous walk -> skate -> roll -> unroll -> walk motion of a biped.

Run end to end through :func:`mechkin.tasks.run_file` (the scenario is written into tmp_path) on
the bundled hwang2023 biped (plane (a) of Table 5, ESTIMATED geometry) and on the non-paper
``mechanisms/custom_biped.yaml`` (tilted and turned body, a plane tilted about both axes, toe
turned out, the right blade rolled to an ankle angle and the left one to a tilt). Every step
after the first is sampled with ``frames > 1``, so the log is one continuous motion:

* walk -> skate: the blade frame E moves from where the standing foot holds it to the upright
  blade pose (line + slerp, every frame the §2.2 closed form of the blade class);
* roll: §2.4 rolling without slipping (right: to theta6, left: to a tilt beta_end);
* unroll: ``beta_end: 0`` back to the upright blade (Eq. 37, then §2.2);
* skate -> walk: the foot frame moves back to the walking pose of the first step.

Checked: (a) continuity, (b) the unroll ends at tilt 0, (c) the last frame is the first pose,
and the per-frame joint rates of ``frames.csv`` and ``/joint_states``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from mechkin.io.csv_out import read_csv
from mechkin.tasks import run_file

ROOT = Path(__file__).resolve().parents[2]
SIDES = ("right", "left")
N = 8  # frames per step of the coarse run; the fine run has REFINE * N
REFINE = 4
C_JUMP = (REFINE**0.5 + REFINE) / 2  # = 3, the continuity bound's factor (see its test)

SCENARIO = """name: {name}
task: ik
mechanism: {mech}
units: {{length: mm, angle: deg}}
biped:
  plane: {plane}
  body: {body}
  sequence:
    - {{name: walk, mode: walk, legs: {walk}}}
    - {{name: skate, mode: skate, frames: {ns}, time_law: smooth, legs: {skate}}}
    - {{name: roll, mode: roll, frames: {n}, duration: 2.0, legs: {roll}}}
    - {{name: unroll, mode: roll, frames: {n}, time_law: smooth, legs: {unroll}}}
    - {{name: walk back, mode: walk, frames: {n}, duration: 1.5, legs: {walk}}}
"""

BIPEDS = {
    # hwang2023 Fig. 7 (a) -> (b) -> rolled to theta6 = 20 deg (c) -> back upright -> (a)
    "hwang2023": {
        "mech": ROOT / "mechanisms" / "hwang2023_biped.yaml",
        "plane": "{lam_x: 0, lam_y: 15, gam_x: 0, origin: [0, 0, 0]}",
        "body": "{position: [0, 0, 677.205]}",
        "walk": "{right: {beta: 0}, left: {beta: 0}}",
        "skate": "{right: {beta: 0}, left: {beta: 0}}",
        "roll": "{right: {theta6: 20}, left: {theta6: 20}}",
        "unroll": "{right: {beta_end: 0}, left: {beta_end: 0}}",
    },
    # a non-paper biped (geometry and joint limits from its file), everything off-axis
    "custom_biped": {
        "mech": ROOT / "mechanisms" / "custom_biped.yaml",
        "plane": "{lam_x: 4, lam_y: 8, gam_x: 2, origin: [0, 0, 0]}",
        "body": "{position: [10, -5, 600], theta_x: 2, theta_y: -3, theta_z: 5}",
        "walk": "{right: {beta: 0, beta_z: 6}, left: {beta: 0, below_hip: [0, 15]}}",
        "skate": "{right: {beta: 0, beta_z: 6}, left: {beta: 0, below_hip: [0, 15]}}",
        "roll": "{right: {theta6: 5, beta_z: 6}, left: {beta_end: -12}}",
        "unroll": "{right: {beta_end: 0, beta_z: 6}, left: {beta_end: 0}}",
    },
}


def _run(tmp_path: Path, biped: str, n: int, n_skate: int | None = None):
    p = tmp_path / f"{biped}_{n}_{n_skate}.yaml"
    p.write_text(SCENARIO.format(name=f"{biped}_motion", n=n,
                                 ns=n if n_skate is None else n_skate, **BIPEDS[biped]))
    rep = run_file(p, "ik")
    assert rep.ok, rep.summary["status"]
    return rep


@pytest.fixture(scope="module", params=sorted(BIPEDS))
def runs(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp(request.param)
    return (request.param, _run(tmp, request.param, N),
            _run(tmp, request.param, REFINE * N), tmp)


def _segments(rep) -> dict[int, np.ndarray]:
    """Per step k >= 1: its frames' q (all leg joints) preceded by the frame it starts from
    (the previous step's last frame), so the switch between steps is inside the segment."""
    steps = np.array([r["step"] for r in rep.data.state])
    q = rep.data.q
    out = {}
    for k in range(1, int(steps.max()) + 1):
        idx = np.flatnonzero(steps == k)
        out[k] = q[np.r_[idx[0] - 1, idx]]
    return out


def _max_jump(seg: np.ndarray) -> float:
    return float(np.abs(np.diff(seg, axis=0)).max())


def test_joint_angles_are_continuous(runs):
    """Each step k is a path q_k(s), s in [0, 1] from the frame the previous step left (s = 0)
    to the step's pose (s = 1), sampled at ds = 1/n. By the mean value theorem the largest jump
    of any joint between consecutive frames is at most L_k ds, L_k = max over the step and the
    joints of |dq/ds|. L_k is estimated from the coarse run (n = N): L_k ~= (its largest
    jump) / ds_N. The bound checked on the fine run (n = R N, R = REFINE = 4) is

        max jump <= C L_k ds,   ds = 1 / (R N),   C = C_JUMP = (sqrt(R) + R) / 2 = 3.

    Why C = 3: the coarse estimate is low where the path is steep. The upright blade of
    hwang2023 Table 6 (b) holds the right knee 5 deg from straight, where theta4 grows like the
    square root of the hip-ankle shortening, so at the start of the roll q_k(s) behaves like
    sqrt(s) over the first frames (measured: the largest jump per ds grows 1.51 -> 2.42 -> 3.11
    rad for n = 8 -> 32 -> 128). A path that steep, q ~ sqrt(s), still continuous, gives a
    ratio (fine jump R N) / (coarse jump N) = sqrt(R) = 2; a discontinuity of size J (e.g. the
    foot-to-blade switch done in one frame) does not shrink with ds and gives R = 4 for
    J >> L_k ds. C lies between the two. The first frame of each step (the switch walk ->
    skate, skate -> roll, roll -> unroll, unroll -> walk) is inside its segment.
    """
    name, coarse, fine, _ = runs
    seg_c, seg_f = _segments(coarse), _segments(fine)
    assert sorted(seg_c) == [1, 2, 3, 4]
    for k in seg_c:
        assert len(seg_c[k]) == N + 1 and len(seg_f[k]) == REFINE * N + 1
        # both runs sample the same path: every REFINE-th fine frame is a coarse frame
        np.testing.assert_allclose(seg_f[k][::REFINE], seg_c[k], atol=1e-9)
        L = _max_jump(seg_c[k]) * N  # [rad per unit s]
        assert L > 1e-3, (name, k)  # every step moves
        ds = 1.0 / (REFINE * N)
        assert _max_jump(seg_f[k]) <= C_JUMP * L * ds, (name, k)
        # the switch itself (the step's first frame) obeys the same bound
        assert float(np.abs(seg_f[k][1] - seg_f[k][0]).max()) <= C_JUMP * L * ds, (name, k)


def test_foot_to_blade_switch_in_one_frame_is_a_jump(tmp_path):
    """The control: with ``frames: 1`` on the skate step the foot-to-blade switch is one jump
    (hwang2023 Table 6 (a) -> (b): right theta4 -11.60 -> -5.00 deg) that refining the other
    steps does not shrink, whereas sampled (the runs above) its largest jump is below the
    continuity bound, a fraction of it."""
    name = "hwang2023"
    fine = _run(tmp_path, name, REFINE * N)
    jumps = []
    for n in (N, REFINE * N):
        seg = _segments(_run(tmp_path, name, n, n_skate=1))[1]
        assert len(seg) == 2
        jumps.append(_max_jump(seg))
        np.testing.assert_allclose(np.rad2deg(seg[:, 3]), [-11.60, -5.00],
                                   atol=0.05)  # right theta4, hwang2023 Table 6 (a), (b)
    assert jumps[1] == pytest.approx(jumps[0], rel=1e-12) and jumps[0] > np.deg2rad(6.5)
    assert _max_jump(_segments(fine)[1]) < jumps[0] / REFINE
    # the continuity bound of the test above, with this step refined like the others (L = J
    # per frame), asks the switch to shrink to C J / REFINE = 0.75 J: it stays J
    assert jumps[1] > C_JUMP * jumps[0] / REFINE


def test_unroll_returns_the_blade_to_tilt_zero(runs):
    name, rep, _, _ = runs
    st = rep.summary["steps"]
    for side in SIDES:
        rolled = st[2]["legs"][side]
        # every blade rolls, except hwang2023's left one (theta6 19.84 -> 20 deg: 0.13 deg tilt)
        assert abs(rolled["beta_deg"]) > 4.0 or name == "hwang2023" and side == "left"
        back = st[3]["legs"][side]
        assert back["beta_kind"] == "beta_Y"
        assert back["beta_deg"] == pytest.approx(0.0, abs=1e-9)
        assert back["normal_angle"] == pytest.approx(0.0, abs=1e-9)  # blade upright on plane
        assert abs(back["contact_plane_distance_m"]) < 1e-12
        assert back["model_fk_error_m"] < 1e-9
        # rolling without slipping is path independent (Eq. 37): back upright is the skate pose
        np.testing.assert_allclose(back["q_rad_list"], st[1]["legs"][side]["q_rad_list"],
                                   atol=1e-9)
        np.testing.assert_allclose(back["contact_point_m"], st[1]["legs"][side]
                                   ["contact_point_m"], atol=1e-9)
        # the log's last unroll frame says the same
        last = [x for x in rep.data.state if x["step"] == 3][-1]
        assert last[f"beta_{side}_deg"] == pytest.approx(0.0, abs=1e-9)


def test_final_walk_returns_to_the_start_pose(runs):
    _, rep, fine, _ = runs
    for r in (rep, fine):
        q = r.data.q
        assert np.abs(q[-1] - q[0]).max() <= 1e-9
        assert r.summary["motion"]["end_minus_start_rad"] <= 1e-9
        st = r.summary["steps"]
        for side in SIDES:
            np.testing.assert_allclose(st[4]["legs"][side]["q_rad_list"],
                                       st[0]["legs"][side]["q_rad_list"], atol=1e-9)
            assert st[4]["legs"][side]["branch"] == st[0]["legs"][side]["branch"]
        # and the motion did go somewhere in between
        assert np.abs(q - q[0]).max() > np.deg2rad(3.0)


def test_joint_rates_in_frames_csv_and_joint_states(runs):
    """The per-frame rates are finite differences of the sampled motion; cross-check: at the
    coarse run's interior frames of each step (uniform spacing dt there, so central
    differences) they equal the central differences of the fine run (the same path sampled
    REFINE times denser, dt_f = dt / REFINE). Both are dq/dt + q3 dt^2 / 6 + ... (q3 the third
    time derivative), so they differ by at most C (dt^2 + dt_f^2) / 6 max |q3| per joint,
    C = 1.5, max |q3| estimated from the fine run's third differences over the step."""
    name, rep, fine, tmp = runs
    rec = rep.data
    t = rec.times
    assert rec.qd.shape == rec.q.shape
    steps = np.array([r["step"] for r in rec.state])
    steps_f = np.array([r["step"] for r in fine.data.state])
    tf = fine.data.times
    checked = 0
    for k in range(1, int(steps.max()) + 1):
        idx_f = np.flatnonzero(steps_f == k)
        dt_f = float(tf[idx_f[1]] - tf[idx_f[0]])
        q3 = np.abs(np.diff(fine.data.q[idx_f], n=3, axis=0)).max(axis=0) / dt_f**3
        tol = 1.5 * ((REFINE * dt_f) ** 2 + dt_f**2) / 6.0 * q3 + 1e-12
        idx = np.flatnonzero(steps == k)
        for i in idx[1:-1]:  # not the step's ends: the spacing (and a linear law's slope) changes
            j = int(np.flatnonzero(np.abs(tf - t[i]) < 1e-12)[0])
            ref = (fine.data.q[j + 1] - fine.data.q[j - 1]) / (tf[j + 1] - tf[j - 1])
            assert np.all(np.abs(rec.qd[i] - ref) <= tol), (name, k, i, rec.qd[i] - ref, tol)
            checked += 1
    assert checked == 4 * (N - 2)
    out = tmp / f"out_{name}"
    summary = rep.write(out, plots=False)
    assert "frames.csv" in summary["files"]
    cols = read_csv(out / "frames.csv")
    assert len(cols["t_s"]) == len(t)
    names = rec.joint_names
    for jn in ("r_theta4", "l_theta6"):
        j = names.index(jn)
        np.testing.assert_allclose(np.asarray(cols[f"{jn}_rad"], float), rec.q[:, j],
                                   atol=1e-12)
        np.testing.assert_allclose(np.asarray(cols[f"{jn}_rad_s"], float), rec.qd[:, j],
                                   atol=1e-12)
    with open(out / "biped.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        js = [d for _s, _c, _m, d in reader.iter_decoded_messages(topics=["/joint_states"])]
    assert len(js) == len(t)
    vel = np.array([[js[i].joints[k].velocity for k in range(len(names))]
                    for i in range(len(js))])
    assert [js[0].joints[k].name for k in range(len(names))] == names
    np.testing.assert_allclose(vel, rec.qd, atol=1e-12)


def test_readme_biped_example_runs_and_returns_to_its_start(tmp_path):
    """The README's continuous-motion example (section ``ik``), run as written (with the name,
    task and units its comment asks for)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("*Any biped, continuous motions.*", 1)[1].split("```yaml", 1)[1]
    block = block.split("```", 1)[0].replace("../mechanisms/", f"{ROOT / 'mechanisms'}/")
    p = tmp_path / "readme.yaml"
    p.write_text("name: readme_biped\ntask: ik\nunits: {length: mm, angle: deg}\n" + block)
    rep = run_file(p, "ik")
    assert rep.ok, rep.summary["status"]
    st = rep.summary["steps"]
    assert st[2]["legs"]["left"]["beta_deg"] == pytest.approx(-10.0, abs=1e-9)
    assert st[2]["legs"]["right"]["q"]["r_theta6"] == pytest.approx(np.deg2rad(8), abs=1e-12)
    for side in SIDES:
        assert st[3]["legs"][side]["beta_deg"] == pytest.approx(0.0, abs=1e-9)
        assert len(st[0]["legs"][side]["solutions"]) == st[0]["legs"][side]["n_solutions"] >= 1
    assert rep.summary["motion"]["end_minus_start_rad"] <= 1e-9
    assert rep.summary["motion"]["max_frame_step_rad"] < np.deg2rad(2.0)

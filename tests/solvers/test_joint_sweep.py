"""Joint sweeps that keep one assembly mode: the continuation order (grid / KD-tree), lee's
mechanism closed sample by sample from a solved neighbour (cross-checked with the closed-form
inverse position of lee §2), and the mode/failure report of ``mechkin workspace``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.io.csv_out import read_csv
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.lee_spherical import (
    LeeGeometry,
    euler_xyz_from_matrix,
    evaluate_poses,
    inverse_position,
)
from mechkin.solvers.workspace.joint_sweep import continuation_tree, joint_sweep

ROOT = Path(__file__).resolve().parents[2]
LEE = ROOT / "mechanisms" / "lee_spherical_rrps.yaml"
DEG = np.pi / 180.0


def test_grid_tree_parents_are_one_step_back():
    shape = (3, 4, 5)
    m = int(np.prod(shape))
    parent, level = continuation_tree(np.zeros((m, 3)), shape)
    idx = np.array(np.unravel_index(np.arange(m), shape)).T
    assert parent[0] == -1 and (parent[1:] >= 0).all()
    d = idx[1:] - idx[parent[1:]]
    assert (np.abs(d).sum(axis=1) == 1).all() and (d >= 0).all()  # one grid step
    assert (parent[1:] < np.arange(1, m)).all()
    assert (level[1:] == level[parent[1:]] + 1).all()


def test_scattered_tree_parent_is_nearest_earlier_neighbour():
    rng = np.random.default_rng(3)
    x = rng.uniform(-1.0, 1.0, size=(400, 2)) * [1.0, 0.1]  # mixed scales: distances scaled
    parent, level = continuation_tree(x, None, home=np.zeros(2), k=6)
    roots = np.flatnonzero(parent < 0)
    assert roots.size >= 1
    assert np.argmin(np.linalg.norm(x / np.ptp(x, axis=0), axis=1)) in roots
    kids = np.flatnonzero(parent >= 0)
    assert (level[parent[kids]] < level[kids]).all()
    xs = x / np.ptp(x, axis=0)
    for i in kids[:50]:
        earlier = np.flatnonzero(level < level[i])
        d = np.linalg.norm(xs[earlier] - xs[i], axis=1)
        # the parent is among the 6 nearest samples overall and no earlier sample among
        # those is nearer
        near6 = np.argsort(np.linalg.norm(xs - xs[i], axis=1))[1:7]
        cand = [j for j in near6 if level[j] < level[i]]
        if cand:
            assert np.linalg.norm(xs[parent[i]] - xs[i]) == pytest.approx(
                min(np.linalg.norm(xs[j] - xs[i]) for j in cand))
        assert np.linalg.norm(xs[parent[i]] - xs[i]) >= d.min() - 1e-12


def _plate_euler(mech, q):
    pl = mech.frame_index("plate")
    return euler_xyz_from_matrix(forward_kinematics(mech, q).frames(mech, [pl])[:, 0, :3, :3])


def test_lee_pose_path_keeps_the_home_assembly_mode():
    # legs of the straight pose path (0, 0, 30) -> (-30, 60, 30) deg (lee's Rx Ry Rz); the
    # last pose lies across the singular surface det G = 0 (another assembly mode)
    mech = load_mechanism(LEE)
    g = LeeGeometry(r=0.5)
    n = 25
    t = np.linspace(0.0, 1.0, n)[:, None]
    mus = np.deg2rad([0.0, 0.0, 30.0]) + t * np.deg2rad([-30.0, 60.0, 0.0])
    legs = inverse_position(g, mus)
    prescribed = np.sign(evaluate_poses(g, mus).det_G)
    assert prescribed[0] > 0 and prescribed[-1] < 0
    rec = joint_sweep(mech, legs, mech.frame_index("plate"), grid_shape=(n,),
                      manipulability=False)
    assert rec.converged.all() and not rec.mode_change.any() and not rec.reseeded.any()
    assert (rec.seed == np.arange(n) - 1).all()  # each sample from the previous one
    mu = _plate_euler(mech, rec.q)
    solved = np.sign(evaluate_poses(g, mu).det_G)
    assert (solved == solved[0]).all()  # one assembly mode throughout
    same = prescribed > 0
    assert_allclose(mu[same], mus[same], atol=1e-7)  # the prescribed poses of that mode
    # every solution closes the legs exactly (closed-form cross-check of the loop closure)
    assert_allclose(inverse_position(g, mu), legs, atol=1e-8)
    # the legs of (-30, 60, 30) deg close in the home mode at (-35, 42, 43.4) deg
    assert_allclose(mu[-1] / DEG, [-34.978, 41.953, 43.363], atol=5e-3)


def test_lee_grid_continuation_solves_every_sample_in_one_mode():
    mech = load_mechanism(LEE)
    g = LeeGeometry(r=0.5)
    n = 7
    ax = np.linspace(0.6, 1.8, n)
    legs = np.array(np.meshgrid(ax, ax, ax, indexing="ij")).reshape(3, -1).T
    f = mech.frame_index("plate")
    cont = joint_sweep(mech, legs, f, grid_shape=(n, n, n), manipulability=False)
    home = joint_sweep(mech, legs, f, seed_from="home", manipulability=False)
    ok = cont.converged
    assert ok.sum() >= home.converged.sum() > 0
    mu = _plate_euler(mech, cont.q[ok])
    assert_allclose(inverse_position(g, mu), legs[ok], atol=1e-8)
    h = np.sign(evaluate_poses(g, np.deg2rad([[0.0, 0.0, 30.0]])).det_G[0])
    assert (np.sign(evaluate_poses(g, mu).det_G) == h).all()
    assert home.seed is not None and (home.seed == -1).all()


def test_workspace_task_reports_modes_and_failures(tmp_path):
    from mechkin.config.scenario import load_scenario
    from mechkin.tasks.workspace import run

    p = tmp_path / "lee_sweep.yaml"
    p.write_text(f"name: lee_sweep\ntask: workspace\nmechanism: {LEE}\n"
                 "units: {length: m, angle: deg}\nworkspace:\n  kind: joint_sweep\n"
                 "  method: grid\n  joints:\n    l1: {range: [0.8, 1.6], n: 4}\n"
                 "    l2: {range: [0.8, 1.6], n: 4}\n    l3: {range: [0.8, 1.6], n: 4}\n"
                 "  mode_jump: 3\n  manipulability: false\n")
    rep = run(load_scenario(p))
    out = tmp_path / "out"
    rep.write(out, plots=False)
    s = json.loads((out / "summary.json").read_text())
    c = s["continuation"]
    assert c["seed_from"] == "neighbour" and c["mode_jump"] == 3
    cols = read_csv(out / "points.csv")
    assert c["n_mode_changes"] == int(np.sum(np.asarray(cols["mode_change"], dtype=float)))
    assert c["n_closure_failures"] == s["n_not_converged"] == int(
        np.sum(np.asarray(cols["status"]) != "converged"))
    assert c["n_roots"] == 1 and int(np.asarray(cols["seed_sample"], dtype=float)[0]) == -1


def test_seed_from_only_for_joint_sweep(tmp_path):
    from mechkin.config.scenario import load_scenario
    from mechkin.errors import ConfigError

    p = tmp_path / "bad.yaml"
    p.write_text("name: bad\ntask: workspace\nworkspace:\n  kind: lee_spherical\n"
                 "  isotropy_maps: {a: [20]}\n  seed_from: home\n")
    with pytest.raises(ConfigError, match="seed_from"):
        load_scenario(p)


# ---- the dimensionally honest dexterity index ------------------------------------------------

PUMA = ROOT / "mechanisms" / "puma560.yaml"


def _puma_copy(tmp_path, name, factor, unit):
    import yaml

    d = yaml.safe_load(PUMA.read_text())
    d["units"]["length"] = unit
    for j in d["joints"]:
        for k in ("a", "d"):
            j["dh"][k] = j["dh"][k] * factor
    for ln in d["links"]:
        ln.pop("inertial", None)
        for fr in ln.get("frames", []):
            fr["xyz"] = [v * factor for v in fr["xyz"]]
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _puma_sweep(path, q_v, length=None):
    mech = load_mechanism(path)
    return joint_sweep(mech, q_v, mech.end_effector, length=length)


def test_normalized_isotropy_is_invariant_under_the_length_unit(tmp_path):
    rng = np.random.default_rng(7)
    mech = load_mechanism(PUMA)
    q_v = rng.uniform(mech.lower * 0.9, mech.upper * 0.9, size=(300, 6))
    m_file = _puma_sweep(PUMA, q_v)
    # the same arm written in mm: identical SI model, identical index and length
    mm_file = _puma_sweep(_puma_copy(tmp_path, "puma_mm.yaml", 1000.0, "mm"), q_v)
    assert_allclose(mm_file.isotropy_normalized, m_file.isotropy_normalized, atol=1e-12)
    assert mm_file.characteristic_length == pytest.approx(m_file.characteristic_length, rel=1e-9)
    # the arm's lengths read in another unit (numbers of mm taken as m: every length x 1000):
    # the raw SI isotropy changes, the normalized one does not, and L scales by 1000
    big = _puma_sweep(_puma_copy(tmp_path, "puma_x1000.yaml", 1000.0, "m"), q_v)
    assert np.max(np.abs(big.isotropy - m_file.isotropy)) > 0.05
    assert big.characteristic_length / m_file.characteristic_length == pytest.approx(1000.0,
                                                                                      rel=1e-5)
    assert_allclose(big.isotropy_normalized, m_file.isotropy_normalized, atol=1e-5)
    # a given L behaves the same way, exactly
    g1 = _puma_sweep(PUMA, q_v, length=0.3)
    g2 = _puma_sweep(_puma_copy(tmp_path, "puma_x1000b.yaml", 1000.0, "m"), q_v, length=300.0)
    assert_allclose(g2.isotropy_normalized, g1.isotropy_normalized, atol=1e-10)


def test_characteristic_length_maximises_the_mean_normalized_isotropy():
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian
    from mechkin.solvers.workspace.dexterity import characteristic_length, normalized_isotropy

    rng = np.random.default_rng(2)
    mech = load_mechanism(PUMA)
    q = rng.uniform(mech.lower * 0.9, mech.upper * 0.9, size=(200, 6))
    J = frame_jacobian(mech, forward_kinematics(mech, q), mech.end_effector)
    L = characteristic_length(J)
    best = normalized_isotropy(J, L).mean()
    for f in (0.5, 0.9, 1.1, 2.0):
        assert normalized_isotropy(J, f * L).mean() <= best + 1e-12
    assert 0.05 < L < 2.0  # a length of the order of the PUMA's links (0.43 m)


def test_normalized_jacobian_of_a_prismatic_joint_is_dimensionless():
    from mechkin.solvers.workspace.dexterity import normalized_isotropy, normalized_jacobian

    # one revolute joint about z at distance r (v = omega x r) and one prismatic joint along x
    r = 0.2
    J = np.zeros((1, 6, 2))
    J[0, 2, 0], J[0, 4, 0] = 1.0, r
    J[0, 3, 1] = 1.0
    Jn = normalized_jacobian(J, r, np.array([False, True]))
    assert_allclose(Jn[0, :, 0], [0, 0, 1, 0, 1, 0])
    assert_allclose(Jn[0, :, 1], [0, 0, 0, r / r, 0, 0])
    # scaling every length by s (r -> s r, L -> s L) leaves the index unchanged
    J2 = J.copy()
    J2[0, 4, 0] = 1000 * r
    assert_allclose(normalized_isotropy(J2, 1000 * r, np.array([False, True])),
                    normalized_isotropy(J, r, np.array([False, True])), atol=1e-14)


# ---- explicit pose lists ---------------------------------------------------------------------


def _scenario(tmp_path, name, body):
    from mechkin.config.scenario import load_scenario

    p = tmp_path / f"{name}.yaml"
    p.write_text(body)
    return load_scenario(p)


def test_lee_pose_list_inline_and_csv(tmp_path):
    from mechkin.solvers.closed_form.lee_spherical import isotropy_index
    from mechkin.tasks.workspace import run

    poses = [[0.0, 0.0, 20.0], [10.0, -20.0, 30.0], [-30.0, 60.0, 30.0], [80.0, 80.0, 170.0]]
    head = ("task: workspace\nunits: {angle: deg}\nworkspace:\n  kind: lee_spherical\n"
            "  parameters: {r: 0.5}\n")
    inline = run(_scenario(tmp_path, "a", f"name: a\n{head}  poses: {poses}\n"))
    (tmp_path / "p.csv").write_text("alpha,beta,gamma\n" + "\n".join(
        ",".join(str(v) for v in p) for p in poses) + "\n")
    from_csv = run(_scenario(tmp_path, "b", f"name: b\n{head}  poses_csv: p.csv\n"))
    pl = inline.data.record.poses
    assert_allclose(from_csv.data.record.poses.sigma, pl.sigma, atol=0)
    ref = isotropy_index(LeeGeometry(r=0.5), np.deg2rad(poses))
    assert_allclose(pl.sigma, ref, atol=1e-12)
    assert pl.sigma[0] == pytest.approx(0.483690, abs=5e-7)  # PAPER_NOTES closed form, 20 deg
    s = inline.summary["poses"]
    assert s["count"] == 4 and s["in_workspace_fraction"] == pytest.approx(pl.in_workspace.mean())
    out = tmp_path / "o"
    inline.write(out, plots=False)
    t = read_csv(out / "sigma_ki_poses.csv")
    assert len(t["alpha_deg"]) == 4
    assert_allclose(t["sigma_ki"], pl.sigma)


def test_task_space_pose_list(tmp_path):
    from mechkin.config.scenario import load_scenario
    from mechkin.errors import ConfigError
    from mechkin.spatial.rotations import quat_from_matrix
    from mechkin.tasks.workspace import run

    mech = load_mechanism(PUMA)
    rng = np.random.default_rng(5)
    q = rng.uniform(mech.lower * 0.5, mech.upper * 0.5, size=(4, mech.n))
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    rows = [[*(1000 * T[k, :3, 3]).tolist(), *quat_from_matrix(T[k, :3, :3]).tolist()]
            for k in range(4)]
    rows.append([5000.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])  # out of reach
    head = (f"task: workspace\nmechanism: {PUMA}\nunits: {{length: mm, angle: deg}}\n"
            "workspace:\n  kind: task_space\n  restarts: 4\n")
    rep = run(_scenario(tmp_path, "ts", f"name: ts\n{head}  poses: {rows}\n"))
    rec = rep.data.record
    assert rec.reachable.tolist() == [True] * 4 + [False]
    assert_allclose(rec.T_P[:4], T, atol=1e-9)
    assert rep.summary["method"] == "poses" and rep.summary["n_poses"] == 5
    (tmp_path / "t.csv").write_text("x,y,z,qw,qx,qy,qz\n" + "\n".join(
        ",".join(repr(v) for v in r) for r in rows) + "\n")
    rep2 = run(_scenario(tmp_path, "ts2", f"name: ts2\n{head}  poses_csv: t.csv\n"))
    assert_allclose(rep2.data.record.T_P, rec.T_P, atol=1e-12)
    assert rep2.data.record.reachable.tolist() == rec.reachable.tolist()
    # bad input: one line with the file and key
    with pytest.raises(ConfigError, match=r"poses: expected every pose"):
        load_scenario(_write(tmp_path, "b1",
                             f"name: b1\n{head}  poses: [[1, 2, 3], [1, 2, 3, 4]]\n"))
    (tmp_path / "bad.csv").write_text("x,y\n1,2\n")
    with pytest.raises(ConfigError, match=r"bad.csv:1: missing column"):
        run(_scenario(tmp_path, "b2", f"name: b2\n{head}  poses_csv: bad.csv\n"))
    with pytest.raises(ConfigError, match=r"method: not used with poses"):
        load_scenario(_write(tmp_path, "b3", f"name: b3\n{head}  method: grid\n"
                                             f"  poses: {rows}\n"))


def _write(tmp_path, name, body):
    p = tmp_path / f"{name}.yaml"
    p.write_text(body)
    return p

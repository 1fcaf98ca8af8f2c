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
from mechkin.solvers.joint_sweep import continuation_tree, joint_sweep

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

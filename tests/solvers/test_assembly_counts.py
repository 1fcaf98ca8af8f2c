"""``assembly: all`` counts against independent counts (issue 24).

The planar 3-RRR (mechanisms/planar_3rrr.yaml: base radius 0.5, platform circumradius 0.1,
l1 = 0.3, l2 = 0.25 m): with the motors fixed the elbows E_i are fixed and the platform's pins
lie on circles of radius l2 about them (a 3-RPR forward problem). Counted here in one variable:
for each platform angle phi, pin 1 lies on two circles (its own and pin 2's shifted by the
platform), giving two branches; the assembly modes are the roots in phi of pin 3's circle
residual on each branch (bracketed on a grid of 20,000 angles, refined by brentq).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.assembly import assembly_modes

ROOT = Path(__file__).resolve().parents[2]
B = 0.5 * np.array([[np.cos(a), np.sin(a)] for a in np.radians([90.0, 210.0, 330.0])])
C = np.array([[0.0, 0.1], [-0.0866025403784439, -0.05], [0.0866025403784439, -0.05]])
L1, L2 = 0.3, 0.25


def _rot(p):
    return np.array([[np.cos(p), -np.sin(p)], [np.sin(p), np.cos(p)]])


def platform_poses(qv, n=20000):
    E = B + L1 * np.column_stack([np.cos(qv), np.sin(qv)])

    def branch(phi, s):
        """Pin 3's residual and pin 1 on branch s at angles phi (k,); nan where pins 1 and 2
        cannot both reach their circles."""
        phi = np.atleast_1d(phi)
        cs, sn = np.cos(phi), np.sin(phi)
        R = np.stack([np.stack([cs, -sn], -1), np.stack([sn, cs], -1)], -2)
        d = E[1] - R @ (C[1] - C[0]) - E[0]
        dist = np.linalg.norm(d, axis=1)
        with np.errstate(invalid="ignore"):
            h = np.sqrt(L2**2 - (dist / 2) ** 2)
        u = d / dist[:, None]
        P1 = E[0] + u * dist[:, None] / 2 + s * h[:, None] * np.stack([-u[:, 1], u[:, 0]], 1)
        r = np.sum((P1 + R @ (C[2] - C[0]) - E[2]) ** 2, axis=1) - L2**2
        return r, P1

    out = []
    grid = np.linspace(-np.pi, np.pi, n + 1)
    for s in (1.0, -1.0):
        v, _ = branch(grid, s)
        hit = np.flatnonzero(np.isfinite(v[:-1]) & np.isfinite(v[1:])
                             & (np.sign(v[:-1]) != np.sign(v[1:])))
        for k in hit:
            phi = brentq(lambda p, s=s: branch(p, s)[0][0], grid[k], grid[k + 1], xtol=1e-15)
            P1 = branch(phi, s)[1][0]
            out.append(np.array([*(P1 - _rot(phi) @ C[0]), phi]))
    return np.array(out).reshape(-1, 3)


@pytest.mark.parametrize("dq", [[0.0, 0.0, 0.0], [0.3, -0.2, 0.25], [-0.4, 0.1, 0.0],
                                [1.5, 1.5, 1.5]])
def test_planar_3rrr_modes_match_the_counted_roots(dq):
    mech = load_mechanism(ROOT / "mechanisms" / "planar_3rrr.yaml")
    qv = mech.home[mech.independent] + np.asarray(dq)
    ref = platform_poses(qv)
    modes = assembly_modes(mech, qv, starts=128)
    assert modes.count == len(ref)
    if not len(ref):
        return
    T = forward_kinematics(mech, modes.q).frames(mech, [mech.end_effector])[:, 0]
    got = np.column_stack([T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])])
    d = np.abs(got[:, None] - ref[None])
    d[..., 2] = np.abs((d[..., 2] + np.pi) % (2 * np.pi) - np.pi)
    dist = d.max(axis=-1)
    assert dist.min(axis=1).max() < 1e-9 and dist.min(axis=0).max() < 1e-9
    assert modes.from_home is not None


def test_fourbar_modes_and_the_one_fk_follows():
    mech = load_mechanism(ROOT / "tests" / "data" / "fourbar.yaml")
    import mechkin

    for deg in (-150.0, 20.0, 170.0):
        qv = np.radians([deg])
        modes = assembly_modes(mech, qv, starts=32)
        assert modes.count == 2
        fk = mechkin.fk(mech, qv)
        assert modes.from_home is not None
        k = modes.from_home
        dw = (fk.q[0, mech.dependent] - modes.q[k, mech.dependent] + np.pi) % (2 * np.pi) - np.pi
        assert np.abs(dw).max() < 1e-9


def test_info_lists_the_modes_at_home():
    from mechkin.cli.info_report import run_info

    info = run_info(mechanism=ROOT / "tests" / "data" / "fourbar.yaml")
    modes = info["assembly_modes_at_home"]
    assert modes["count"] == 2 and modes["within_limits"] == 2
    mech = load_mechanism(ROOT / "tests" / "data" / "fourbar.yaml")
    home = mechkin_fk_home(mech)
    first = np.array(list(modes["modes"][0]["q_w"].values()))
    assert np.abs((first - home + np.pi) % (2 * np.pi) - np.pi).max() < 1e-9
    assert run_info(mechanism=ROOT / "mechanisms" / "puma560.yaml")[
        "assembly_modes_at_home"] is None


def mechkin_fk_home(mech):
    from mechkin.model.continuation import home_assembly

    return home_assembly(mech).q[0, mech.dependent]

"""The closed forms of mechkin.solvers.closed_form are cases of the leg decomposition
(mechkin.solvers.ik.analytic.legs): on random platform poses the legs give the closed forms'
values to 1e-12 (references typed in here: Stewart and lee leg lengths |p + R b_i - a_i|,
kim1995's direct-drive appendix), ``closed_form_ik`` / ``closed_form_solutions`` take the legs'
route (the hand-written formulas only where the legs do not decompose), and ``legs_all`` (built
on arrays) lists exactly the combinations of the legs' own solutions."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.closed_form import recognise
from mechkin.solvers.closed_form.recognise import check_closed_form, closed_form_ik
from mechkin.solvers.ik.analytic import legs as legs_mod
from mechkin.solvers.ik.analytic.legs import legs_all, platform_legs, solve_legs

ROOT = Path(__file__).resolve().parents[2]


def _rot(a: float, b: float, c: float) -> np.ndarray:
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    Rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    Ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    Rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _home_pose(mech):
    res = solve_closure(mech, mech.home[mech.independent][None], mech.home[mech.dependent][None])
    return forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[0, 0]


def _random_poses(T0: np.ndarray, m: int, dp: float, da: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    T = np.repeat(T0[None], m, axis=0)
    for k in range(m):
        T[k, :3, :3] = _rot(*rng.uniform(-da, da, 3)) @ T0[:3, :3]
        T[k, :3, 3] += rng.uniform(-dp, dp, 3)
    return T


def _closes(mech, q: np.ndarray, T: np.ndarray) -> None:
    kin = forward_kinematics(mech, q[None])
    assert np.abs(closure_residual(mech, kin)).max() < 1e-10
    assert np.abs(kin.frames(mech, [mech.end_effector])[0, 0] - T).max() < 1e-10


@pytest.mark.parametrize("name", ["kim1995_stewart", "tests/data/stewart_66"])
def test_stewart_legs_equal_the_leg_lengths(name):
    """l_i = |p + R b_i - a_i| (a_i, b_i read from the model by the recognition; sigma, c the
    joint's direction and zero) on 40 random platform poses, to 1e-12."""
    path = ROOT / (f"{name}.yaml" if "/" in name else f"mechanisms/{name}.yaml")
    mech = load_mechanism(path)
    g = check_closed_form(mech, "stewart")
    legs = platform_legs(mech)
    assert [leg.kind for leg in legs] == ["chain"] * 6
    T = _random_poses(_home_pose(mech), 40, 0.05 * np.abs(g.a).max(), np.radians(6), seed=21)
    ref = np.array([[np.linalg.norm(t[:3, 3] + t[:3, :3] @ b - a) for a, b in zip(g.a, g.b,
                                                                                 strict=True)]
                    for t in T]) * g.sigma - g.c
    q_cf, ok = closed_form_ik(mech, T, "stewart")
    assert ok.all() and np.abs(q_cf - ref).max() < 1e-12
    for t, r in zip(T, ref, strict=True):
        q, found = solve_legs(mech, legs, t, mech.home)
        assert found and np.abs(q[mech.independent] - r).max() < 1e-12
        _closes(mech, q, t)


def test_lee_legs_equal_the_leg_lengths():
    """lee Eq. (9), l_i = |P + R r_i - R_i|, typed in from the paper's parameters that the
    recognition reads (R = 1, r = 0.5, angles 0/120/240 deg, P = (0, 0, 1)), on 40 random
    orientations about P, to 1e-12; a plate centre off P has no solution."""
    mech = load_mechanism(ROOT / "mechanisms" / "lee_spherical_rrps.yaml")
    geo = check_closed_form(mech, "lee_spherical").geometry
    assert (geo.R, geo.r) == pytest.approx((1.0, 0.5))
    ang = np.radians([0.0, 120.0, 240.0])
    base = np.stack([np.cos(ang), np.sin(ang), np.zeros(3)], axis=1)
    top = 0.5 * base
    P = np.array([0.0, 0.0, 1.0])
    T = _random_poses(_home_pose(mech), 40, 0.0, np.radians(25), seed=22)
    assert np.abs(T[:, :3, 3] - P).max() < 1e-12
    ref = np.array([[np.linalg.norm(P + t[:3, :3] @ r - b) for r, b in zip(top, base,
                                                                          strict=True)]
                    for t in T])
    q_cf, ok = closed_form_ik(mech, T, "lee_spherical")
    assert ok.all() and np.abs(q_cf - ref).max() < 1e-12
    legs = platform_legs(mech)
    for t, r in zip(T, ref, strict=True):
        q, found = solve_legs(mech, legs, t, mech.home)
        assert found and np.abs(q[mech.independent] - r).max() < 1e-12
        _closes(mech, q, t)
    off = T[:1].copy()
    off[0, 0, 3] += 0.05
    assert recognise.closed_form_solutions(mech, off, "lee_spherical")[0].shape == (0, 3)


def _appendix(T: np.ndarray) -> np.ndarray:
    """kim1995 appendix (PAPER_NOTES reading: d1 = 0.4, a3 = 0.25, a4 = 0.4, dE = -0.65, lower
    signs), typed in: q1 = atan2(-s_x, s_y), q2 = atan2(a_z, c1 a_x + s1 a_y) - pi,
    q3 = pi/2 - q2 - atan2(+sqrt(1 - c3^2), c3)."""
    d1, a3, a4, dE = 0.4, 0.25, 0.4, -0.65
    out = []
    for t in T:
        s, a, p = t[:3, 1], t[:3, 2], t[:3, 3]
        q1 = np.arctan2(-s[0], s[1])
        c1, s1 = np.cos(q1), np.sin(q1)
        q2 = np.arctan2(a[2], c1 * a[0] + s1 * a[1]) - np.pi
        alpha = c1 * p[0] + s1 * p[1] + dE * (c1 * a[0] + s1 * a[1])
        beta = p[2] - d1 + dE * a[2]
        c3 = (alpha**2 + beta**2 - a3**2 - a4**2) / (2 * a3 * a4)
        q3 = np.pi / 2 - q2 - np.arctan2(np.sqrt(1 - c3**2), c3)
        out.append([q1, q2, q3])
    q = np.array(out)
    return (q + np.pi) % (2 * np.pi) - np.pi


def test_direct_drive_legs_equal_the_appendix():
    """kim1995's direct-drive arm decomposes: the crank, rod and forearm on the turning
    shoulder (Subproblem 1, then the planar 3R), then the upper arm on the known shoulder (two
    parallel axes reaching the elbow frame). On 40 poses of random motors the legs equal the
    appendix to 1e-12, and every joint closes the loop."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    legs = platform_legs(mech)
    assert [leg.kind for leg in legs] == ["rplanar3", "pose2r"]
    assert [mech.joint_names[j] for j in legs[1].prefix] == ["q1"]
    iv = mech.independent
    rng = np.random.default_rng(23)
    qv = rng.uniform(mech.lower[iv] * 0.9, mech.upper[iv] * 0.9, size=(60, 3))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent], (60, 3)).copy())
    ok = res.ok & np.all((res.q >= mech.lower) & (res.q <= mech.upper), axis=1)
    assert ok.sum() >= 40
    T = forward_kinematics(mech, res.q[ok]).frames(mech, [mech.end_effector])[:, 0]
    ref = _appendix(T)
    assert np.abs(ref - qv[ok]).max() < 1e-9  # the typed-in appendix is right
    q_cf, found = closed_form_ik(mech, T, "direct_drive")
    assert found.all() and np.abs(q_cf - ref).max() < 1e-12
    for t, r in zip(T, ref, strict=True):
        q, f = solve_legs(mech, legs, t, mech.home)
        assert f and np.abs(q[iv] - r).max() < 1e-12
        _closes(mech, q, t)


def test_closed_form_ik_takes_the_legs_route(monkeypatch):
    """closed_form_solutions calls the legs; with the legs switched off the hand-written
    formulas give the same values (to 1e-12), so each route is exercised and they agree."""
    calls = []
    real = legs_mod.legs_all

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(legs_mod, "legs_all", spy)
    for name, kind in [("kim1995_stewart", "stewart"), ("kim1995_direct_drive", "direct_drive"),
                       ("lee_spherical_rrps", "lee_spherical")]:
        mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
        T = _home_pose(mech)[None]
        calls.clear()
        by_legs = recognise.closed_form_solutions(mech, T, kind)
        assert calls == [1]
        monkeypatch.setattr(legs_mod, "legs_for", lambda m: None)
        by_formula = recognise.closed_form_solutions(mech, T, kind)
        monkeypatch.undo()
        monkeypatch.setattr(legs_mod, "legs_all", spy)
        assert by_legs[0].shape == by_formula[0].shape == (1, len(mech.independent))
        assert np.abs(by_legs[0] - by_formula[0]).max() < 1e-12


@pytest.mark.parametrize("name", ["delta", "planar_3rrr", "kim1995_direct_drive"])
def test_legs_all_is_every_combination(name):
    """legs_all (arrays, no loop over combinations) equals the loop over every combination of
    each leg's own solutions (the legs solved one after the other), row for row."""
    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    # limits opened (joints within pi of home), so that the legs have several branches
    mech = dataclasses.replace(mech, lower=mech.home - np.pi, upper=mech.home + np.pi)
    legs = platform_legs(mech)
    iv = mech.independent
    rng = np.random.default_rng(24)
    qv = mech.home[iv] + rng.uniform(-0.1, 0.1, size=(5, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (5, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q[res.ok]).frames(mech, [mech.end_effector])[:, 0]
    ref = np.where(np.isfinite(mech.home), mech.home, 0.0)
    e = int(mech.end_effector)
    counts = []
    for t in T:
        got = legs_all(mech, legs, t, ref)
        T_plat = (t @ np.linalg.inv(mech.frame_offset[e]))[None]
        rows = [ref.copy()]
        for leg in legs:  # one partial configuration at a time
            nxt = []
            for row in rows:
                T_end = legs_mod._leg_targets(mech, leg, T_plat, row[None])
                sols, n = legs_mod._leg_solutions_batch(mech, leg, T_end,
                                                        row[leg.joints][None])
                for s in sols[0, :n[0]]:
                    r = row.copy()
                    r[leg.joints] = s
                    nxt.append(r)
            rows = nxt
        want = np.array(rows).reshape(-1, mech.n)
        assert got.shape == want.shape and np.abs(got - want).max() < 1e-12
        counts.append(len(got))
        for q in got:
            _closes(mech, q, t)
    assert min(counts) >= {"delta": 8, "planar_3rrr": 8, "kim1995_direct_drive": 2}[name]


@pytest.mark.parametrize("name", ["delta", "planar_3rrr"])
def test_method_closed_form_on_any_mechanism_whose_legs_decompose(tmp_path, name):
    """``method: closed-form`` is no longer limited to the three named closed forms: a
    parallel mechanism whose legs decompose (Delta, 3-RRR) is solved through its legs (the
    same joints as ``method: analytic``, 1e-12), checks clean, and ``solutions: all`` lists
    every combination of the legs' branches (complete); a serial arm is still refused."""
    from mechkin.errors import ConfigError
    from mechkin.tasks import run_file
    from mechkin.tasks.validate import _legs_decompose

    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    iv = mech.independent
    qv = mech.home[iv] + np.random.default_rng(25).uniform(-0.1, 0.1, size=(4, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (4, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q[res.ok]).frames(mech, [mech.end_effector])[:, 0]
    rows = "\n".join(f"    - {{name: P{i}, matrix: {np.round(t, 15).tolist()}}}"
                     for i, t in enumerate(T))

    def scenario(method: str, extra: str = "") -> Path:
        p = tmp_path / f"{method}{bool(extra)}.yaml"
        p.write_text(f"""name: cf_{name}
task: ik
mechanism: {ROOT / "mechanisms" / f"{name}.yaml"}
units: {{length: m, angle: deg}}
ik:
  method: {method}
{extra}  targets:
{rows}
outputs: {{csv: false, plots: false, mcap: false}}
""")
        return p

    assert _legs_decompose(mech)
    cf = run_file(scenario("closed-form"), "ik").summary
    an = run_file(scenario("analytic"), "ik").summary
    assert cf["status"] == an["status"] == "ok" and cf["methods_used"] == ["closed-form"]
    for a, b in zip(cf["targets"], an["targets"], strict=True):
        assert max(abs(a["q"][k] - b["q"][k]) for k in a["q"]) < 1e-12
    al = run_file(scenario("closed-form", "  solutions: all\n"), "ik").summary
    assert al["solutions"]["complete"] is True and al["solutions"]["source"] == ["analytic legs"]
    puma = ROOT / "mechanisms" / "puma560.yaml"
    bad = scenario("closed-form").read_text().replace(str(ROOT / "mechanisms" / f"{name}.yaml"),
                                                      str(puma))
    (tmp_path / "bad.yaml").write_text(bad)
    with pytest.raises(ConfigError, match="no closed form fits mechanism 'puma560'"):
        run_file(tmp_path / "bad.yaml", "ik")

"""The bundled non-paper mechanisms (five-bar, 3-RRR, Delta, UR5) against their closed forms.

Three kinds of check per mechanism: the general solvers (loop closure, lm) against the closed
forms of reference_closed_forms.py at random configurations; the scenarios' ``expect:``
values re-derived from the closed form (so no number in scenarios/ is taken on trust); and
every scenario run end to end, exit 0, with the fk trajectories compared step by step.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.io.csv_out import read_csv
from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, IkStatus, solve_ik
from tests.mechanisms import reference_closed_forms as ref

ROOT = Path(__file__).resolve().parents[2]
MECH = ROOT / "mechanisms"
SCEN = ROOT / "scenarios"
runner = CliRunner()
d2r = np.deg2rad


def _assembled(name: str, qv: np.ndarray):
    mech = load_mechanism(MECH / f"{name}.yaml")
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (len(qv), len(mech.dependent))))
    assert res.ok.all()
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    return mech, T


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ---- structure -------------------------------------------------------------------------------
@pytest.mark.parametrize("name, dof, n, ne", [("five_bar", 2, 4, 2), ("planar_3rrr", 3, 7, 4),
                                              ("delta", 3, 15, 12), ("ur5", 6, 6, 0)])
def test_structure(name, dof, n, ne):
    mech = load_mechanism(MECH / f"{name}.yaml")
    assert (mech.n, mech.n_equations, len(mech.independent)) == (n, ne, dof)


# ---- solvers vs closed forms -----------------------------------------------------------------
def test_five_bar_fk_and_ik_closed_form():
    rng = np.random.default_rng(0)
    qv = d2r(np.array([135.0, 45.0]) + rng.uniform(-20, 20, (12, 2)))
    mech, T = _assembled("five_bar", qv)
    np.testing.assert_allclose(T[:, :2, 3], ref.five_bar_fk(qv), atol=1e-12)
    np.testing.assert_allclose(T[:, 2, 3], 0.0, atol=1e-15)
    np.testing.assert_allclose(ref.five_bar_ik(T[:, :2, 3]), qv, atol=1e-12)
    for k in range(3):
        r = solve_ik(mech, T[k], weights=[1, 1, 1, 0, 0, 0], options=IkOptions(grad_tol=1e-14))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, qv[k], atol=1e-8)


def test_3rrr_ik_closed_form_and_fk_cross_checked():
    rng = np.random.default_rng(1)
    x = np.column_stack([rng.uniform(-0.04, 0.04, (8, 2)), d2r(rng.uniform(-12, 12, 8))])
    qv = ref.rrr_ik(x)
    qv[:, 2] = np.where(qv[:, 2] > np.pi / 2, qv[:, 2] - 2 * np.pi, qv[:, 2])
    mech, T = _assembled("planar_3rrr", qv)
    # FK by loop closure gives back the pose the closed-form IK started from
    np.testing.assert_allclose(T[:, :2, 3], x[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.arctan2(T[:, 1, 0], T[:, 0, 0]), x[:, 2], atol=1e-12)
    # and an independent numerical FK (scipy on the three distance equations) agrees
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for k in range(3):
            xk = ref.rrr_fk_numerical(qv[k], np.zeros(3))
            np.testing.assert_allclose(xk, x[k], atol=1e-10)
    for k in range(3):
        r = solve_ik(mech, T[k], options=IkOptions(grad_tol=1e-14))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, qv[k], atol=1e-8)


def test_delta_fk_three_spheres_and_ik_per_arm():
    rng = np.random.default_rng(2)
    qv = d2r(rng.uniform(5, 60, (12, 3)))
    mech, T = _assembled("delta", qv)
    np.testing.assert_allclose(T[:, :3, 3], ref.delta_fk(qv), atol=1e-12)
    np.testing.assert_allclose(T[:, :3, :3], np.broadcast_to(np.eye(3), (12, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(ref.delta_ik(T[:, :3, 3]), qv, atol=1e-12)
    for k in range(3):
        r = solve_ik(mech, T[k], options=IkOptions(grad_tol=1e-14))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, qv[k], atol=1e-8)


def test_ur5_fk_is_the_dh_product():
    mech = load_mechanism(MECH / "ur5.yaml")
    rng = np.random.default_rng(3)
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (50, 6))
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    for k in range(50):
        np.testing.assert_allclose(T[k], ref.ur5_fk(q[k]), atol=1e-12)
    np.testing.assert_allclose(mech.lower, -2 * np.pi)
    np.testing.assert_allclose(mech.upper, 2 * np.pi)
    # q = 0: stretched along -x0 (a2 + a3 = -0.81725, -(d4 + d6) = -0.19145, d1 - d5)
    T0 = forward_kinematics(mech, np.zeros((1, 6))).frames(mech, [mech.end_effector])[0, 0]
    np.testing.assert_allclose(T0[:3, 3], [-0.81725, -0.19145, 0.089159 - 0.09465], atol=1e-15)


# ---- scenarios: expects re-derived, then run -------------------------------------------------
def _scenario(name: str) -> dict:
    return yaml.safe_load((SCEN / f"{name}.yaml").read_text())


def _expects(sc: dict) -> dict[str, np.ndarray]:
    out = {}
    for e in sc["expect"]:
        if "value" in e:
            f = d2r(1.0) if e.get("unit") == "deg" else 1.0
            out[e["key"]] = np.asarray(e["value"], float) * f
    return out


def _sinusoids(sc: dict, names: list[str], t: float) -> np.ndarray:
    mo = sc["fk"]["motion"]
    return np.array([d2r(mo[n].get("offset", 0) + mo[n]["amplitude"] * np.sin(
        2 * np.pi * mo[n]["frequency"] * t + d2r(mo[n].get("phase", 0)))) for n in names])


def _grid(sc: dict, names: list[str]) -> np.ndarray:
    js = sc["workspace"]["joints"]
    axes = [d2r(np.linspace(*js[n]["range"], js[n]["n"])) for n in names]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(names))


def _targets_xyz(sc: dict) -> np.ndarray:
    return np.array([t["xyz"] for t in sc["ik"]["targets"]], float)


def _ik_expect_q(sc: dict, n: int) -> np.ndarray:
    ex = _expects(sc)
    k = len(sc["ik"]["targets"])
    return np.array([[ex[f"targets.{i}.q_v.q{j + 1}"] for j in range(n)] for i in range(k)])


def test_five_bar_scenario_expects():
    fk = _scenario("five_bar_fk")
    qf = _sinusoids(fk, ["q1", "q2"], fk["fk"]["time"]["stop"])
    np.testing.assert_allclose(_expects(fk)["final.end_effector.xyz_m"][:2],
                               ref.five_bar_fk(qf[None])[0], atol=1e-11)
    ik = _scenario("five_bar_ik")
    np.testing.assert_allclose(_ik_expect_q(ik, 2), ref.five_bar_ik(_targets_xyz(ik)[:, :2]),
                               atol=1e-11)
    ws = _scenario("five_bar_workspace")
    P = ref.five_bar_fk(_grid(ws, ["q1", "q2"]))
    assert np.all(np.isfinite(P))
    ex = _expects(ws)
    np.testing.assert_allclose(ex["bounding_box.min_m"][:2], P.min(0), atol=1e-11)
    np.testing.assert_allclose(ex["bounding_box.max_m"][:2], P.max(0), atol=1e-11)


def test_3rrr_scenario_expects():
    fk = _scenario("planar_3rrr_fk")
    tab = fk["fk"]["table"]
    t = np.asarray(tab["t"])
    x = np.column_stack([0.03 * np.cos(np.pi * t) - 0.03, 0.03 * np.sin(np.pi * t),
                         d2r(10) * np.sin(np.pi * t)])
    q_tab = d2r(np.column_stack([tab["q1"], tab["q2"], tab["q3"]]))
    np.testing.assert_allclose(_wrap(q_tab - ref.rrr_ik(x)), 0.0, atol=1e-11)
    ik = _scenario("planar_3rrr_ik")
    xs = np.array([[*tg["xyz"][:2], d2r(tg["euler"]["angles"][2])] for tg in ik["ik"]["targets"]])
    np.testing.assert_allclose(_wrap(_ik_expect_q(ik, 3) - ref.rrr_ik(xs)), 0.0, atol=1e-11)
    ws = _scenario("planar_3rrr_workspace")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        X = np.array([ref.rrr_fk_numerical(q, np.zeros(3)) for q in _grid(ws, ["q1", "q2", "q3"])])
    ex = _expects(ws)
    np.testing.assert_allclose(ex["bounding_box.min_m"][:2], X[:, :2].min(0), atol=1e-11)
    np.testing.assert_allclose(ex["bounding_box.max_m"][:2], X[:, :2].max(0), atol=1e-11)


def test_delta_scenario_expects():
    fk = _scenario("delta_fk")
    qf = _sinusoids(fk, ["q1", "q2", "q3"], fk["fk"]["time"]["stop"])
    np.testing.assert_allclose(_expects(fk)["final.end_effector.xyz_m"],
                               ref.delta_fk(qf[None])[0], atol=1e-11)
    ik = _scenario("delta_ik")
    np.testing.assert_allclose(_ik_expect_q(ik, 3), ref.delta_ik(_targets_xyz(ik)), atol=1e-11)
    ws = _scenario("delta_workspace")
    P = ref.delta_fk(_grid(ws, ["q1", "q2", "q3"]))
    ex = _expects(ws)
    np.testing.assert_allclose(ex["bounding_box.min_m"], P.min(0), atol=1e-11)
    np.testing.assert_allclose(ex["bounding_box.max_m"], P.max(0), atol=1e-11)


def test_ur5_scenario_expects():
    names = [f"q{i}" for i in range(1, 7)]
    fk = _scenario("ur5_fk")
    T = ref.ur5_fk(_sinusoids(fk, names, fk["fk"]["time"]["stop"]))
    ex = _expects(fk)
    np.testing.assert_allclose(ex["final.end_effector.xyz_m"], T[:3, 3], atol=1e-11)
    for i in range(3):
        np.testing.assert_allclose(ex[f"final.end_effector.R.{i}"], T[i, :3], atol=1e-11)
    # the ik targets are the D-H products at the joint values written in their comments
    text = (SCEN / "ur5_ik.yaml").read_text()
    qs = [np.array([float(v) for v in line.split("q = (")[1].split(")")[0].split(",")])
          for line in text.splitlines() if "D-H product at q = (" in line]
    ik = _scenario("ur5_ik")
    assert len(qs) == len(ik["ik"]["targets"]) == 4
    for q, tg in zip(qs, ik["ik"]["targets"], strict=True):
        np.testing.assert_allclose(np.asarray(tg["matrix"]), ref.ur5_fk(d2r(q)), atol=1e-11)
    ws = _scenario("ur5_workspace")
    P = np.array([ref.ur5_fk(q)[:3, 3] for q in _grid(ws, names)])
    ex = _expects(ws)
    np.testing.assert_allclose(ex["bounding_box.min_m"], P.min(0), atol=1e-11)
    np.testing.assert_allclose(ex["bounding_box.max_m"], P.max(0), atol=1e-11)


SCENARIOS = [f"{m}_{k}" for m in ("five_bar", "planar_3rrr", "delta", "ur5")
             for k in ("fk", "ik", "workspace")]


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_runs_and_its_expects_hold(name, tmp_path):
    task = name.rsplit("_", 1)[1]
    out = tmp_path / "out"
    res = runner.invoke(app, [task, str(SCEN / f"{name}.yaml"), "--no-plots", "--out", str(out),
                              "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["expect"] and all(c["ok"] for c in summary["expect"])
    if task != "fk":
        return
    # every step of the trajectory, not only the final one, equals the closed form
    cols = read_csv(out / "fk.csv")
    sc = _scenario(name)
    mech = load_mechanism(SCEN / sc["mechanism"])
    qv = np.column_stack([np.asarray(cols[f"{n}_rad"], float) for n in mech.independent_names])
    p = np.column_stack([np.asarray(cols[f"ee_{c}_m"], float) for c in "xyz"])
    if name == "five_bar_fk":
        np.testing.assert_allclose(p[:, :2], ref.five_bar_fk(qv), atol=1e-11)
    elif name == "delta_fk":
        np.testing.assert_allclose(p, ref.delta_fk(qv), atol=1e-11)
    elif name == "planar_3rrr_fk":
        t = np.asarray(cols["t_s"], float)
        np.testing.assert_allclose(p[:, 0], 0.03 * np.cos(np.pi * t) - 0.03, atol=1e-11)
        np.testing.assert_allclose(p[:, 1], 0.03 * np.sin(np.pi * t), atol=1e-11)
    else:
        np.testing.assert_allclose(p, [ref.ur5_fk(q)[:3, 3] for q in qv], atol=1e-11)

"""Which route :func:`mechkin.model.kinematics.frame_poses` takes (mechkin.model.fk_accel: rent
or buy, MECHKIN_JIT=0/1), the compiled route on inputs of other types and layouts, and the
routes against each other on open chains, trees, prismatic joints and closed chains' spanning
trees (each against the tree FK ``forward_kinematics(...).frames(...)`` to 1e-12).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mechkin.model import fk_accel, load_mechanism
from mechkin.model import kinematics as K
from mechkin.model.kinematics import forward_kinematics, frame_poses
from tests.model.test_fast_fk import _naive

ROOT = Path(__file__).resolve().parents[2]
MECH = ROOT / "mechanisms"


@pytest.fixture(autouse=True)
def _fresh_route():
    fk_accel.reset()
    yield
    fk_accel.reset()


def _both(mech, qs, idx, monkeypatch):
    """frame_poses by the numpy route, then by the compiled route (a fresh choice each)."""
    monkeypatch.setenv("MECHKIN_JIT", "0")
    fk_accel.reset()
    a = frame_poses(mech, qs, idx)
    assert fk_accel.KERNEL is None
    monkeypatch.setenv("MECHKIN_JIT", "1")
    fk_accel.reset()
    b = frame_poses(mech, qs, idx)
    assert fk_accel.KERNEL is not None
    return a, b


@pytest.mark.parametrize("name", ["puma560", "lee_spherical_rrps", "kim1995_stewart",
                                  "hwang2023_biped", "kim1995_end_effector_robot", "delta"])
def test_routes_agree_with_the_tree_fk(name, monkeypatch):
    pytest.importorskip("numba")
    mech = load_mechanism(MECH / f"{name}.yaml")
    rng = np.random.default_rng(2)
    span = np.where(mech.s == 0, np.pi, 0.4)
    nf = len(mech.frame_names)
    for m in (1, 5, K.PLAN_LARGE_BATCH + 3, K.PLAN_BLOCK + 5):
        qs = rng.uniform(-span, span, size=(m, mech.n))
        kin = forward_kinematics(mech, qs)
        for idx in ([nf - 1], None, list(range(0, nf, 3))):
            a, b = _both(mech, qs, idx, monkeypatch)
            ref = kin.frames(mech, idx)
            np.testing.assert_allclose(a, ref, rtol=0, atol=1e-12)
            np.testing.assert_allclose(b, ref, rtol=0, atol=1e-12)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_the_cases_are_covered():
    # the mechanisms above: prismatic joints, branches (a joint's parent link has two child
    # joints) and closed chains (cuts: their spanning tree is what frame_poses evaluates)
    kinds = {"prismatic": False, "branch": False, "closed": False}
    for name in ("lee_spherical_rrps", "kim1995_stewart", "hwang2023_biped"):
        mech = load_mechanism(MECH / f"{name}.yaml")
        kinds["prismatic"] |= bool(np.any(mech.s == 1))
        kinds["branch"] |= bool(np.any(np.bincount(mech.joint_parent_link) > 1))
        kinds["closed"] |= bool(mech.cuts)
    assert all(kinds.values()), kinds


def test_compiled_route_other_inputs(monkeypatch):
    pytest.importorskip("numba")
    monkeypatch.setenv("MECHKIN_JIT", "1")
    mech = load_mechanism(MECH / "kim1995_stewart.yaml")
    rng = np.random.default_rng(4)
    qs = rng.uniform(-0.3, 0.3, size=(6, mech.n))
    ee = [len(mech.frame_names) - 1, 0]
    ref = forward_kinematics(mech, qs).frames(mech, ee)
    frame_poses(mech, qs, ee)
    kern = fk_accel.KERNEL
    assert kern is not None
    ro = qs.copy()
    ro.flags.writeable = False
    for q in (np.asfortranarray(qs), ro, qs.astype(np.float32).astype(np.float64), qs.tolist(),
              np.repeat(qs, 2, axis=1)[:, ::2], np.broadcast_to(qs[:1], (6, mech.n))):
        want = forward_kinematics(mech, np.array(q, dtype=np.float64)).frames(mech, ee)
        np.testing.assert_allclose(frame_poses(mech, q, ee), want, rtol=0, atol=1e-12)
    assert len(kern.signatures) == 1  # no new compile for other layouts: normalised instead
    one = frame_poses(mech, qs[2:3], ee)
    np.testing.assert_allclose(one, ref[2:3], rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        frame_poses(mech, np.zeros((2, mech.n - 1)), ee)
    with pytest.raises(ValueError):
        frame_poses(mech, np.zeros(mech.n), ee)


def test_rent_or_buy(monkeypatch):
    pytest.importorskip("numba")
    mech = load_mechanism(MECH / "puma560.yaml")
    q = mech.home[None]
    ee = [mech.end_effector]
    monkeypatch.setenv("MECHKIN_JIT", "0")
    ref = forward_kinematics(mech, q).frames(mech, ee)
    monkeypatch.delenv("MECHKIN_JIT")
    fk_accel.reset()
    est = fk_accel.estimate_s(6, 1)
    monkeypatch.setattr(fk_accel, "LOAD_S", 3.5 * est)
    monkeypatch.setattr(fk_accel, "LOAD_WARM_S", 3.5 * est)
    for _ in range(3):  # 3 estimated calls fit below the load cost: numpy
        np.testing.assert_allclose(frame_poses(mech, q, ee), ref, rtol=0, atol=1e-12)
        assert fk_accel.KERNEL is None
    np.testing.assert_allclose(frame_poses(mech, q, ee), ref, rtol=0, atol=1e-12)
    assert fk_accel.KERNEL is not None  # the fourth would pass it: loaded for good
    # batches stay on the numpy routes without MECHKIN_JIT=1 (the same bits in every process),
    # also once the kernel serves single configurations
    big = np.repeat(q, 2000, axis=0)
    ref_big = frame_poses(mech, big, ee)
    fk_accel.reset()
    monkeypatch.setattr(fk_accel, "LOAD_S", 1e-3)
    monkeypatch.setattr(fk_accel, "LOAD_WARM_S", 1e-3)
    np.testing.assert_array_equal(frame_poses(mech, big, ee), ref_big)
    assert fk_accel.KERNEL is None
    # MECHKIN_JIT=0: never
    fk_accel.reset()
    monkeypatch.setenv("MECHKIN_JIT", "0")
    for _ in range(3):
        frame_poses(mech, np.repeat(q, 2000, axis=0), ee)
    assert fk_accel.KERNEL is None


def test_estimate_grows_with_the_job():
    assert fk_accel.estimate_s(6, 1) < fk_accel.estimate_s(6, 10) < fk_accel.estimate_s(6, 1e5)
    assert fk_accel.estimate_s(3, 100) < fk_accel.estimate_s(6, 100)
    assert 0 < fk_accel.LOAD_WARM_S < fk_accel.LOAD_S


def _run(code: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("MECHKIN_JIT", None)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True, timeout=600)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_few_calls_do_not_load_numba():
    # a fresh process with the default (no MECHKIN_JIT) that calls frame_poses a few times
    # never pays for numba
    got = _run(
        "import json, sys, numpy as np\n"
        "from mechkin.model import load_mechanism\n"
        "from mechkin.model.kinematics import frame_poses\n"
        f"mech = load_mechanism({str(MECH / 'puma560.yaml')!r})\n"
        "for k in range(10):\n"
        "    frame_poses(mech, mech.home[None], [mech.end_effector])\n"
        "frame_poses(mech, np.zeros((5000, 6)), [mech.end_effector])\n"
        "print(json.dumps({'numba': 'numba' in sys.modules}))\n")
    assert got == {"numba": False}


def test_warm_compiles_or_loads_into_the_cache_folder():
    pytest.importorskip("numba")
    # NUMBA_CACHE_DIR is the tests' temporary folder (tests/conftest.py), inherited here
    assert os.environ.get("NUMBA_CACHE_DIR")
    code = ("import json\nfrom mechkin.model import fk_accel\n"
            "s, c = fk_accel.warm()\n"
            "print(json.dumps({'s': s, 'cached_after': fk_accel.is_cached(),"
            " 'loaded': fk_accel.KERNEL is not None}))\n")
    src = Path(fk_accel.__file__).resolve().parent
    before = {p: p.stat().st_mtime_ns for p in (src / "__pycache__").glob("fk_jit*")}
    first = _run(code)
    assert first["loaded"] and first["cached_after"] is True
    after = {p: p.stat().st_mtime_ns for p in (src / "__pycache__").glob("fk_jit*")}
    assert after == before  # nothing written into the package (a user's warmup may be there)


@pytest.mark.parametrize("name", ["kim1995_stewart", "hwang2023_biped", "lee_spherical_rrps",
                                  "panda"])
def test_tree_fk_routes_and_the_closure_step(name, monkeypatch):
    # forward_kinematics below LARGE_BATCH runs the compiled plan of every link once loaded;
    # the closure Newton step (model/closure.py) uses it: same links, axes and solutions
    pytest.importorskip("numba")
    from mechkin.model.closure import solve_closure

    mech = load_mechanism(MECH / f"{name}.yaml")
    rng = np.random.default_rng(9)
    q = mech.home + rng.uniform(-0.02, 0.02, size=(3, mech.n))
    got = {}
    for mode in ("0", "1"):
        monkeypatch.setenv("MECHKIN_JIT", mode)
        fk_accel.reset()
        kin = forward_kinematics(mech, q)
        assert (fk_accel.KERNEL is not None) == (mode == "1")
        res = solve_closure(mech, q[:, mech.independent], q[:, mech.dependent])
        got[mode] = (kin.T_links, *kin.axes(), res.q, res.iterations)
    for a, b in zip(got["0"], got["1"], strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    for r in range(3):
        for f in range(mech.n_links):
            assert np.allclose(got["1"][0][r, f], _naive(mech, q[r], f), rtol=0, atol=1e-12)


@pytest.mark.parametrize("path", sorted(MECH.glob("*.yaml")), ids=lambda p: p.stem)
def test_generated_single_function_equals_the_plain_python_route(path):
    # the straight-line function folds exact zeros and ones of the constants only: the same
    # floating-point operations in the same order as _plan_one, so equal to the last bit
    mech = load_mechanism(path)
    rng = np.random.default_rng(13)
    nf = len(mech.frame_names)
    for fi in ([nf - 1], list(range(nf)), [0], list(range(nf - 1, -1, -2))):
        plan = K._path_plan(mech, np.array(fi))
        fn = K._one_function(plan)
        for q in rng.uniform(-3.0, 3.0, size=(20, mech.n)):
            np.testing.assert_array_equal(fn(q.tolist()), K._plan_one(plan, q))


@pytest.mark.parametrize("name", ["puma560", "panda", "kim1995_stewart", "lee_spherical_rrps"])
def test_compiled_single_configuration_equals_the_plain_python_route(name):
    # the kernel performs _plan_one's operations in its order: one configuration gives the same
    # bits by either route (batches agree to round-off only: other operation orders)
    pytest.importorskip("numba")
    mech = load_mechanism(MECH / f"{name}.yaml")
    kern = fk_accel.load()
    nf = len(mech.frame_names)
    plan = K._path_plan(mech, np.array([nf - 1, 0, nf // 2]))
    for q in np.random.default_rng(17).uniform(-3.0, 3.0, size=(50, mech.n)):
        out = np.empty((1, plan.k, 4, 4))
        kern(q[None].copy(), plan.jit, out)
        np.testing.assert_array_equal(out, K._plan_one(plan, q))


def test_a_mechanism_with_cached_plans_pickles():
    import pickle

    mech = load_mechanism(MECH / "puma560.yaml")
    frame_poses(mech, mech.home[None], [mech.end_effector])  # plan + generated function
    back = pickle.loads(pickle.dumps(mech))
    np.testing.assert_array_equal(frame_poses(back, back.home[None], [back.end_effector]),
                                  frame_poses(mech, mech.home[None], [mech.end_effector]))

"""The compiled single-solve path of solve_ik (open chains) and the compiled verification of
solve_ik_batch give the answers of the general loop: the same joints bit for bit, the same
statuses, iterations, evaluations and histories, the verified errors to rounding (issue 15).
Also: the one-target seed lookup equals the batched one, the cached restart draws equal fresh
ones, and the job-size peek of the back end does not count a call."""

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, accel, kernel_for, solve_ik, solve_ik_batch
from mechkin.solvers.ik import solve as solve_mod
from mechkin.solvers.ik.seeds import seed_rows, seed_starts

pytest.importorskip("numba")


def _targets(mech, n, seed):
    kern = kernel_for(mech)
    rng = np.random.default_rng(seed)
    q = rng.uniform(kern.lower_v, kern.upper_v, size=(n, mech.n))
    return forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]


def _fields(r):
    return (r.q, r.q_v, r.status, r.f, r.grad_norm, r.iterations, r.evaluations, r.f_history,
            r.at_limit, r.restarts_used, r.method)


CASES = {
    "defaults": dict(options=IkOptions(restarts=50)),
    "guess": dict(options=IkOptions(restarts=30, tol_pos=1e-7), q_v0="home+0.3"),
    "no restarts": dict(options=IkOptions()),
    "one restart": dict(options=IkOptions(restarts=1, seed=3)),
    "position only": dict(options=IkOptions(restarts=5), weights=np.array([1, 1, 1, 0, 0, 0.])),
    "grad tol": dict(options=IkOptions(restarts=10, lm_grad_tol=1e-8, max_iter=40)),
}


@pytest.mark.parametrize("name", ["puma560", "panda"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_compiled_single_solve_equals_the_general_loop(root, monkeypatch, name, case):
    mech = load_mechanism(root / "mechanisms" / f"{name}.yaml")
    kern = kernel_for(mech)
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    kw = dict(CASES[case])
    if kw.get("q_v0") == "home+0.3":
        kw["q_v0"] = mech.home[kern.iv] + 0.3
    T = _targets(mech, 25, 7)
    far = T[0].copy()
    far[:3, 3] *= 3.0  # out of reach: every restart runs, the best failure is kept
    targets = [*T, far]
    fast = [solve_ik(mech, Tk, kernel=kern, **kw) for Tk in targets]
    monkeypatch.setattr(solve_mod, "_fast_open", lambda kern: False)
    ref = [solve_ik(mech, Tk, kernel=kern, **kw) for Tk in targets]
    if kw["options"].restarts:
        assert any(r.restarts_used for r in ref)  # the restart rows are exercised
    assert ref[-1].status is not ref[0].status
    for a, b in zip(fast, ref, strict=True):
        for u, v in zip(_fields(a), _fields(b), strict=True):
            if isinstance(u, np.ndarray):
                np.testing.assert_array_equal(u, v)
            else:
                assert u == v
        assert a.position_error == pytest.approx(b.position_error, rel=1e-9, abs=1e-12)
        assert a.orientation_error == pytest.approx(b.orientation_error, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("name", ["puma560", "panda"])
def test_compiled_small_batch_equals_the_general_loop(root, monkeypatch, name):
    mech = load_mechanism(root / "mechanisms" / f"{name}.yaml")
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    T = _targets(mech, 40, 11)
    far = T[:2].copy()
    far[:, :3, 3] *= 3.0
    T = np.concatenate([T, far])
    for m in (1, 7, len(T)):
        for kw in (dict(options=IkOptions(restarts=20)),
                   dict(options=IkOptions(restarts=9, seed=2), q_v0=mech.home)):
            a = solve_ik_batch(mech, T[:m], **kw)  # small batch: one compiled call/attempt
            with monkeypatch.context() as mp:
                mp.setattr(solve_mod, "SMALL_BATCH", 0)  # the general loop
                b = solve_ik_batch(mech, T[:m], **kw)
                mp.setattr(accel, "is_loaded", lambda kind: False)  # ... numpy verification
                c = solve_ik_batch(mech, T[:m], **kw)
            for x in (b, c):
                np.testing.assert_array_equal(a.q, x.q)
                np.testing.assert_array_equal(a.f, x.f)
                np.testing.assert_array_equal(a.iterations, x.iterations)
                assert list(a.status) == list(x.status)
                np.testing.assert_allclose(a.position_error, x.position_error, rtol=1e-9,
                                           atol=1e-12)
                np.testing.assert_allclose(a.orientation_error, x.orientation_error, rtol=1e-9,
                                           atol=1e-12)
    assert not a.ok.all() and a.ok[:-2].all()


@pytest.mark.parametrize("w", [[1, 1, 1, 1, 1, 1], [1, 1, 1, 0, 0, 0], [0, 0, 0, 1, 1, 1],
                               [0, 0, 0, 0, 0, 0], [2, 0, 1, 0, 0.5, 0]])
def test_one_target_seed_lookup_equals_the_batched_one(root, w):
    mech = load_mechanism(root / "mechanisms" / "puma560.yaml")
    kern = kernel_for(mech)
    w = np.asarray(w, dtype=float)
    for T in _targets(mech, 20, 5):
        for first, count in ((0, 1), (1, 7), (0, 8), (3, 1)):
            want = seed_starts(kern, T[None], w[None], ranks=range(first, first + count))[0]
            np.testing.assert_array_equal(seed_rows(kern, T, w, first, count), want)


def test_cached_restart_draws_equal_fresh_draws(root):
    mech = load_mechanism(root / "mechanisms" / "panda.yaml")
    kern = kernel_for(mech)
    lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
    hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
    for seed, k in ((0, 50), (3, 1), (0, 50)):
        a = solve_mod._restart_draws(kern, seed, k)
        np.testing.assert_array_equal(a, np.random.default_rng(seed).uniform(lo, hi, (k, 7)))
        a[:] = 0.0  # the caller's copy: the cache is untouched
    assert solve_mod._restart_draws(kern, 0, 50).any()


def test_the_back_end_peek_does_not_count_a_call(monkeypatch):
    monkeypatch.delenv("MECHKIN_JIT", raising=False)
    monkeypatch.setattr(accel, "_loaded", set())
    accel.reset_job()
    try:
        n = 0
        while accel.compiled_next("open", 1) is False:
            for _ in range(3):
                assert accel.compiled_next("open", 1) is False  # a peek counts nothing
            assert accel.use_compiled("open", 1) is False
            n += 1
        assert accel.use_compiled("open", 1) is True  # the peek agreed
        assert n == int(accel.OPEN_LOAD_S // (accel.OPEN_CALL_S + accel.OPEN_ROW_S))
    finally:
        accel.reset_job()


def test_the_50_target_cli_job_stays_numpy(root, monkeypatch):
    """`mechkin ik scenarios/puma560_random_ik.yaml` (50 single solves, 31 restarted): numpy
    is faster end to end than loading the compiled kernels (measured, accel.py), so the
    rent-or-buy rule never loads them for it."""
    from mechkin.config.scenario import load_scenario
    from mechkin.tasks import ik as ik_task

    monkeypatch.delenv("MECHKIN_JIT", raising=False)
    monkeypatch.setattr(accel, "_loaded", set())
    accel.reset_job()
    try:
        rep = ik_task.run(load_scenario(root / "scenarios" / "puma560_random_ik.yaml"),
                          progress=False)
        assert rep.summary["counts"] == {"ok": 50}
        assert not accel.is_loaded("open")
    finally:
        accel.reset_job()


def test_exact_seed_search_equals_the_kdtree_without_approximation(root, monkeypatch):
    """seeds.ExactSearch (numpy, no scipy.spatial) gives cKDTree's eps = 0 neighbours; with
    SEARCH = "exact" the codebook is searched by it and the starts are those neighbours."""
    from scipy.spatial import cKDTree

    from mechkin.solvers.ik import seeds

    mech = load_mechanism(root / "mechanisms" / "panda.yaml")
    kern = kernel_for(mech)
    qs, tree = seeds.codebook(kern, 2048, tuple(range(12)))
    assert isinstance(tree, cKDTree)
    ex = seeds.ExactSearch(tree.data)
    rng = np.random.default_rng(2)
    X = tree.data[rng.integers(0, 2048, 700)] + rng.normal(0.0, 0.05, (700, 12))
    for k in (1, 3, 8):
        d0, i0 = tree.query(X, k=k, eps=0.0)
        d1, i1 = ex.query(X, k=k)
        np.testing.assert_array_equal(i1, i0)
        np.testing.assert_allclose(d1, d0, rtol=1e-12, atol=1e-12)
    monkeypatch.setattr(seeds, "SEARCH", "exact")
    T = _targets(mech, 30, 9)
    w = np.ones((30, 6))
    got = seeds.seed_starts(kern, T, w, ranks=(0, 2), size=2048)
    feats = np.concatenate([T[:, :3, 3], 0.5 * T[:, :3, :3].reshape(30, 9)], axis=1)
    _, want = tree.query(feats, k=3, eps=0.0)
    np.testing.assert_array_equal(got, qs[want[:, [0, 2]]])

"""IK of mechanisms with joint couplings (issue 25): coupled open chains (a 7R arm with a mimic
gripper finger carrying {E}, example-robot-data's Panda with its mimic finger) take the compiled
open-chain lm in reduced coordinates and the seed codebook; a closed chain with couplings takes
the compiled closed-chain lm with coupling rows. Answers are checked by Pinocchio's FK (Panda)
or the loop-closure route (the others), coupled joints equal ``m q_master + c`` exactly, every
joint within its limits, and the compiled and numpy back ends agree."""

from __future__ import annotations

import numpy as np
import pytest

import mechkin
from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.couplings import coupling_jacobian
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, accel, kernel_for, solve_ik, solve_ik_batch
from mechkin.solvers.ik.kernel import evaluate
from mechkin.solvers.ik.lm import lm_batch
from mechkin.solvers.ik.seeds import seed_starts
from tests.config.robot_files import pin_frames, pin_model, pin_q, robots_dir

pytest.importorskip("numba")

TIGHT = IkOptions(restarts=50, tol_pos=1e-11, tol_ori=1e-11)


@pytest.fixture(scope="module")
def gripper(request):
    from pathlib import Path

    return load_mechanism(Path(__file__).resolve().parents[1] / "data" / "gripper_mimic.yaml")


@pytest.fixture(scope="module")
def panda_path():
    return robots_dir() / "panda_description" / "urdf" / "panda.urdf"


@pytest.fixture(scope="module")
def panda(panda_path):
    return load_mechanism(panda_path)


def _closure_q(mech, qv):
    """All joints at q_v (m, n_v) by the loop closure (Newton-Raphson on the coupling rows from
    the home guess, :func:`mechkin.model.closure.solve_closure`), not by the closed form."""
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (len(qv), len(mech.dependent))).copy())
    assert res.ok.all()
    return res.q


def _targets(mech, frame, n, seed):
    """Poses of ``frame`` at random independent joints within the limits (bounded by the
    coupled joints' limits), coupled joints by the loop closure."""
    rng = np.random.default_rng(seed)
    kern = kernel_for(mech, frame)
    qv = rng.uniform(kern.lower_v, kern.upper_v, size=(n, kern.iv.size))
    return forward_kinematics(mech, _closure_q(mech, qv)).frames(mech, [frame])[:, 0]


def _spy(monkeypatch, module, name):
    calls = []
    fn = getattr(module, name)

    def wrapped(*a, **k):
        calls.append(name)
        return fn(*a, **k)

    monkeypatch.setattr(module, name, wrapped)
    return calls


def _check_couplings_and_limits(mech, q):
    q = np.atleast_2d(q)
    for c in mech.couplings:  # exactly the row m q_master + c
        np.testing.assert_array_equal(q[:, c.joint], c.multiplier * q[:, c.master] + c.offset)
    assert np.all(q >= mech.lower - 1e-12) and np.all(q <= mech.upper + 1e-12)


def test_closed_form_couplings_equal_the_loop_closure(gripper, panda):
    """q = S q_v + c0 and the reduced Jacobian (dx/dq) S equal the loop-closure route's q and
    kim1995 Eq. (10) with the coupling rows of phi."""
    for mech in (gripper, panda):
        kern = kernel_for(mech)
        assert kern.coupling is not None and kern.open_path
        rng = np.random.default_rng(3)
        qv = rng.uniform(kern.lower_v, kern.upper_v, size=(6, kern.iv.size))
        q_ref = _closure_q(mech, qv)  # Newton-Raphson on the coupling rows
        np.testing.assert_allclose(kern.coupling.full(qv), q_ref, atol=1e-14, rtol=0)
        fk = mechkin.fk(mech, qv, frames=[])  # the API's FK: the closed form, no continuation
        np.testing.assert_allclose(fk.q, q_ref, atol=1e-14, rtol=0)
        assert set(fk.status) == {"converged"} and fk.residual.max() < 1e-15
        T_P = forward_kinematics(mech, q_ref[::-1]).frames(mech, [kern.frame])[:, 0]
        ev = evaluate(kern, qv, np.zeros((6, kern.iw.size)), T_P)
        x, Jq = kern.residual_jacobian(forward_kinematics(mech, q_ref), T_P)
        Phi = coupling_jacobian(mech)
        Jr = Jq[:, :, kern.iv] - Jq[:, :, kern.iw] @ np.linalg.solve(Phi[:, kern.iw],
                                                                   Phi[:, kern.iv])
        np.testing.assert_allclose(ev.x, x, atol=1e-13, rtol=0)
        np.testing.assert_allclose(ev.J, Jr, atol=1e-13, rtol=0)


def test_fk_reports_a_coupled_joint_outside_its_limits(gripper):
    """The API's FK in closed form keeps the loop closure's verdicts: finger_l = 0.038 puts its
    mimic at -0.038, beyond finger_r's -0.03 limit: ``outside limits``, within_limits False."""
    kern = kernel_for(gripper)
    qv = np.array([gripper.home[kern.iv]] * 2)
    qv[1, -1] = 0.038
    res = mechkin.fk(gripper, qv, frames=["tip"])
    assert list(res.status) == ["converged", "outside limits"]
    assert res.within_limits == [True, False]
    np.testing.assert_array_equal(res.q[1, gripper.joint_index("finger_r")], -0.038)


def test_coupled_limits_bound_the_masters(gripper):
    """finger_r = -finger_l with finger_r in [-0.03, 0]: finger_l in [0, 0.03] (not its own
    [0, 0.04]); q3 = -0.5 q2 + 0.2 within [-2, 2] leaves q2's [-1.8, 1.8]; the codebook's
    starts keep the couplings and the limits."""
    kern = kernel_for(gripper)
    names = gripper.independent_names
    assert kern.lower_v[names.index("finger_l")] == 0.0
    assert kern.upper_v[names.index("finger_l")] == pytest.approx(0.03, abs=1e-17)
    assert (kern.lower_v[names.index("q2")], kern.upper_v[names.index("q2")]) == (-1.8, 1.8)
    assert not kern.cont_v.any()
    starts = seed_starts(kern, _targets(gripper, kern.frame, 4, 1), np.ones((4, 6)),
                         ranks=range(8))
    assert starts is not None  # the codebook serves coupled open chains
    _check_couplings_and_limits(gripper, kern.coupling.full(starts.reshape(-1, kern.iv.size)))


def test_gripper_ik_compiled_route_fk_verified(gripper, monkeypatch):
    """Defaults (no guess: the codebook's nearest pose, then restarts): the compiled reduced
    kernel runs (never the loop closure), every answer reaches its target to 1e-10 by the tree
    FK, coupled joints are exact and all joints within their limits, including targets whose
    finger opening is outside the coupled finger's limits (the arm reaches them otherwise)."""
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    from mechkin.solvers.ik import coupled_jit, tree_jit

    calls = _spy(monkeypatch, coupled_jit, "lm_coupled_rows")
    closed = _spy(monkeypatch, tree_jit, "lm_closed_rows")
    kern = kernel_for(gripper)
    T = _targets(gripper, kern.frame, 12, 5)
    qv = np.array(gripper.home[kern.iv])
    qv[-1] = 0.038  # finger_l beyond the 0.03 its mimic allows
    q_bad = kern.coupling.full(qv[None])
    T_far = forward_kinematics(gripper, q_bad).frames(gripper, [kern.frame])[:, 0]
    for Tk in [*T, *T_far]:
        r = solve_ik(gripper, Tk, options=TIGHT)
        assert r.status.value == "ok" and r.method == "lm"
        T_E = forward_kinematics(gripper, r.q[None]).frames(gripper, [kern.frame])[0, 0]
        np.testing.assert_allclose(T_E, Tk, atol=1e-10, rtol=0)
        _check_couplings_and_limits(gripper, r.q)
    assert calls and not closed


@pytest.mark.parametrize("frame", ["panda_hand_tcp", "panda_rightfinger"])
def test_panda_mimic_ik_verified_by_pinocchio(panda, panda_path, monkeypatch, frame):
    """Panda URDF with the mimic finger: {E} the hand TCP (the coupling is off the path) and
    the mimic finger itself (on the path, its master off it). Single solves and a batch by the
    compiled reduced kernel; Pinocchio's FK (its own mimic joint, or the XML's m q + c) of the
    answers equals the targets to 1e-10."""
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    from mechkin.solvers.ik import coupled_jit

    calls = _spy(monkeypatch, coupled_jit, "lm_coupled_rows")
    pin, model, data = pin_model(panda_path)
    f = panda.frame_index(frame)
    T = _targets(panda, f, 8, 11)
    single = [solve_ik(panda, Tk, options=TIGHT, frame=f) for Tk in T]
    batch = solve_ik_batch(panda, T, options=TIGHT, frame=f)
    assert calls
    qs = np.stack([r.q for r in single] + list(batch.q))
    assert all(r.status.value == "ok" for r in single) and batch.ok.all()
    _check_couplings_and_limits(panda, qs)
    for q, Tk in zip(qs, [*T, *T], strict=True):
        T_pin = pin_frames(pin, model, data, pin_q(model, panda, q), [frame])[0]
        np.testing.assert_allclose(T_pin, Tk, atol=1e-10, rtol=0)


def test_compiled_and_numpy_lm_agree_on_a_coupled_chain(gripper, monkeypatch):
    """The same starts, one lm run each, no restarts: the compiled kernel in reduced
    coordinates and the numpy rows follow the same iteration (agree to round-off growth)."""
    kern = kernel_for(gripper)
    T = np.ascontiguousarray(_targets(gripper, kern.frame, 10, 9))
    rng = np.random.default_rng(4)
    qv0 = np.ascontiguousarray(np.clip(kern.coupling.full(rng.uniform(
        kern.lower_v, kern.upper_v, size=(10, kern.iv.size)))[:, kern.iv], kern.lower_v,
        kern.upper_v))
    w = np.ones((10, 6))
    out = {}
    for backend in ("compiled", "numpy"):
        monkeypatch.setattr(accel, "compiled_lm_available", lambda b=backend: b == "compiled")
        out[backend] = lm_batch(kern, qv0.copy(), np.zeros((10, kern.iw.size)), T, w,
                                IkOptions(tol_pos=1e-11, tol_ori=1e-11))
    a, b = out["compiled"], out["numpy"]
    assert a["closed"].all() and b["closed"].all()
    np.testing.assert_array_equal(a["iters"], b["iters"])
    reached = a["f"] < 1e-24  # (random starts, no restarts: some rows end in a local minimum)
    np.testing.assert_array_equal(reached, b["f"] < 1e-24)
    assert reached.sum() >= 5
    # the arm is redundant (9 joints, 6 equations): round-off moves an answer along the
    # self-motion, so rows agree to round-off growth, not to the last bit
    assert np.abs(a["q"] - b["q"])[reached].max() < 1e-8
    np.testing.assert_allclose(a["q"], b["q"], atol=1e-4, rtol=0)
    for r in (a, b):
        _check_couplings_and_limits(gripper, r["q"])
        T_E = forward_kinematics(gripper, r["q"][reached]).frames(gripper, [kern.frame])[:, 0]
        np.testing.assert_allclose(T_E, T[reached], atol=1e-10, rtol=0)


#: tests/config/test_couplings.py's four-bar: a cut and two couplings in one phi
def _coupled_fourbar(tmp_path):
    from tests.config.test_couplings import YAML

    p = tmp_path / "coupled.yaml"
    p.write_text(YAML)
    return load_mechanism(p)


def test_closed_chain_with_couplings_compiled(tmp_path, monkeypatch):
    """Cuts and couplings: the compiled closed-chain lm (coupling rows after the cut rows)
    runs, reaches the targets (checked by the numpy loop-closure FK), keeps phi (cut and
    coupling rows) at zero, and agrees with the numpy back end."""
    from mechkin.model.kinematics import closure_residual
    from mechkin.solvers.ik import tree_jit

    mech = _coupled_fourbar(tmp_path)
    kern = kernel_for(mech)
    assert kern.coupling is None  # cut links: the loop-closure route
    qv = np.radians([[50.0], [58.0], [66.0], [75.0]])
    T = mechkin.fk(mech, qv, frames=["tip"]).poses["tip"]
    res = {}
    for backend in ("compiled", "numpy"):
        monkeypatch.setattr(accel, "compiled_lm_available", lambda b=backend: b == "compiled")
        calls = _spy(monkeypatch, tree_jit, "lm_closed_rows")
        res[backend] = [solve_ik(mech, Tk, q_v0=np.radians([60.0]),
                                 options=IkOptions(restarts=5, tol_pos=1e-11, tol_ori=1e-11))
                        for Tk in T]
        assert bool(calls) == (backend == "compiled")
    for a, b, Tk in zip(res["compiled"], res["numpy"], T, strict=True):
        assert a.status.value == "ok" and b.status.value == "ok"
        np.testing.assert_allclose(a.q, b.q, atol=1e-9, rtol=0)
        kin = forward_kinematics(mech, a.q[None])
        assert np.abs(closure_residual(mech, kin)).max() < 1e-12
        np.testing.assert_allclose(kin.frames(mech, [kern.frame])[0, 0], Tk, atol=1e-10)


def test_every_solution_of_a_coupled_chain(gripper):
    """``solutions: all`` by multi-start lm on the coupled gripper: codebook starts, every
    solution reaches the target by the tree FK, coupled joints exact, limits kept."""
    from mechkin.solvers.ik.all_solutions import multistart_all

    kern = kernel_for(gripper)
    T = _targets(gripper, kern.frame, 1, 21)[0]
    sols = multistart_all(gripper, T, starts=24)
    assert sols.count >= 2
    T_E = forward_kinematics(gripper, sols.q).frames(gripper, [kern.frame])[:, 0]
    np.testing.assert_allclose(T_E, np.broadcast_to(T, T_E.shape), atol=1e-6, rtol=0)
    _check_couplings_and_limits(gripper, sols.q)


def test_warmup_covers_the_coupled_kernel(tmp_path, monkeypatch):
    """``mechkin warmup`` (its built-in coupled arm) compiles the coupled kernel with the
    signature the solvers use: a later solve adds none."""
    from mechkin.solvers.ik import coupled_jit, warm

    p = tmp_path / "coupled.yaml"
    p.write_text(warm.TINY_COUPLED)
    mech = load_mechanism(p)
    assert kernel_for(mech).coupling is not None
    assert "coupled_jit.lm_coupled" in [n for n, _ in warm.kernels_for(mech)]
    for _ in warm.warm([mech]):
        pass
    sigs = list(coupled_jit.lm_coupled.signatures)
    assert sigs
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    calls = _spy(monkeypatch, coupled_jit, "lm_coupled_rows")
    T = _targets(mech, mech.end_effector, 2, 1)
    assert solve_ik_batch(mech, T, options=IkOptions(restarts=3)).ok.all()
    assert calls and list(coupled_jit.lm_coupled.signatures) == sigs


def test_coupled_rows_on_threads_equal_one_thread(gripper, monkeypatch):
    """Large batches run row blocks on threads (as the plain open-chain kernel): the same
    answers as one thread, bit for bit."""
    from mechkin.solvers.ik import coupled_jit

    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    kern = kernel_for(gripper)
    T = _targets(gripper, kern.frame, 12, 13)
    one = solve_ik_batch(gripper, T, options=IkOptions(restarts=4))
    monkeypatch.setattr(coupled_jit, "PARALLEL_ROWS", 4)
    monkeypatch.setattr(coupled_jit, "_CPUS", 3)
    many = solve_ik_batch(gripper, T, options=IkOptions(restarts=4))
    np.testing.assert_array_equal(one.q, many.q)
    np.testing.assert_array_equal(one.iterations, many.iterations)
    assert one.ok.sum() >= 10


def test_cg_golden_on_a_coupled_chain_both_back_ends(gripper, monkeypatch):
    """kim1995 §5.2 on the coupled gripper: the compiled point evaluator (the coupling rows of
    the compiled loop closure) and the numpy one (couplings in closed form) take the same
    steps to the same answer."""
    kern = kernel_for(gripper)
    rng = np.random.default_rng(2)
    qv = rng.uniform(kern.lower_v, kern.upper_v, size=kern.iv.size)
    T = forward_kinematics(gripper, _closure_q(gripper, qv[None])).frames(
        gripper, [kern.frame])[0, 0]
    out = {}
    for backend in ("compiled", "numpy"):
        monkeypatch.setattr(accel, "compiled_lm_available", lambda b=backend: b == "compiled")
        out[backend] = solve_ik(gripper, T, q_v0=qv + 0.05,
                                options=IkOptions(method="cg-golden", restarts=0))
    a, b = out["compiled"], out["numpy"]
    assert a.status.value == "ok" and b.status.value == "ok"
    assert a.iterations == b.iterations
    np.testing.assert_allclose(a.q, b.q, atol=1e-8, rtol=0)
    _check_couplings_and_limits(gripper, np.stack([a.q, b.q]))


CHAINED = """name: chained
units: {length: m, angle: rad}
links:
  - name: base
  - name: l1
  - name: l2
  - name: l3
  - name: l4
    frames: [{name: tip, xyz: [0.3, 0, 0]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, axis: [0, 0, 1], limits: [-3, 3]}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [0.5, 0, 0]},
     axis: [0, 0, 1], limits: [-2, 2]}
  - {name: q3, type: revolute, parent: l2, child: l3, origin: {xyz: [0.4, 0, 0]},
     axis: [0, 0, 1], limits: [-1.5, 1.0]}
  - {name: q4, type: prismatic, parent: l3, child: l4, axis: [1, 0, 0], limits: [0.0, 0.2]}
couplings:
  - {joint: q4, master: q3, multiplier: -0.1, offset: 0.1}
  - {joint: q3, master: q2, multiplier: 2.0, offset: 0.1}
independent: [q1, q2]
end_effector: tip
"""


def test_chained_couplings_compose(tmp_path, monkeypatch):
    """q4 follows q3, which follows q2: q4 = -0.1 (2 q2 + 0.1) + 0.1. The map composes the
    chain (and evaluates each row as written, so every coupled joint equals its own row to the
    bit), q2's bounds are the intersection of its limits with q3's and q4's images, and IK of
    the planar chain's position reaches its targets within them."""
    p = tmp_path / "chained.yaml"
    p.write_text(CHAINED)
    mech = load_mechanism(p)
    kern = kernel_for(mech)
    cm = kern.coupling
    assert cm is not None
    assert (cm.col[3], cm.mult[3]) == (1, pytest.approx(-0.2))
    assert cm.off[3] == pytest.approx(-0.1 * 0.1 + 0.1)
    # q3 in [-1.5, 1.0] -> q2 in [-0.8, 0.45]; q4 in [0, 0.2] -> q3 in [-1, 1] -> q2 in
    # [-0.55, 0.45]; with q2's own [-2, 2]: [-0.55, 0.45]
    assert kern.lower_v[1] == pytest.approx(-0.55) and kern.upper_v[1] == pytest.approx(0.45)
    rng = np.random.default_rng(8)
    qv = rng.uniform(kern.lower_v, kern.upper_v, size=(8, 2))
    np.testing.assert_allclose(cm.full(qv), _closure_q(mech, qv), atol=1e-14)
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    T = _targets(mech, kern.frame, 8, 2)
    w = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.0])  # planar: x, y of the tip
    for Tk in T:
        r = solve_ik(mech, Tk, weights=w, options=IkOptions(restarts=20, tol_pos=1e-11))
        assert r.status.value == "ok" and r.position_error < 1e-10
        _check_couplings_and_limits(mech, r.q)


def test_empty_coupled_limits_keep_the_loop_closure_route(tmp_path):
    """A coupled joint whose limits no value of its master reaches: no closed form (its
    interval on q_v is empty), the loop-closure route answers and reports the passive joint
    outside its limits instead of an answer."""
    p = tmp_path / "empty.yaml"
    p.write_text(CHAINED.replace("limits: [0.0, 0.2]", "limits: [0.5, 0.6], home: 0.55"))
    mech = load_mechanism(p)
    kern = kernel_for(mech)
    assert kern.coupling is None and not kern.open_path
    T = _targets(mech, kern.frame, 1, 2)[0]
    r = solve_ik(mech, T, weights=np.array([1.0, 1, 0, 0, 0, 0]), options=IkOptions(restarts=2))
    assert r.status.value != "ok" and "q4" in r.at_limit


def test_a_master_with_followers_is_never_wrapped(tmp_path):
    """Limits over a full turn make a revolute joint continuous (wrapped by whole turns), but
    not a master that a joint follows: a whole turn of q2 moves q3 = 2 q2 + 0.1 by two turns
    and the prismatic q4 by -0.4 pi m. q1 (no follower) stays continuous."""
    text = (CHAINED.replace("limits: [-3, 3]", "limits: [-7, 7]")
            .replace("limits: [-2, 2]", "limits: [-7, 7]")
            .replace("limits: [-1.5, 1.0]", "limits: [-7, 7]")
            .replace("limits: [0.0, 0.2]", "limits: [-10, 10]"))
    p = tmp_path / "wide.yaml"
    p.write_text(text)
    kern = kernel_for(load_mechanism(p))
    assert kern.cont_v.tolist() == [True, False]
    assert (kern.lower_v[1], kern.upper_v[1]) == (-7.0, 7.0)  # q4's image is wider
    np.testing.assert_array_equal(kern.project(np.array([[0.0, 7.5]])), [[0.0, 7.0]])  # clamped
    q = np.array([[6.9, 6.9]])
    np.testing.assert_array_equal(kern.nearest_turn(q, np.zeros((1, 2))),
                                  [[6.9 - 2 * np.pi, 6.9]])  # q1 turned, q2 kept

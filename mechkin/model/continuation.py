r"""Assembly by continuation: the loop closure reached from a known assembly (kim1995 §5.1).

Newton-Raphson on :math:`\phi_R(q_v, q_w) = 0` (kim1995 Eq. (4)) converges to the root nearest
its start, which from a far first guess may be another assembly mode (a crossed four-bar, a
parallelogram folded into an anti-parallelogram) or none. Here a requested q_v is reached from
an assembled configuration ``(q_v^0, q_w^0)`` (home, or a neighbouring solved sample) along the
straight path :math:`q_v(t) = q_v^0 + t\,(q_v - q_v^0)`, :math:`t \in [0, 1]`, by a
predictor-corrector with step control:

* predictor: the tangent of the solution curve, kim1995 Eq. (4) differentiated,
  :math:`\dot q_w = -[\partial\phi_R/\partial q_w]^+ [\partial\phi_R/\partial q_v]\,
  (q_v - q_v^0)`, times the step h;
* corrector: at most :data:`CORRECTOR_ITER` Newton steps at :math:`q_v(t + h)`, accepted when
  they converge, contract (each step at most half the previous) and land near the predictor
  (correction no more than half the predicted move plus :data:`ABS_CORRECTION`): a step that
  would jump to another branch fails these tests;
* step control: a failed step is halved, an accepted one grows by 1.5 up to the largest h that
  moves no independent joint by more than :data:`MAX_STEP` (rad, or times the mechanism's size
  for prismatic joints) and no dependent joint by more than :data:`MAX_STEP_W` per step;
* stop: at t = 1 the point is polished by :func:`mechkin.model.closure.solve_closure` to the
  closure tolerance (status ``converged``); a path whose step falls below :data:`MIN_STEP`
  stops there: ``constraint singularity`` when the nondimensionalised
  :math:`\partial\phi_R/\partial q_w` has lost rank there (sigma_min / sigma_max <
  :data:`RATIO_SINGULAR`; the assembly folds, the requested q_v is beyond it), else
  ``not converged``.

The answer is therefore the assembly mode connected to the start along that path, and every
row of a batch advances at once (vectorised over rows with their own t and h).

References
----------
kim1995_complex_chain_ik §5.1, Eq. (4); E. L. Allgower, K. Georg, *Introduction to Numerical
Continuation Methods*, SIAM 2003, §2.2 (predictor-corrector with steplength adaptation).
"""

from __future__ import annotations

import numpy as np

from mechkin.model.closure import (
    MAX_ITER,
    TOL_DQ,
    TOL_PHI,
    ClosureResult,
    ClosureStatus,
    _cond,
    _pinv_solve,
    solve_closure,
)
from mechkin.model.couplings import coupling_jacobian, coupling_map, coupling_residual
from mechkin.model.kinematics import closure_jacobian, forward_kinematics
from mechkin.model.mechanism import Mechanism

MAX_STEP = 0.2          # largest move of an independent joint per step [rad, or x L for m]
MAX_STEP_W = 0.3        # largest predicted move of a dependent joint per step [rad | x L]
MIN_STEP = 1e-7         # smallest path step (fraction of the path) before giving up
CORRECTOR_ITER = 8
TOL_CORRECT = 1e-10     # closure residual accepted inside the path (polished at the end)
ABS_CORRECTION = 1e-6   # correction always allowed regardless of the predicted move
RATIO_SINGULAR = 1e-3   # sigma_min / sigma_max of the scaled dphi/dq_w at a stuck path
MAX_PATH_STEPS = 1_000   # path iterations per call (every active row advances in each)
MAX_PATH_LENGTH = 500    # longest path, in max_step units (100 rad at 0.2): beyond, refused
WINDOW0 = 64            # samples per step-to-step run after a miss (doubling while they hold)


def _size(mech: Mechanism) -> float:
    from mechkin.model.singularity import characteristic_length

    return characteristic_length(mech)


def _scaled_w(mech: Mechanism, Jw: np.ndarray) -> np.ndarray:
    """The nondimensionalised dphi/dq_w (m, n_eq, n_w)."""
    from mechkin.model.singularity import constraint_scaling

    row, col = constraint_scaling(mech, _size(mech))
    if row.size != Jw.shape[1]:  # constraint rows that are not cut rows (couplings): unscaled
        row = np.ones(Jw.shape[1])
    return Jw * row[None, :, None] * col[None, None, :]


def _scaled_ratio(mech: Mechanism, Jw: np.ndarray) -> np.ndarray:
    """sigma_min / sigma_max of the nondimensionalised dphi/dq_w (m, n_eq, n_w)."""
    c = _cond(_scaled_w(mech, Jw))
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(c), 1.0 / c, 0.0)


class _Crossings:
    r"""Constraint singularities crossed along each row's path: the orientation of the
    nondimensionalised dphi/dq_w, :math:`\det(A_i^T A_k) < 0` between consecutive regular
    points i < k of the path (sigma_min / sigma_max >= RATIO_SINGULAR), counted per row
    (Allgower and Georg (2003) §8.1; the fk task's :func:`mechkin.model.singularity.
    constraint_crossings` along a sampled motion)."""

    def __init__(self, m: int) -> None:
        self.count = np.zeros(m, dtype=int)
        self.prev: np.ndarray | None = None
        self.has = np.zeros(m, dtype=bool)

    def see(self, mech: Mechanism, rows: np.ndarray, Jw: np.ndarray) -> None:
        A = _scaled_w(mech, Jw)
        c = _cond(A)
        regular = np.isfinite(c) & (c <= 1.0 / RATIO_SINGULAR)
        if self.prev is None:
            self.prev = np.zeros((self.count.size,) + A.shape[1:])
        r = rows[regular]
        A = A[regular]
        old = self.has[r]
        if old.any():
            d = np.linalg.det(np.swapaxes(self.prev[r[old]], 1, 2) @ A[old])
            self.count[r[old]] += d < 0
        self.prev[r] = A
        self.has[r] = True


def _tangent(mech: Mechanism, J: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """dq_w/dt = -Phi_w^+ Phi_v dv (m, n_w) from closure Jacobians J (m, n_eq, n)."""
    Jw = J[:, :, mech.dependent]
    rhs = np.einsum("mkv,mv->mk", J[:, :, mech.independent], dv)
    step, _ = _pinv_solve(Jw, rhs)
    return -step


def continue_closure(
    mech: Mechanism,
    q_v: np.ndarray,
    q_start: np.ndarray,
    *,
    tol_phi: float = TOL_PHI,
    tol_dq: float = TOL_DQ,
    max_iter: int = MAX_ITER,
    max_step: float = MAX_STEP,
) -> ClosureResult:
    r"""Reach each requested q_v from an assembled start by continuation (module docstring).

    Parameters
    ----------
    q_v : array, shape (m, n_v)
        Requested independent joints [rad | m].
    q_start : array, shape (m, n) or (n,)
        Assembled configurations (all joints, the loops closed) to start from: home, or a
        neighbouring solved sample.
    tol_phi, tol_dq, max_iter
        The final polish (:func:`mechkin.model.closure.solve_closure`).
    max_step : float
        Largest independent-joint move per path step [rad; times the size L for prismatic].

    Returns
    -------
    ClosureResult
        ``status`` ``converged``, ``constraint singularity`` (the path stopped where the
        dependent Jacobian loses rank; ``q`` is the last assembled point on the path) or ``not
        converged``; ``iterations`` counts every Newton step along the path.

    References
    ----------
    kim1995_complex_chain_ik §5.1, Eq. (4); Allgower and Georg (2003) §2.2.
    """
    q_v = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    m = q_v.shape[0]
    start = np.array(np.broadcast_to(np.asarray(q_start, np.float64), (m, mech.n)))
    iw = mech.dependent
    kw = {"tol_phi": tol_phi, "tol_dq": tol_dq, "max_iter": max_iter}
    if m == 0 or len(iw) == 0 or mech.n_equations == 0:
        return solve_closure(mech, q_v, start[:, iw], **kw)
    with np.errstate(all="ignore"):
        return _continue(mech, q_v, start, kw, max_step)


def _continue(mech: Mechanism, q_v: np.ndarray, start: np.ndarray, kw: dict,
              max_step: float) -> ClosureResult:
    m = q_v.shape[0]
    iv, iw = mech.independent, mech.dependent
    L = _size(mech)
    # a row that is not finite, or whose path is longer than MAX_PATH_LENGTH steps, is not
    # tried: it stays at its start, not converged
    refused = ~(np.isfinite(q_v).all(axis=1) & np.isfinite(start).all(axis=1))
    v0 = start[:, iv].copy()
    unit_v = np.where(mech.s[iv] == 1, L, 1.0)
    unit_w = np.where(mech.s[iw] == 1, L, 1.0)
    dv = np.where(refused[:, None], 0.0, q_v - v0)
    span = np.max(np.abs(dv) / unit_v, axis=1, initial=0.0)
    refused |= span > MAX_PATH_LENGTH * max_step
    dv[refused] = 0.0
    span[refused] = 0.0
    h_max = np.where(span > 0, np.minimum(1.0, max_step / np.maximum(span, 1e-300)), 1.0)
    t = np.zeros(m)
    h = h_max.copy()
    qw = start[:, iw].copy()
    iters = np.zeros(m, dtype=int)
    stuck = refused.copy()
    active = span > 0
    crossed = _Crossings(m)
    for _ in range(MAX_PATH_STEPS):
        act = np.flatnonzero(active)
        if act.size == 0:
            break
        hs = np.minimum(h[act], 1.0 - t[act])
        kin = forward_kinematics(mech, mech.assemble(v0[act] + t[act, None] * dv[act], qw[act]))
        _, J = closure_jacobian(mech, kin)
        crossed.see(mech, act, J[:, :, iw])
        tan = _tangent(mech, J, dv[act])
        move = np.max(np.abs(tan) / unit_w, axis=1, initial=0.0)
        hs = np.minimum(hs, np.where(move > 0, MAX_STEP_W / np.maximum(move, 1e-300), hs))
        hs = np.maximum(hs, np.minimum(MIN_STEP, 1.0 - t[act]))
        pred = qw[act] + hs[:, None] * tan
        qv_new = v0[act] + (t[act] + hs)[:, None] * dv[act]
        ok, qc, it = _correct(mech, qv_new, pred, hs[:, None] * tan)
        iters[act] += it
        good = act[ok]
        t[good] = np.where(t[good] + hs[ok] >= 1.0 - 1e-15, 1.0, t[good] + hs[ok])
        qw[good] = qc[ok]
        h[good] = np.minimum(h_max[good], 1.5 * hs[ok])
        bad = act[~ok]
        h[bad] = 0.5 * hs[~ok]
        gave_up = bad[h[bad] < MIN_STEP]
        stuck[gave_up] = True
        active[gave_up] = False
        active[good[t[good] >= 1.0]] = False
    stuck |= active  # out of path steps
    fin = ~stuck
    res_q = mech.assemble(v0 + t[:, None] * dv, qw)
    status = np.empty(m, dtype=object)
    residual = np.zeros(m)
    cond = np.ones(m)
    if fin.any():
        pol = solve_closure(mech, q_v[fin], qw[fin], **kw)
        res_q[fin] = pol.q
        status[fin] = pol.status
        iters[fin] += pol.iterations
        residual[fin] = pol.residual
        cond[fin] = pol.cond
        moved = np.flatnonzero(fin & (span > 0))
        if moved.size:  # the path's end against its last regular point
            _, Jf = closure_jacobian(mech, forward_kinematics(mech, res_q[moved]))
            crossed.see(mech, moved, Jf[:, :, iw])
    status[refused] = ClosureStatus.NOT_CONVERGED
    residual[refused] = np.inf
    res_q[np.ix_(refused, iv)] = q_v[refused]  # the requested joints, the start's q_w
    stuck &= ~refused
    if stuck.any():
        kin = forward_kinematics(mech, res_q[stuck])
        phi, J = closure_jacobian(mech, kin)
        Jw = J[:, :, iw]
        ratio = _scaled_ratio(mech, Jw)
        residual[stuck] = np.linalg.norm(phi, axis=1)
        cond[stuck] = _cond(Jw)
        status[stuck] = np.where(ratio < RATIO_SINGULAR, ClosureStatus.CONSTRAINT_SINGULAR,
                                 ClosureStatus.NOT_CONVERGED)
    return ClosureResult(res_q, status, iters, residual, cond, crossings=crossed.count)


def _correct(mech: Mechanism, q_v: np.ndarray, pred: np.ndarray, moved: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton corrector at q_v (k, n_v) from the predictor (k, n_w): (accepted (k,), q_w,
    iterations (k,)). Accepted when ||phi|| < TOL_CORRECT within CORRECTOR_ITER contracting
    steps and the correction stays within half the predicted move (``moved``)."""
    k = q_v.shape[0]
    qw = pred.copy()
    iw = mech.dependent
    ok = np.zeros(k, dtype=bool)
    live = np.ones(k, dtype=bool)
    last = np.full(k, np.inf)
    its = np.zeros(k, dtype=int)
    for _ in range(CORRECTOR_ITER):
        a = np.flatnonzero(live)
        if a.size == 0:
            break
        kin = forward_kinematics(mech, mech.assemble(q_v[a], qw[a]))
        phi, J = closure_jacobian(mech, kin)
        nphi = np.linalg.norm(phi, axis=1)
        done = nphi < TOL_CORRECT
        ok[a[done]] = True
        live[a[done]] = False
        a, phi, J = a[~done], phi[~done], J[~done]
        if a.size == 0:
            break
        step, _ = _pinv_solve(J[:, :, iw], phi)
        ns = np.linalg.norm(step, axis=1)
        diverge = ~np.isfinite(ns) | (ns > 0.5 * last[a])
        live[a[diverge]] = False
        a, step, ns = a[~diverge], step[~diverge], ns[~diverge]
        qw[a] -= step
        last[a] = ns
        its[a] += 1
    dist = np.linalg.norm(qw - pred, axis=1)
    ok &= dist <= 0.5 * np.linalg.norm(moved, axis=1) + ABS_CORRECTION
    return ok, qw, its


def home_assembly(mech: Mechanism, q_w0: np.ndarray | None = None, **kw) -> ClosureResult:
    """The loops closed at the home independent joints (from ``q_w0``, default home): the
    known assembly continuation starts from. One row."""
    home = np.where(np.isfinite(mech.home), mech.home, 0.0)
    g = home[mech.dependent] if q_w0 is None else np.asarray(q_w0, np.float64).reshape(-1)
    return solve_closure(mech, home[mech.independent][None], g[None], **kw)


def closure_from_home(mech: Mechanism, q_v: np.ndarray, *, q_w0: np.ndarray | None = None,
                      **kw) -> ClosureResult:
    """Every row of q_v (m, n_v) reached from the home assembly by continuation (the assembly
    mode connected to home). When the loops do not close at home, each row is solved by
    Newton from the home guess instead (the old single solve: nothing better is known)."""
    q_v = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    h = home_assembly(mech, q_w0, **{k: v for k, v in kw.items() if k != "max_step"})
    if h.status[0] is not ClosureStatus.CONVERGED:
        g = np.broadcast_to(h.q[0, mech.dependent] if q_w0 is None else q_w0,
                            (len(q_v), len(mech.dependent)))
        pol = {k: v for k, v in kw.items() if k != "max_step"}
        return solve_closure(mech, q_v, np.array(g), **pol)
    return continue_closure(mech, q_v, h.q[0], **kw)


def within_limits(mech: Mechanism, q: np.ndarray, joints: np.ndarray | None = None,
                  tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Revolute ``joints`` (default the dependent ones) moved by whole turns into their limits
    where that is possible; returns (q (m, n) moved, inside (m,) bool: every one of those
    joints within [lower - tol, upper + tol])."""
    q = np.array(np.atleast_2d(q), dtype=np.float64)
    j = mech.dependent if joints is None else np.asarray(joints, dtype=int)
    if j.size == 0:
        return q, np.ones(q.shape[0], dtype=bool)
    lo, hi = mech.lower[j], mech.upper[j]
    x = q[:, j]
    rev = (mech.s[j] == 0) & np.isfinite(lo)
    with np.errstate(invalid="ignore"):
        k = np.ceil((lo - tol - x) / (2 * np.pi))
        moved = x + 2 * np.pi * k
        fits = rev & np.isfinite(x) & (moved <= hi + tol) & ((x < lo - tol) | (x > hi + tol))
    x = np.where(fits, moved, x)
    q[:, j] = x
    with np.errstate(invalid="ignore"):
        inside = np.all((x >= lo - tol) & (x <= hi + tol), axis=1)
    return q, inside


def with_limits(mech: Mechanism, res: ClosureResult, tol: float = 1e-9) -> ClosureResult:
    """Converged rows whose dependent (passive) joints are outside their limits get status
    ``outside limits`` (revolute joints first moved by whole turns into them where possible):
    a loop closure the mechanism cannot take is not an answer."""
    from dataclasses import replace

    q, inside = within_limits(mech, res.q, tol=tol)
    status = res.status.copy()
    conv = np.array([s is ClosureStatus.CONVERGED for s in status], dtype=bool)
    status[conv & ~inside] = ClosureStatus.OUTSIDE_LIMITS
    moved = not np.array_equal(q, res.q, equal_nan=True)
    return replace(res, q=q, status=status,
                   T_links=None if moved else res.T_links,
                   jacobian=None if moved else res.jacobian)


def fk_rows(mech: Mechanism, q_v: np.ndarray, *, q_w0: np.ndarray | None = None,
            **kw) -> tuple[ClosureResult, str]:
    """Forward kinematics of a batch of unrelated rows q_v (m, n_v) (the API's ``fk``).

    ``q_w0`` None or (n_w,): the assembly at the home q_v closed from it (default home), and
    every row reached from there by continuation. ``q_w0`` (m, n_w): a guess per row, solved by
    Newton from it; rows that do not close from their guess are reached from home by
    continuation. Then :func:`with_limits`. ``crossings`` of the result counts, per row, the
    constraint singularities (change points) its path from home crossed (0 for a row solved
    from its own guess; None when no path was followed). Returns the result and where the
    rows started (``"home"``, ``"guess"``). A mechanism whose only constraints are joint
    couplings has one assembly, in closed form
    (:class:`mechkin.model.couplings.CouplingMap`): no guess, no path.
    """
    q_v = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    m = q_v.shape[0]
    g = None if q_w0 is None else np.asarray(q_w0, dtype=np.float64)
    cm = coupling_map(mech)
    if cm is not None:  # couplings alone: one assembly, q = S q_v + c0 (no guess, no path)
        q = cm.full(q_v)
        Pw = coupling_jacobian(mech)[:, mech.dependent]
        res = ClosureResult(q, np.array([ClosureStatus.CONVERGED] * m, dtype=object),
                            np.zeros(m, dtype=int),
                            np.linalg.norm(coupling_residual(mech, q), axis=1),
                            np.broadcast_to(_cond(Pw[None]), (m,)).copy())
        return with_limits(mech, res), "home" if g is None else "guess"
    if g is not None and g.ndim == 2 and g.shape[0] == m and m > 1:
        pol = {k: v for k, v in kw.items() if k != "max_step"}
        res = solve_closure(mech, q_v, g, **pol)
        bad = np.flatnonzero(~res.ok)
        if bad.size:
            r2 = closure_from_home(mech, q_v[bad], **kw)
            q, st, it = res.q.copy(), res.status.copy(), res.iterations.copy()
            rs, cd = res.residual.copy(), res.cond.copy()
            q[bad], st[bad], it[bad], rs[bad], cd[bad] = (r2.q, r2.status, r2.iterations,
                                                          r2.residual, r2.cond)
            cr = np.zeros(m, dtype=int)
            if r2.crossings is not None:
                cr[bad] = r2.crossings
            res = ClosureResult(q, st, it, rs, cd, crossings=cr)
        return with_limits(mech, res), "guess"
    if g is not None:
        g = g.reshape(-1)
    return with_limits(mech, closure_from_home(mech, q_v, q_w0=g, **kw)), (
        "home" if g is None else "guess")


def _big_steps(mech: Mechanism, qv: np.ndarray, max_step: float) -> np.ndarray:
    """(m,) bool: row k moves an independent joint by more than 2 max_step from row k - 1."""
    unit = np.where(mech.s[mech.independent] == 1, _size(mech), 1.0)
    big = np.zeros(len(qv), dtype=bool)
    if len(qv) > 1:
        big[1:] = np.max(np.abs(np.diff(qv, axis=0)) / unit, axis=1, initial=0.0) > 2 * max_step
    return big


def _big_step(mech: Mechanism, q_v: np.ndarray, prev: np.ndarray, ckw: dict) -> ClosureResult:
    """One sample (1, n_v) from the assembled ``prev`` (n,): a single predictor-corrector step
    when its corrector passes the acceptance test of :func:`_correct` (converged, contracting,
    within half the predicted move), else :func:`continue_closure` with step control."""
    kin = forward_kinematics(mech, prev[None])
    _, J = closure_jacobian(mech, kin)
    move = _tangent(mech, J, q_v - prev[None, mech.independent])
    pred = prev[None, mech.dependent] + move
    ok, qw, _ = _correct(mech, q_v, pred, move)
    if ok[0]:
        pol = solve_closure(mech, q_v, qw, **{k: v for k, v in ckw.items() if k != "max_step"})
        if pol.ok[0]:
            return pol
    return continue_closure(mech, q_v, prev, **ckw)


def _on_branch(mech: Mechanism, q: np.ndarray, ok: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """(m,) bool on-branch and (m,) bool singular base.

    On-branch: sample k (solved by Newton from sample k - 1) passes the corrector's acceptance
    test of :func:`_correct` against the first-order predictor from k - 1 (the correction at
    most half the predicted move): a step-to-step solve that jumped to another assembly mode
    fails it. Row 0 and rows after a failed one pass. A sample whose predecessor is at a
    constraint singularity (:func:`_scaled_ratio` < :data:`RATIO_SINGULAR`: a change point
    where two modes cross, e.g. a parallelogram four-bar with all links in line) fails too:
    there the tangent is not determined and Newton from it may leave on either branch, so
    :func:`solve_motion` reaches it from the last regular sample instead (the predictor then
    steps across the crossing along the incoming tangent: the smooth continuation).
    Singular base: sample k is assembled and at such a constraint singularity."""
    m = q.shape[0]
    out = np.ones(m, dtype=bool)
    sing = np.zeros(m, dtype=bool)
    iv, iw = mech.independent, mech.dependent
    done = np.flatnonzero(ok)
    if done.size == 0:
        return out, sing
    with np.errstate(all="ignore"):
        _, J = closure_jacobian(mech, forward_kinematics(mech, q[done]))
        sing[done] = _scaled_ratio(mech, J[:, :, iw]) < RATIO_SINGULAR
    both = np.flatnonzero(ok[:-1] & ok[1:]) if m > 1 else np.zeros(0, dtype=int)
    if both.size == 0:
        return out, sing
    with np.errstate(all="ignore"):
        Jb = J[np.searchsorted(done, both)]  # dq_w/dq_v = -Phi_w^+ Phi_v at the bases
        S = -np.linalg.pinv(Jb[:, :, iw]) @ Jb[:, :, iv]
        move = np.einsum("kwv,kv->kw", S, q[both + 1][:, iv] - q[both][:, iv])
        corr = np.linalg.norm(q[both + 1][:, iw] - q[both][:, iw] - move, axis=1)
        out[both + 1] = ((corr <= 0.5 * np.linalg.norm(move, axis=1) + ABS_CORRECTION)
                         & ~sing[both])
    return out, sing


def _put(dst: dict, sl, r: ClosureResult) -> None:
    for k in ("q", "status", "iterations", "residual", "cond"):
        dst[k][sl] = getattr(r, k)


def solve_motion(mech: Mechanism, q_v: np.ndarray, *, q_w0: np.ndarray | None = None,
                 guess: bool = False, q_start: np.ndarray | None = None,
                 tol_phi: float = TOL_PHI, tol_dq: float = TOL_DQ, max_iter: int = MAX_ITER,
                 max_step: float = MAX_STEP) -> ClosureResult:
    """The loop closure along a motion q_v (m, n_v) in the assembly mode connected to its start.

    The first sample is reached by continuation from ``q_start`` (an assembled configuration,
    e.g. the previous chunk's last sample), else from the home assembly (closed from ``q_w0``,
    default home); with ``guess=True`` ``q_w0`` is a first guess at the first sample (Newton
    from it; from home if that fails). Then sample to sample as kim1995 §5.1 Steps 1-5
    (:func:`mechkin.model.closure.solve_trajectory`, Newton from the previous sample) over runs
    of small steps; a step that moves an independent joint by more than ``2 max_step``, and a
    sample whose Newton solve fails, are reached by continuation from the previous assembled
    sample, and the motion resumes from there. Passive limits are not applied here
    (:func:`with_limits`).
    """
    from mechkin.model.closure import solve_trajectory

    q_v = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    m = q_v.shape[0]
    iv, iw = mech.independent, mech.dependent
    kw = {"tol_phi": tol_phi, "tol_dq": tol_dq, "max_iter": max_iter}
    ckw = dict(kw, max_step=max_step)
    if m == 0 or len(iw) == 0 or mech.n_equations == 0:
        g = mech.home[iw] if q_w0 is None else q_w0
        return solve_trajectory(mech, q_v, g, **kw)
    out = {"q": np.empty((m, mech.n)), "status": np.empty(m, dtype=object),
           "iterations": np.zeros(m, dtype=int), "residual": np.zeros(m), "cond": np.ones(m)}
    home = np.where(np.isfinite(mech.home), mech.home, 0.0)
    g0 = home[iw] if q_w0 is None else np.asarray(q_w0, np.float64).reshape(-1)
    # the first sample
    first: ClosureResult | None = None
    if q_start is not None:
        q_start = np.asarray(q_start, np.float64).reshape(-1)
        if np.array_equal(q_start[iv], q_v[0]):
            first = solve_closure(mech, q_v[:1], q_start[iw][None], **kw)
        else:
            first = continue_closure(mech, q_v[:1], q_start, **ckw)
    elif guess:
        first = solve_closure(mech, q_v[:1], g0[None], **kw)
        if not first.ok[0]:
            first = closure_from_home(mech, q_v[:1], **ckw)
    elif np.array_equal(home[iv], q_v[0]):
        first = solve_closure(mech, q_v[:1], g0[None], **kw)
    else:
        first = closure_from_home(mech, q_v[:1], q_w0=g0, **ckw)
        # where Newton from the home guess lands on the same assembly, keep its digits (the
        # motion then matches kim1995's scheme from that guess bit for bit)
        newton = solve_closure(mech, q_v[:1], g0[None], **kw)
        if first.ok[0] and newton.ok[0] and np.abs(newton.q - first.q).max() < 1e-9:
            first = newton
    big = _big_steps(mech, q_v, max_step)
    window = m  # the whole motion step to step; after a miss, windows of WINDOW0 that double
    k = 0
    prev: np.ndarray | None = None  # the last assembled sample before k
    start_r = first
    while k < m:
        if start_r is None:  # reach sample k from the previous assembled one
            start_r = (_big_step(mech, q_v[k:k + 1], prev, ckw) if prev is not None
                       else closure_from_home(mech, q_v[k:k + 1], q_w0=g0, **ckw))
        if not start_r.ok[0]:
            # stuck (a fold) or lost: the following samples straight from the last assembled
            # one; the motion resumes at the first that closes
            _put(out, slice(k, k + 1), start_r)
            rest = q_v[k + 1:]
            if len(rest) == 0:
                break
            r = (continue_closure(mech, rest, prev, **ckw) if prev is not None
                 else closure_from_home(mech, rest, q_w0=g0, **ckw))
            okr = r.ok
            j = int(np.argmax(okr)) if okr.any() else len(rest)
            _put(out, slice(k + 1, k + 1 + j), ClosureResult(
                r.q[:j], r.status[:j], r.iterations[:j], r.residual[:j], r.cond[:j]))
            k = k + 1 + j
            if k < m:
                start_r = ClosureResult(r.q[j:j + 1], r.status[j:j + 1],
                                        r.iterations[j:j + 1], r.residual[j:j + 1],
                                        r.cond[j:j + 1])
            continue
        # a run of small steps from sample k, Newton step to step
        nxt = np.flatnonzero(big[k + 1:])
        stop = m if nxt.size == 0 else k + 1 + int(nxt[0])
        stop = min(stop, k + window)  # a window that doubles while the steps hold
        if stop - k > 1:
            r = solve_trajectory(mech, q_v[k:stop], start_r.q[0, iw], **kw)
            r = ClosureResult(np.vstack([start_r.q, r.q[1:]]),
                              np.concatenate([start_r.status, r.status[1:]]),
                              np.concatenate([start_r.iterations, r.iterations[1:]]),
                              np.concatenate([start_r.residual, r.residual[1:]]),
                              np.concatenate([start_r.cond, r.cond[1:]]))
        else:
            r = start_r
        on, sing = _on_branch(mech, r.q, r.ok)
        okr = r.ok & on
        j = int(np.argmin(okr)) if not okr.all() else len(okr)
        window = 2 * window if j == len(okr) else WINDOW0
        _put(out, slice(k, k + j), ClosureResult(r.q[:j], r.status[:j], r.iterations[:j],
                                                 r.residual[:j], r.cond[:j]))
        # the next sample is reached from the last regular one: never from a change point
        regular = np.flatnonzero(~sing[:j])
        if regular.size:
            prev = out["q"][k + int(regular[-1])].copy()
        elif prev is None:
            prev = out["q"][k + j - 1].copy()
        k += j
        start_r = None
    return ClosureResult(out["q"], out["status"], out["iterations"], out["residual"],
                         out["cond"])

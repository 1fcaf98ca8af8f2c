r"""Forward kinematics of complex chains: dependent joints from independent ones (kim1995 §5.1).

Newton-Raphson with a pseudo-inverse on the loop-closure equations phi_R(q_v, q_w) = 0
(kim1995 Eq. (4)); the pseudo-inverse (SVD) copes with redundant equations, e.g. the planar loop
of the direct-drive arm gives 6 equations of rank 3.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from mechkin.model.kinematics import Kinematics, closure_jacobian, forward_kinematics
from mechkin.model.mechanism import Mechanism

TOL_PHI = 1e-12
TOL_DQ = 1e-12
MAX_ITER = 50
COND_SINGULAR = 1e10


class ClosureStatus(enum.Enum):
    CONVERGED = "converged"
    NOT_CONVERGED = "not converged"
    SINGULAR = "singular"
    #: a continuation path stopped where d(phi)/d(q_w) loses rank (mechkin.model.continuation)
    CONSTRAINT_SINGULAR = "constraint singularity"
    #: the loops close but a dependent (passive) joint is outside its limits
    OUTSIDE_LIMITS = "outside limits"


@dataclass(frozen=True)
class ClosureResult:
    """Batch result: one row per configuration.

    q (m, n) all joints; status (m,) of ClosureStatus; iterations (m,); residual (m,) ||phi||_2
    at exit [m and rad mixed]; cond (m,) condition number sigma_1 / sigma_{n_w} of
    d(phi)/d(q_w) at exit (at the solution when converged; unscaled: position rows in m,
    Euler-parameter rows dimensionless; inf when the columns lose rank; 1 when the mechanism
    has no dependent joints). A large cond means the closed chain is near a constraint
    singularity, see :mod:`mechkin.model.singularity`.
    """

    q: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    cond: np.ndarray
    #: ``keep_kinematics=True``: the link poses (m, nl, 4, 4) and d(phi)/dq (m, n_eq, n) of
    #: the last Newton iterate of each converged row, evaluated at exactly ``q`` (None when
    #: some row did not converge or was moved by whole turns; then recompute them).
    T_links: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    #: reached by continuation (:mod:`mechkin.model.continuation`): per row, the constraint
    #: singularities (change points) its path crossed (None: no path was followed)
    crossings: np.ndarray | None = None

    @property
    def ok(self) -> np.ndarray:
        return np.array([s is ClosureStatus.CONVERGED for s in self.status])


def _pinv_solve(J: np.ndarray, r: np.ndarray, rcond: float = 1e-12):
    """Least-squares step J^+ r for stacks J (m, k, n), r (m, k) with k >= n; and cond (m,).

    kim1995 §5.1 writes the pseudo-inverse as (J^T J)^-1 J^T; a square J is solved directly,
    a tall one through its normal equations, and only a rank-deficient stack pays for an SVD
    (minimum-norm step, singular values below rcond * s_max dropped).
    """
    k, n = J.shape[1], J.shape[2]
    if k >= n:
        try:
            if k == n:
                step = np.linalg.solve(J, r[..., None])[..., 0]
            else:
                Jt = np.swapaxes(J, 1, 2)
                step = np.linalg.solve(Jt @ J, (Jt @ r[..., None]))[..., 0]
            if np.all(np.isfinite(step)):
                return step, None
        except np.linalg.LinAlgError:
            pass
    return _svd_solve(J, r, rcond)


def _svd_solve(J: np.ndarray, r: np.ndarray, rcond: float = 1e-12):
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    smax = S[:, :1]
    keep = rcond * np.maximum(smax, 1e-300) < S
    Sinv = np.where(keep, 1.0 / np.where(keep, S, 1.0), 0.0)
    step = np.einsum("mji,mj->mi", Vt, Sinv * np.einsum("mkj,mk->mj", U, r))
    return step, _cond_from_s(S, J.shape[2])


def _cond_from_s(S: np.ndarray, n: int) -> np.ndarray:
    smin = S[:, n - 1] if n <= S.shape[1] else np.zeros(S.shape[0])
    return np.where(smin > 0, S[:, 0] / np.maximum(smin, 1e-300), np.inf)


def _cond(J: np.ndarray) -> np.ndarray:
    """Condition number of the columns of J (m, k, n)."""
    if J.shape[0] == 0:
        return np.zeros(0)
    return _cond_from_s(np.linalg.svd(J, compute_uv=False), J.shape[2])


def solve_closure(
    mech: Mechanism,
    q_v: np.ndarray,
    q_w0: np.ndarray,
    *,
    tol_phi: float = TOL_PHI,
    tol_dq: float = TOL_DQ,
    max_iter: int = MAX_ITER,
    keep_kinematics: bool = False,
) -> ClosureResult:
    r"""Solve the dependent joints of a batch of configurations by Newton-Raphson.

    .. math:: q_w^{k+1} = q_w^k
              - \left[\frac{\partial\phi_R}{\partial q_w}\right]^+ \phi_R(q_v, q_w^k)

    Converged when ``||phi|| < tol_phi`` and ``||dq_w|| < tol_dq`` (kim1995 §5.1 Step 3; a step
    whose residual is already at round-off counts as converged). Singular when the dependent
    Jacobian loses column rank (cond > 1e10) at exit without convergence.

    Parameters
    ----------
    q_v : array, shape (m, n_v)
    q_w0 : array, shape (m, n_w)
        Initial guesses (the previous step's solution on a trajectory).
    keep_kinematics : bool
        Also return the link poses and the closure Jacobian of the converged iterates
        (``ClosureResult.T_links``, ``.jacobian``): the forward kinematics the caller would
        otherwise redo at the solution (the IK evaluation does; the same numbers, since they
        are computed at the same q by the same code).

    References
    ----------
    kim1995_complex_chain_ik §5.1, Steps 2-3.
    """
    q_v = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    q_w = np.array(np.broadcast_to(np.atleast_2d(q_w0), (q_v.shape[0], len(mech.dependent))),
                   dtype=np.float64)
    q_w_init = q_w.copy()
    m = q_v.shape[0]
    iters = np.zeros(m, dtype=int)
    done = np.zeros(m, dtype=bool)
    res = np.full(m, np.inf)
    cond = np.ones(m)
    if not mech.is_closed or len(mech.dependent) == 0:
        q = mech.assemble(q_v, q_w)
        kin = forward_kinematics(mech, q)
        from mechkin.model.kinematics import closure_residual

        r = np.linalg.norm(closure_residual(mech, kin), axis=1)
        st = np.array([ClosureStatus.CONVERGED if x < max(tol_phi, 1e-9) else
                       ClosureStatus.NOT_CONVERGED for x in r], dtype=object)
        return ClosureResult(q, st, iters, r, cond)
    dep = mech.dependent
    prev_res = np.full(m, np.inf)
    prev_step = np.zeros_like(q_w)
    shrink = np.ones(m)
    keep_T = np.empty((m, mech.n_links, 4, 4)) if keep_kinematics else None
    keep_J = np.empty((m, mech.n_equations, mech.n)) if keep_kinematics else None
    for _ in range(max_iter + 1):
        act = np.flatnonzero(~done)
        if act.size == 0:
            break
        q = mech.assemble(q_v[act], q_w[act])
        kin = forward_kinematics(mech, q)
        phi, J = closure_jacobian(mech, kin)
        nphi = np.linalg.norm(phi, axis=1)
        # backtracking: a step that raised ||phi|| is retried at half length (kim1995 takes
        # full steps; this only acts far from a solution, where plain Newton can cycle)
        worse = (nphi > prev_res[act] * (1.0 + 1e-9)) & (shrink[act] > 1e-3) & (nphi > 1e-13)
        if worse.any():
            wi = act[worse]
            q_w[wi] += prev_step[wi]
            shrink[wi] *= 0.5
            prev_step[wi] *= 0.5
            q_w[wi] -= prev_step[wi]
            iters[wi] += 1
            keep = ~worse
            act, phi, J, nphi = act[keep], phi[keep], J[keep], nphi[keep]
            if keep_T is not None:
                kin = Kinematics(q=kin.q[keep], T_links=kin.T_links[keep], mech=mech)
            if act.size == 0:
                if (iters[~done] >= max_iter).all():
                    break
                continue
        res[act] = nphi
        Jw = J[:, :, dep]
        step, _ = _pinv_solve(Jw, phi)
        ndq = np.linalg.norm(step, axis=1)
        conv = (nphi < tol_phi) & ((ndq < tol_dq) | (nphi < 1e-14))
        if conv.any():
            # the Jacobian of the converged iterate: cond at the solution (one small SVD)
            cond[act[conv]] = _cond(Jw[conv])
        done[act[conv]] = True
        if keep_T is not None and conv.any():
            keep_T[act[conv]] = kin.T_links[conv]
            keep_J[act[conv]] = J[conv]
        upd = act[~conv]
        upd = upd[iters[upd] < max_iter]
        if upd.size == 0:
            if (iters[~done] >= max_iter).all():
                break
            continue
        st = step[~conv][iters[act[~conv]] < max_iter]
        # a trust region of 0.5 (rad or m) per step keeps far starts from jumping branches
        nst = np.linalg.norm(st, axis=1, keepdims=True)
        st = st * np.minimum(1.0, 0.5 / np.maximum(nst, 1e-300))
        prev_res[upd] = res[upd]
        shrink[upd] = 1.0
        prev_step[upd] = st
        q_w[upd] -= st
        iters[upd] += 1
    bad = np.flatnonzero(~done)
    if bad.size:
        _, Jb = closure_jacobian(mech, forward_kinematics(mech, mech.assemble(q_v[bad], q_w[bad])))
        cond[bad] = _cond(Jb[:, :, dep])
    # revolute dependents: the branch nearest the initial guess (Newton may wander by 2 pi)
    rev = mech.s[dep] == 0
    turns = np.round((q_w[:, rev] - q_w_init[:, rev]) / (2.0 * np.pi))
    q_w[:, rev] -= 2.0 * np.pi * turns
    if keep_T is not None and (bad.size or np.any(turns != 0)):
        keep_T = keep_J = None  # not all at the returned q: the caller recomputes
    status = np.empty(m, dtype=object)
    for k in range(m):
        if done[k]:
            status[k] = ClosureStatus.CONVERGED
        elif cond[k] > COND_SINGULAR:
            status[k] = ClosureStatus.SINGULAR
        else:
            status[k] = ClosureStatus.NOT_CONVERGED
    return ClosureResult(mech.assemble(q_v, q_w), status, iters, res, cond, keep_T, keep_J)


def dependent_sensitivity(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """dq_w/dq_v = -(dphi/dq_w)^+ dphi/dq_v at configurations q (m, n): (m, n_w, n_v)."""
    _, J = closure_jacobian(mech, forward_kinematics(mech, q))
    Jw, Jv = J[:, :, mech.dependent], J[:, :, mech.independent]
    return -np.linalg.pinv(Jw) @ Jv


def solve_trajectory(
    mech: Mechanism,
    q_v_traj: np.ndarray,
    q_w0: np.ndarray,
    *,
    tol_phi: float = TOL_PHI,
    tol_dq: float = TOL_DQ,
    max_iter: int = MAX_ITER,
    chunk: int = 32,
) -> ClosureResult:
    """Continuation along a trajectory (kim1995 §5.1 Steps 1-5).

    ``chunk = 1`` is the paper's scheme: each step starts from the previous step's solution.
    With ``chunk = K > 1`` (default) the next K steps are solved together in one batched Newton
    run, each started from a first-order predictor off the last converged step,
    ``q_w + (dq_w/dq_v) (q_v - q_v_last)``; any step of the chunk that does not converge is then
    solved alone from its predecessor, so the result equals the sequential one.

    q_v_traj (m, n_v); q_w0 (n_w,) the initial approximation at t0.
    """
    q_v_traj = np.atleast_2d(np.asarray(q_v_traj, dtype=np.float64))
    m = q_v_traj.shape[0]
    qs = np.empty((m, mech.n))
    status = np.empty(m, dtype=object)
    iters = np.zeros(m, dtype=int)
    res = np.zeros(m)
    cond = np.zeros(m)
    kw = {"tol_phi": tol_phi, "tol_dq": tol_dq, "max_iter": max_iter}
    guess = np.asarray(q_w0, dtype=np.float64).reshape(1, -1)
    first = solve_closure(mech, q_v_traj[:1], guess, **kw)
    qs[0], status[0], iters[0], res[0], cond[0] = (first.q[0], first.status[0],
                                                   first.iterations[0], first.residual[0],
                                                   first.cond[0])
    last_q = first.q[0] if first.status[0] is ClosureStatus.CONVERGED else None
    k = 1
    while k < m:
        if chunk <= 1 or last_q is None or not mech.is_closed:
            g = guess if last_q is None else last_q[mech.dependent][None]
            r = solve_closure(mech, q_v_traj[k : k + 1], g, **kw)
            sl = slice(k, k + 1)
        else:
            sl = slice(k, min(m, k + chunk))
            S = dependent_sensitivity(mech, last_q[None])[0]
            g = last_q[mech.dependent] + (q_v_traj[sl] - last_q[mech.independent]) @ S.T
            r = solve_closure(mech, q_v_traj[sl], g, **kw)
            ok = np.array([x is ClosureStatus.CONVERGED for x in r.status])
            if not ok.all():
                # keep the converged prefix, redo the rest one by one from its predecessor
                n_ok = int(np.argmin(ok)) if not ok.all() else len(ok)
                sl = slice(k, k + max(n_ok, 0))
                r = ClosureResult(r.q[:n_ok], r.status[:n_ok], r.iterations[:n_ok],
                                  r.residual[:n_ok], r.cond[:n_ok])
                if n_ok == 0:
                    r = solve_closure(mech, q_v_traj[k : k + 1], last_q[mech.dependent][None],
                                      **kw)
                    sl = slice(k, k + 1)
        qs[sl], status[sl], iters[sl], res[sl], cond[sl] = (r.q, r.status, r.iterations,
                                                            r.residual, r.cond)
        conv = [i for i, x in enumerate(r.status) if x is ClosureStatus.CONVERGED]
        if conv:
            last_q = r.q[conv[-1]]
        k = sl.stop
    return ClosureResult(qs, status, iters, res, cond)

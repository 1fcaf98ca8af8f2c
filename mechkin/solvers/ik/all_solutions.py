r"""Every distinct inverse-kinematics solution of one precision point.

A 6R arm such as the PUMA 560 has up to eight solutions of a generic pose (shoulder left /
right, elbow up / down, wrist flip); the kim1995 direct-drive arm two (elbow up / down; its
q1 is fixed by the orientation); a Stewart platform one (the leg lengths). Two ways:

* closed form (:func:`mechkin.solvers.closed_form.all_solutions.closed_form_all`, in the
  closed-form room, which builds on this module): every branch of a recognised closed form,
  each closed by the loop closure and verified the same way;
* numerical (:func:`multistart_all`): Levenberg-Marquardt
  (:func:`mechkin.solvers.ik.solve_ik_batch`, no restarts) from many seeded starts at once:
  the nearest poses of the seeded codebook (open chains), then seeded random independent joints
  uniform within the limits; the verified results are clustered.

Both keep a solution only when forward kinematics at the returned joints puts {E} within
``tol_pos`` [m] and ``tol_ori`` [rad] of the target (components with non-zero weight; defaults
0.1 mm and 1 mrad), the loops closed, and every joint within its limits (the passive ones
too: a five-bar whose elbow limits keep one working mode has one solution). Two
solutions are one when their independent joints differ by less than ``same_tol`` (max-abs;
revolute joints modulo 2 pi); each is represented by its member nearest the guess (revolute
joints at the turn nearest the guess within the limits). The result is ordered by the joint
distance from the guess (revolute modulo 2 pi), then lexicographically by q_v.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`; may import the family and
:mod:`mechkin.model`; never :mod:`mechkin.solvers.closed_form` (which imports ik), ``io/``,
``cli/``, ``tasks/`` or ``config/``.

References
----------
kim1995_complex_chain_ik §5.2 and appendix 1 (direct drive), §6.2 (Stewart); Paul & Zhang
1986 (the eight PUMA 560 configurations).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual
from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.kernel import kernel_for
from mechkin.solvers.ik.results import IkOptions, pose_and_weighted_errors
from mechkin.solvers.ik.seeds import seed_starts

SOLUTION_STARTS = 256  # multi-start LM starts per target
CODEBOOK_STARTS = 32  # of which the nearest codebook poses (open chains)
TOL_POS_ALL = 1e-4  # [m] verification of every solution
TOL_ORI_ALL = 1e-3  # [rad]
SAME_TOL = 1e-3  # [rad | m] max-abs joint difference under which two solutions are one


@dataclass(frozen=True)
class IkSolutions:
    """Every distinct verified solution of one target.

    q : (k, n) all joints; q_v : (k, n_v) independent joints; position_error,
    orientation_error : (k,) [m], [rad] by forward kinematics; distance : (k,) joint distance
    of q_v from the guess (revolute modulo 2 pi); source : "analytic", "closed-form" or
    "multi-start"; starts : candidates tried; time_s : wall time; complete : the list is
    every solution within the limits (analytic and closed-form enumeration of all branches);
    False for multi-start, which finds what its starts reach.
    """

    q: np.ndarray
    q_v: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    distance: np.ndarray
    source: str
    starts: int
    time_s: float
    complete: bool = False

    @property
    def count(self) -> int:
        return int(self.q.shape[0])


def wrapped(mech: Mechanism, joints: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Joint differences d (..., k) of joints (k,), revolute ones wrapped into [-pi, pi)."""
    rev = mech.s[joints] == 0
    return np.where(rev, (d + np.pi) % (2 * np.pi) - np.pi, d)


def _near_guess(mech: Mechanism, iv: np.ndarray, qv: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Revolute joints of qv (k, n_v) at the turn nearest ref (n_v,) where that stays within
    the limits (else at the nearest turn within the limits, else as given)."""
    lo, hi = mech.lower[iv] - 1e-12, mech.upper[iv] + 1e-12
    rev = mech.s[iv] == 0
    base = ref[None] + wrapped(mech, iv, qv - ref[None])
    out = qv.copy()
    done = ~np.broadcast_to(rev, qv.shape)
    for shift in (0.0, 2 * np.pi, -2 * np.pi):
        cand = base + shift
        take = ~done & (cand >= lo) & (cand <= hi)
        out = np.where(take, cand, out)
        done = done | take
    return out


def _within_limits(mech: Mechanism, iv: np.ndarray, qv: np.ndarray) -> np.ndarray:
    tol = 1e-9
    return np.all((qv >= mech.lower[iv] - tol) & (qv <= mech.upper[iv] + tol), axis=1)


def _finish(mech: Mechanism, q: np.ndarray, T_P: np.ndarray, w: np.ndarray, ref: np.ndarray,
            tol_pos: float, tol_ori: float, same_tol: float, source: str, starts: int,
            t0: float) -> IkSolutions:
    """Verify candidates q (k, n), cluster, order (the module docstring's rules)."""
    iv = mech.independent
    kern = kernel_for(mech)
    n = mech.n
    q = np.asarray(q, dtype=np.float64).reshape(-1, n)
    q = q[np.all(np.isfinite(q), axis=1)]
    if len(q):
        q[:, iv] = _near_guess(mech, iv, q[:, iv], ref)
        iw = mech.dependent
        if kern.coupling is not None:  # coupled joints follow their masters (exactly)
            q = kern.coupling.full(q[:, iv])
        elif iw.size:
            q[:, iw] = _near_guess(mech, iw, q[:, iw], np.where(np.isfinite(mech.home[iw]),
                                                                 mech.home[iw], 0.0))
        T_E = kern.pose_check(q)
        k = len(q)
        pe, oe, wpe, woe = pose_and_weighted_errors(T_E, np.broadcast_to(T_P, (k, 4, 4)),
                                                    np.broadcast_to(w, (k, 6)))
        closed = np.ones(k, dtype=bool)
        if mech.is_closed:
            from mechkin.model.kinematics import forward_kinematics

            phi = closure_residual(mech, forward_kinematics(mech, q))
            closed = np.linalg.norm(phi, axis=1) < 1e-8
        ok = (wpe <= tol_pos) & (woe <= tol_ori) & closed & _within_limits(mech, iv, q[:, iv])
        ok &= _within_limits(mech, mech.dependent, q[:, mech.dependent])
        q, pe, oe = q[ok], pe[ok], oe[ok]
    else:
        pe = oe = np.zeros(0)
    dist = np.linalg.norm(wrapped(mech, iv, q[:, iv] - ref[None]), axis=1)
    order = np.lexsort(tuple(np.round(q[:, iv], 9).T[::-1]) + (np.round(dist, 9),))
    q, pe, oe, dist = q[order], pe[order], oe[order], dist[order]
    idx = first_of_clusters(mech, iv, q[:, iv], same_tol)
    return IkSolutions(q=q[idx], q_v=q[idx][:, iv], position_error=pe[idx],
                       orientation_error=oe[idx], distance=dist[idx], source=source,
                       starts=starts, time_s=time.perf_counter() - t0,
                       complete=source == "closed-form")


def first_of_clusters(mech: Mechanism, iv: np.ndarray, qv: np.ndarray, same_tol: float
                      ) -> np.ndarray:
    """Rows of qv (k, n_v) kept by the greedy rule: a row is kept unless it lies within
    same_tol (max-abs, revolute joints modulo 2 pi) of an earlier kept row. Vectorised: one
    array pass per kept row (every row close to it is dropped at once), not one Python step
    per pair; the first remaining row is always kept, so this is the greedy rule exactly."""
    alive = np.ones(len(qv), dtype=bool)
    keep = []
    while alive.any():
        i = int(np.argmax(alive))
        keep.append(i)
        alive &= np.abs(wrapped(mech, iv, qv - qv[i])).max(axis=-1) >= same_tol
    return np.array(keep, dtype=int)


def assembled_starts(mech: Mechanism, k: int, qw0: np.ndarray, rng: np.random.Generator
                     ) -> tuple[np.ndarray, np.ndarray]:
    """k starts (q_v (k, n_v), q_w (k, n_w)) of a closed chain that close the loops: random
    q_v within the limits with random q_w (uniform, or normal about ``qw0``), the loop closure
    solved in one batch (kim1995 §5.1), the converged ones kept (rows that never close keep
    q_w0: lm then reports them unassembled)."""
    from mechkin.solvers.assembly import characteristic_length

    iv, iw = mech.independent, mech.dependent
    L = characteristic_length(mech)
    prism_v, prism_w = mech.s[iv] == 1, mech.s[iw] == 1
    home_v = np.where(np.isfinite(mech.home[iv]), mech.home[iv], 0.0)
    lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], np.where(prism_v, home_v - L,
                                                                           -np.pi))
    hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], np.where(prism_v, home_v + L,
                                                                           np.pi))
    m = 4 * k
    qv = rng.uniform(lo, hi, size=(m, iv.size))
    qw = np.where(rng.random((m, 1)) < 0.5,
                  rng.uniform(-np.pi, np.pi, size=(m, iw.size)),
                  qw0 + rng.normal(size=(m, iw.size)) * 0.5)
    qw = np.where(prism_w, qw0 + rng.normal(size=(m, iw.size)) * 0.1 * L, qw)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = solve_closure(mech, qv, qw, max_iter=30)
    ok = np.flatnonzero(res.ok & np.all(np.isfinite(res.q), axis=1))
    out_v = rng.uniform(lo, hi, size=(k, iv.size))
    out_w = np.array(np.broadcast_to(qw0, (k, iw.size)))
    take = ok[:k]
    out_v[:take.size] = res.q[take][:, iv]
    out_w[:take.size] = res.q[take][:, iw]
    return out_v, out_w


def multistart_all(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray | None = None,
                   q_w0: np.ndarray | None = None, weights: np.ndarray | None = None,
                   options: IkOptions | None = None, starts: int = SOLUTION_STARTS,
                   seed: int = 0, extra: np.ndarray | None = None,
                   tol_pos: float = TOL_POS_ALL, tol_ori: float = TOL_ORI_ALL,
                   same_tol: float = SAME_TOL) -> IkSolutions:
    r"""Every solution of T_P (4, 4) found by multi-start Levenberg-Marquardt.

    .. math:: \{q_v^* : f(q_v^*) = \tfrac12 x^T W x \approx 0\}\ \text{from}\ q_v^{(0)} \in
              \{q_{v0}\} \cup \text{codebook} \cup \mathcal U(\text{limits})

    Parameters
    ----------
    q_v0 : array, shape (n_v,), optional
        The guess: the first start and the reference of the order (default home).
    q_w0 : array, shape (n_w,), optional
        Initial dependent joints of every start (default home).
    options : IkOptions, optional
        Tolerances of each LM solve (``restarts`` is ignored: every start is one solve).
    starts : int
        Starts in total (the guess, ``CODEBOOK_STARTS`` nearest codebook poses for open chains,
        then seeded random joints within the limits).
    extra : array, shape (k, n), optional
        Further candidates (e.g. the primary solution of the task).

    Returns
    -------
    IkSolutions
    """
    from dataclasses import replace

    from mechkin.solvers.ik.solve import solve_ik_batch

    t0 = time.perf_counter()
    kern = kernel_for(mech)
    iv, iw = mech.independent, mech.dependent
    T_P = np.asarray(T_P, dtype=np.float64).reshape(4, 4)
    w = np.ones(6) if weights is None else np.asarray(weights, float)
    ref = mech.home[iv].copy() if q_v0 is None else np.asarray(q_v0, float)
    qw0 = mech.home[iw] if q_w0 is None else np.asarray(q_w0, float)
    k = max(int(starts), 1)
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
    hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
    Q0 = rng.uniform(lo, hi, size=(k, iv.size))
    Q0[0] = ref
    nc = min(CODEBOOK_STARTS, k - 1)
    if nc > 0:
        seeded = seed_starts(kern, T_P[None], w[None], ranks=range(nc))
        if seeded is not None:
            Q0[1:1 + nc] = seeded[0]
    QW = np.array(np.broadcast_to(qw0, (k, iw.size)))
    if kern.n_cuts and kern.coupling is None and k > 1:  # (couplings alone: any q_v assembles)
        Q0[1:], QW[1:] = assembled_starts(mech, k - 1, qw0, rng)
    opts = replace(options or IkOptions(), method="lm", restarts=0)
    br = solve_ik_batch(mech, np.broadcast_to(T_P, (k, 4, 4)), q_v0=Q0, q_w0=QW,
                        weights=np.broadcast_to(w, (k, 6)), options=opts)
    q = br.q[br.ok]  # reached within the solve's own tolerances (default 1e-6 m, 1e-6 rad)
    if extra is not None:
        q = np.vstack([np.asarray(extra, float).reshape(-1, mech.n), q])
    return _finish(mech, q, T_P, w, ref, tol_pos, tol_ori, same_tol, "multi-start", len(q),
                   t0)

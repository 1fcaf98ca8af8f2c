r"""Compiled lm of a coupled open chain in its reduced coordinates (optional, needs ``numba``).

The open-chain lm of :mod:`mechkin.solvers.ik.serial_jit` on the serial path to {E} when some
of the path's joints are coupled (URDF ``<mimic>``; :mod:`mechkin.model.couplings`): the
unknowns are the r independent joints that drive the path, ``u`` (r,); the path's joint i is

.. math:: q_i = M_i\,u_{c(i)} + C_i,\qquad
          J_u[:, b] = \sum_{i:\,c(i) = b} M_i\,J[:, i]

(the column of a coupled joint added into its master's, times M), so a step never leaves the
coupling manifold and no constraint rows or loop closure are needed. Everything else (the
residual in {P}, Marquardt step, projection onto the bounds of u, which already hold the
coupled joints' limits, acceptance and stopping rules, ``stop_first`` and ``stall``) is the
loop of :func:`mechkin.solvers.ik.serial_jit.lm`, with its helpers.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports numpy, numba and
:mod:`mechkin.solvers.ik.serial_jit` (shared loop kernels); never ``io/``, ``cli/`` or
``tasks/``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

from mechkin.solvers.ik.accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR (a read-only install: user cache)

import numba  # noqa: E402
import numpy as np  # noqa: E402

from mechkin.solvers.ik.serial_jit import (  # noqa: E402
    _CPUS,
    PARALLEL_ROWS,
    evaluate,
    half_wsq,
    lm_decide,
    lm_step,
    project,
)

_njit = numba.njit(cache=True, nogil=True)


@_njit
def evaluate_reduced(u, F0, Pc, Ps, Pd, P0, rev, jcol, jmul, joff, qc, F, x, Jc, J):
    """x (6,) and J (6, r) = J_chain M of the reduced joints u (r,); qc (k,), F (k+1, 4, 4),
    Jc (6, k) workspace."""
    k = qc.size
    for i in range(k):
        qc[i] = jmul[i] * u[jcol[i]] + joff[i]
    evaluate(qc, F0, Pc, Ps, Pd, P0, rev, F, x, Jc)
    for a in range(6):
        for b in range(u.size):
            J[a, b] = 0.0
        for i in range(k):
            J[a, jcol[i]] += jmul[i] * Jc[a, i]


@_njit
def lm_coupled(u0, F0, w, Pc, Ps, Pd, P0, rev, jcol, jmul, joff, lo, hi, cont, lower, upper,
               f_abs, grad_tol, max_iter, stall, mu, stop_first, u, f, iters, done, gnorm, hist):
    """Rows (starts u0 (m, r)) one after another, as :func:`serial_jit.lm`; with
    ``stop_first`` the rows after the first that converges are not run (E inf, 0 iterations)."""
    m, r = u0.shape
    k = jcol.size
    F = np.empty((k + 1, 4, 4))
    qc = np.empty(k)
    Jc = np.empty((6, k))
    x = np.empty(6)
    J = np.empty((6, r))
    xn = np.empty(6)
    Jn = np.empty((6, r))
    g = np.empty(r)
    H = np.empty((r, r))
    A = np.empty((r, r))
    step = np.empty(r)
    un = np.empty(r)
    blk = np.zeros(r, dtype=np.bool_)
    keep_hist = hist.shape[0] > 0
    for row in range(m):
        ur = u[row]
        for a in range(r):
            ur[a] = u0[row, a]
        project(ur, lo, hi, cont, lower, upper)
        evaluate_reduced(ur, F0[row], Pc, Ps, Pd, P0, rev, jcol, jmul, joff, qc, F, x, Jc, J)
        fr = half_wsq(w[row], x)
        if keep_hist:
            hist[row, 0] = fr
        lam = 1e-2
        fref = fr
        fin = fr < f_abs
        it = 0
        gn = 0.0
        while not fin and it < max_iter:
            gn = lm_step(J, x, w[row], ur, lo, hi, lam, mu, g, H, A, step, blk)
            if gn < grad_tol:
                fin = True
                break
            for a in range(r):
                un[a] = ur[a] - step[a]
            project(un, lo, hi, cont, lower, upper)
            evaluate_reduced(un, F0[row], Pc, Ps, Pd, P0, rev, jcol, jmul, joff, qc, F, xn, Jc,
                             Jn)
            fn = half_wsq(w[row], xn)
            it += 1
            accept, lam, fin = lm_decide(fr, fn, True, lam, step, f_abs)
            if accept:
                for a in range(r):
                    ur[a] = un[a]
                    for i in range(6):
                        J[i, a] = Jn[i, a]
                for i in range(6):
                    x[i] = xn[i]
                fr = fn
            if keep_hist:
                hist[row, it] = fr
            if stall > 0 and it % stall == 0:
                if fr > 0.5 * fref:
                    fin = True
                fref = fr
        f[row] = fr
        iters[row] = it
        done[row] = fin
        gnorm[row] = gn
        if stop_first and fr < f_abs:
            for rr in range(row + 1, m):
                for a in range(r):
                    u[rr, a] = u0[rr, a]
                project(u[rr], lo, hi, cont, lower, upper)
                f[rr] = np.inf
                iters[rr] = 0
                done[rr] = False
                gnorm[rr] = 0.0
            break


def lm_coupled_rows(u0: np.ndarray, F0: np.ndarray, w: np.ndarray, chain, reduced, lo, hi,
                    cont, lower, upper, *, f_abs: float, max_iter: int, stall: int, mu: float,
                    history: bool, stop_first: bool = False, grad_tol: float = 0.0):
    """Run :func:`lm_coupled` on every row; returns u (m, r), f, iters, done, gnorm, hist.

    ``chain``: the :class:`mechkin.model.serial.SerialChain` to {E}; ``reduced``: its
    ``(jcol, jmul, joff)`` (:attr:`mechkin.solvers.ik.kernel.IkKernel.coupled_chain`); lo, hi,
    cont, lower, upper (r,): bounds, continuous flags and limits of u."""
    m, r = u0.shape
    u = np.empty((m, r))
    f = np.empty(m)
    iters = np.zeros(m, dtype=np.int64)
    done = np.zeros(m, dtype=np.bool_)
    gnorm = np.zeros(m)
    hist = np.full((m, max_iter + 1) if history else (0, 0), np.nan)
    cc = chain.__dict__.get("_jit_consts")
    if cc is None:
        cc = chain.__dict__["_jit_consts"] = (
            chain.Pc[:, 0].copy(), chain.Ps[:, 0].copy(), chain.Pd[:, 0].copy(),
            chain.P0[:, 0].copy(), chain.rev.copy())
    args = (np.ascontiguousarray(u0, dtype=np.float64), np.ascontiguousarray(F0),
            np.ascontiguousarray(w, dtype=np.float64))
    consts = (*cc, *reduced, *(np.ascontiguousarray(a) for a in (lo, hi, cont, lower, upper)),
              float(f_abs), float(grad_tol), int(max_iter), int(stall), float(mu),
              bool(stop_first))
    outs = (u, f, iters, done, gnorm, hist)

    def run(sl: slice) -> None:
        lm_coupled(*(a[sl] for a in args), *consts, *(o[sl] if o.shape[0] else o for o in outs))

    # as serial_jit.lm_serial: row blocks on threads (the kernel releases the GIL)
    workers = 1 if stop_first else min(_CPUS, m // PARALLEL_ROWS)
    if workers <= 1:
        run(slice(None))
    else:
        bounds = np.linspace(0, m, workers + 1).astype(int)
        with ThreadPoolExecutor(workers) as ex:
            list(ex.map(run, [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:],
                                                             strict=True)]))
    return u, f, iters, done, gnorm, hist

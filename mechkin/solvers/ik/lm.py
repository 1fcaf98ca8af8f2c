r"""Levenberg-Marquardt on the reduced Jacobian, batched across targets (the default method).

Damped Gauss-Newton on ``J_r = dx/dq_v`` of kim1995's residual (Eq. (8), (10)) for m targets
at once, vectorized across targets (numpy on :mod:`mechkin.model`), or by the optional compiled
kernels (:mod:`mechkin.solvers.ik.serial_jit` for open chains, :mod:`mechkin.solvers.ik.tree_jit`
for closed ones) when :func:`mechkin.solvers.ik.accel.use_compiled` says so (numba available,
and the job big enough to repay loading the kernels, or the kernels already loaded). Joint
limits of q_v are kept by projection; on closed chains the passive joints' limits by an
active-set step (:func:`passive_limited_steps`).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel`, :mod:`mechkin.solvers.ik.results`,
:mod:`mechkin.solvers.ik.accel`, lazily the compiled kernels, and :mod:`mechkin.spatial`; never
``io/``, ``cli/`` or ``tasks/``. The back end is read at call time as
``accel.compiled_lm_available()`` (tests monkeypatch that one attribute).
"""

from __future__ import annotations

import numpy as np

from mechkin.solvers.ik import accel
from mechkin.solvers.ik.kernel import (
    MAX_ITER_CLOSURE,
    TOL_DQ_CLOSURE,
    IkKernel,
    evaluate,
)
from mechkin.solvers.ik.results import IkOptions
from mechkin.spatial.rotations import rotation_log

MAX_ITER_LM = 100
LM_MU = 1e-9  # isotropic part of the damping: keeps steps small along unweighted directions
STALL_WINDOW = 12  # lm with restarts: a row that has not halved E in this many steps restarts
PASSIVE_BAND = 1e-3  # lm: a trial may cross a passive limit by this share of its range


class _OpenRows:
    """lm evaluations of an open chain on the serial path to {E} (:class:`SerialChain`), with
    the chain expressed in {P} itself (``F_0 = T_P^{-1} A_0``, see
    :meth:`SerialChain.first_frame`): the pose of {E} in {P} gives the residual (position,
    rotation vector) and the geometric Jacobian in {P} is its Jacobian. No carry. On a coupled
    open chain (:attr:`IkKernel.coupling`) the path's joints are ``jmul q_v + joff`` and the
    Jacobian is ``J M`` (:mod:`mechkin.model.couplings`)."""

    def __init__(self, kern: IkKernel) -> None:
        self.chain = kern.chain
        self.nv = kern.iv.size
        self.M = None
        if kern.coupling is not None:
            rc, jcol, self.jmul, self.joff = kern.coupled_chain
            self.colv = rc[jcol]  # each path joint's driver in q_v
            self.M = np.zeros((self.chain.k, self.nv))
            np.add.at(self.M, (np.arange(self.chain.k), self.colv), self.jmul)
            self.cols = None
        else:
            self.cols = kern.chain_cols  # None: the chain is q_v itself, in order

    def prepare(self, T_P: np.ndarray) -> np.ndarray:
        """Per-target constants (m, 4, 4): F_0 in {P}."""
        return self.chain.first_frame(T_P)

    def __call__(self, qv: np.ndarray, F0: np.ndarray, carry: tuple, q_prev: np.ndarray):
        if self.M is not None:
            qc = qv[:, self.colv] * self.jmul + self.joff
        else:
            qc = qv if self.cols is None else qv[:, self.cols]
        T_E, J = self.chain.pose_jacobian(qc, F0)
        x = np.empty((qv.shape[0], 6))
        x[:, :3] = T_E[:, :3, 3]
        x[:, 3:] = rotation_log(T_E[:, :3, :3])
        if self.M is not None:
            J = J @ self.M
        elif self.cols is not None:
            Jf = np.zeros((qv.shape[0], 6, self.nv))
            Jf[:, :, self.cols] = J
            J = Jf
        return x, J, None, ()


class _ClosedRows:
    """lm evaluations of a closed chain: loop closure warm-started by the first-order predictor
    ``q_w - S (q_v - q_v,prev)`` (kim1995 §5.1), Euler-parameter residual (Eq. (8)), reduced
    Jacobian (Eq. (10)). Carry: (q_w, S)."""

    def __init__(self, kern: IkKernel, tol_phi: float) -> None:
        self.kern = kern
        self.tol_phi = tol_phi

    def prepare(self, T_P: np.ndarray) -> np.ndarray:
        """Per-target constants: the precision points themselves."""
        return T_P

    def __call__(self, qv: np.ndarray, T_P: np.ndarray, carry: tuple, q_prev: np.ndarray):
        qw, S = carry
        if S is not None:
            qw = qw - np.einsum("mij,mj->mi", S, qv - q_prev)
        ev = evaluate(self.kern, qv, qw, T_P, tol_phi=self.tol_phi, rotation="euler")
        return ev.x, ev.J, ev.closed, (ev.q[:, self.kern.iw], ev.S)


def _lm_open_compiled(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
                      w: np.ndarray, opts: IkOptions, history: bool,
                      stop_on_first: bool = False):
    """:func:`lm_batch` of an open chain by the compiled kernel
    (:mod:`mechkin.solvers.ik.serial_jit`)."""
    if kern.coupling is not None:
        return _lm_coupled_compiled(kern, q_v0, T_P, w, opts, history, stop_on_first)
    from mechkin.solvers.ik import serial_jit

    m = q_v0.shape[0]
    max_iter = opts.max_iter or MAX_ITER_LM
    cols = kern.chain_cols
    sel = slice(None) if cols is None else cols
    # the kernel projects the chain's joints onto their limits; the others are left as given
    qv = np.array(q_v0, dtype=np.float64) if cols is None else kern.project(q_v0)
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    stall = STALL_WINDOW if opts.restarts > 0 else 0
    accel.announce(serial_jit.lm, "serial_jit.lm")
    accel.mark_loaded("open")
    qc, f, iters, done, gnorm, hist = serial_jit.lm_serial(
        qv[:, sel], kern.chain.first_frame(T_P), w, kern.chain, kern.bound_lo[sel],
        kern.bound_hi[sel], kern.cont_v[sel], kern.lower_v[sel], kern.upper_v[sel],
        f_abs=f_abs,
        max_iter=max_iter, stall=stall, mu=LM_MU, history=history, stop_first=stop_on_first,
        grad_tol=opts.lm_grad_tol)
    qv[:, sel] = qc
    q = np.empty((m, kern.n))
    q[:, kern.iv] = qv
    q[:, kern.iw] = q_w0
    hl = [h[: i + 1] for h, i in zip(hist, iters, strict=True)] if history else []
    return dict(q=q, qv=qv, qw=q_w0, f=f, iters=iters, nev=iters + 1, gnorm=gnorm,
                closed=np.ones(m, dtype=bool), converged=done, hist=hl)


def _lm_coupled_compiled(kern: IkKernel, q_v0: np.ndarray, T_P: np.ndarray, w: np.ndarray,
                         opts: IkOptions, history: bool, stop_on_first: bool):
    """:func:`lm_batch` of a coupled open chain by the compiled kernel in its reduced
    coordinates (:mod:`mechkin.solvers.ik.coupled_jit`); q_v outside the path's drivers is
    projected and kept, the coupled joints follow in closed form."""
    from mechkin.solvers.ik import coupled_jit

    rc, jcol, jmul, joff = kern.coupled_chain
    max_iter = opts.max_iter or MAX_ITER_LM
    qv = kern.project(q_v0)
    accel.announce(coupled_jit.lm_coupled, "coupled_jit.lm_coupled")
    accel.mark_loaded("open")
    u, f, iters, done, gnorm, hist = coupled_jit.lm_coupled_rows(
        qv[:, rc], kern.chain.first_frame(T_P), w, kern.chain, (jcol, jmul, joff),
        kern.bound_lo[rc], kern.bound_hi[rc], kern.cont_v[rc], kern.lower_v[rc],
        kern.upper_v[rc], f_abs=0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2,
        max_iter=max_iter, stall=STALL_WINDOW if opts.restarts > 0 else 0, mu=LM_MU,
        history=history, stop_first=stop_on_first, grad_tol=opts.lm_grad_tol)
    qv[:, rc] = u
    q = kern.coupling.full(qv)
    hl = [h[: i + 1] for h, i in zip(hist, iters, strict=True)] if history else []
    m = qv.shape[0]
    return dict(q=q, qv=qv, qw=q[:, kern.iw], f=f, iters=iters, nev=iters + 1, gnorm=gnorm,
                closed=np.ones(m, dtype=bool), converged=done, hist=hl)


def passive_limited_steps(A: np.ndarray, g: np.ndarray, step: np.ndarray, qw: np.ndarray,
                           S: np.ndarray, lo_w: np.ndarray, hi_w: np.ndarray) -> np.ndarray:
    r"""lm steps (q_v <- q_v - step) that keep the dependent (passive) joints within their
    limits to first order: where the predicted ``q_w + S step`` crosses a limit, the step is
    re-solved with those joints held on it (equality constraints, KKT system)

    .. math:: \begin{pmatrix} A & C^T \\ C & 0\end{pmatrix}
              \begin{pmatrix} \delta \\ \nu\end{pmatrix} =
              \begin{pmatrix} g \\ q_{w,lim} - q_w \end{pmatrix},\qquad C = S_{active}

    adding crossed joints until none is crossed (an active-set loop, rows one by one)."""
    pred = qw + (S @ step[:, :, None])[:, :, 0]
    crossing = np.flatnonzero(((pred > hi_w) | (pred < lo_w)).any(axis=1))
    if crossing.size == 0:
        return step
    step = step.copy()
    nv = step.shape[1]
    for r in crossing:
        act = np.zeros(qw.shape[1], dtype=bool)
        st = step[r]
        for _ in range(qw.shape[1]):
            p = qw[r] + S[r] @ st
            new = ((p > hi_w) | (p < lo_w)) & ~act
            if not new.any():
                break
            act |= new
            C = S[r][act]
            tgt = np.where(p[act] > hi_w[act], hi_w[act], lo_w[act]) - qw[r][act]
            na = int(act.sum())
            K = np.zeros((nv + na, nv + na))
            K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = A[r], C.T, C
            st = np.linalg.lstsq(K, np.concatenate([g[r], tgt]), rcond=None)[0][:nv]
        step[r] = st
    return step


def lm_batch(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
              w: np.ndarray, opts: IkOptions, history: bool = False,
              stop_on_first: bool = False):
    r""":func:`lm_rows`, then on closed chains every answer brought onto its passive joints'
    limits (:func:`mechkin.solvers.ik.passive.restore_onto_limits`): the trials lm accepts may
    close up to PASSIVE_BAND of a range beyond a limit; the answers returned never do. A row
    that cannot be restored is reported not closed (``closed`` False: never an answer)."""
    r = lm_rows(kern, q_v0, q_w0, T_P, w, opts, history, stop_on_first)
    if not (kern.n_cuts and kern.iw.size and kern.coupling is None and kern.passive_bounded):
        return r
    from mechkin.solvers.ik.passive import restore_onto_limits

    run = np.isfinite(r["f"]) & r["closed"]
    q, x, inside = restore_onto_limits(kern, r["q"], T_P, run, opts.tol_phi)
    if x is not None:
        moved = np.isfinite(x).all(axis=1)
        r["q"] = q
        r["qv"], r["qw"] = q[:, kern.iv], q[:, kern.iw]
        xz = np.nan_to_num(x)
        r["f"] = np.where(moved, 0.5 * np.einsum("mi,mi->m", xz, w * xz), r["f"])
    lost = run & ~inside
    if lost.any():
        r["closed"] = r["closed"] & ~lost
        r["f"] = np.where(lost, np.inf, r["f"])
    return r


def lm_rows(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
            w: np.ndarray, opts: IkOptions, history: bool = False,
            stop_on_first: bool = False):
    r"""Levenberg-Marquardt on the reduced Jacobian for m targets at once.

    The residual is kim1995's x (Eq. (8)); for open chains its orientation part is written as a
    rotation vector (angle times axis) instead of the vector part of the Euler parameters: both
    vanish at the same point, but the rotation vector does not flatten out for large errors, so
    far targets converge in a few steps. Closed chains keep the Euler parameters (measured on
    the kim1995 end-effector robot: with position weight 0 the rotation-vector steps drift along
    the unweighted directions onto the leg strokes and the next precision point fails).
    With E = 1/2 x^T W x and Marquardt's scaling,

    .. math:: (H + \lambda\,(\mathrm{diag}\,H + \mu I))\,\delta = -J_r^T W x,\qquad
              H = J_r^T W J_r

    q_v is projected onto its limits after each step; a step is kept when E decreases
    (lambda / 10), else lambda x 4. A row stops when E is far below the verification
    tolerances, when a step gains nothing measurable, or when ``||J_r^T W x|| <
    opts.lm_grad_tol`` (an explicit ``tolerances.grad``; joints held on a limit do not count),
    the same in the numpy and the compiled back ends. On closed chains the dependent (passive)
    joints keep their limits too: a step that would carry them across is re-solved with them
    held on the limit
    (:func:`passive_limited_steps`), and a trial whose loop closure lands more than
    PASSIVE_BAND of a range beyond a limit is rejected. (Measured on the kim1995 end-effector
    robot: without this, lm reaches Table 8 points 2-4 with spherical joint s1 through the
    gimbal lock of its Euler angles, s1_2 = 126 deg, after a ~100-step crawl; with it, point 2
    takes 33 steps and every answer stays within the limits, as Table 9's do.)
    Rows that have converged leave the working set (vectorized across targets): the working
    arrays are compacted only when rows leave, so one target costs a fixed, small number of
    array operations per iteration. With ``stop_on_first`` (several starts for one target) the
    run ends when one row converges.
    """
    m, nv = q_v0.shape
    max_iter = opts.max_iter or MAX_ITER_LM
    lo, hi = kern.bound_lo, kern.bound_hi
    bounded = bool(np.isfinite(lo).any() or np.isfinite(hi).any())
    # couplings alone (no cut links) are solved in closed form: an open chain in q_v
    closed_chain = bool(kern.n_cuts) and kern.iw.size > 0 and kern.coupling is None
    # starts for one target (stop_on_first) end at the first success: about one row's work
    # (measured, PUMA 560 scenario: 30 restart rows 6.4 ms by numpy, one row from the guess
    # 9.6 ms)
    n_rows = 1 if stop_on_first else m
    if accel.use_compiled("closed" if closed_chain else "open", n_rows):
        # writable C arrays: a read-only start (a broadcast, a view of a frozen array) is
        # another numba signature, compiled at first use after `mechkin warmup` (issue 29)
        q_v0, q_w0, T_P, w = (np.require(a, np.float64, ("C", "W"))
                              for a in (q_v0, q_w0, T_P, w))
        if not closed_chain:
            return _lm_open_compiled(kern, q_v0, q_w0, T_P, w, opts, history, stop_on_first)
        from mechkin.solvers.ik import tree_jit

        accel.announce(tree_jit.lm_closed, "tree_jit.lm_closed")
        accel.mark_loaded("closed")
        return tree_jit.lm_closed_rows(
            kern, q_v0, q_w0, T_P, w, tol_phi=opts.tol_phi, tol_dq=TOL_DQ_CLOSURE,
            max_iter_closure=MAX_ITER_CLOSURE, max_iter=max_iter, mu=LM_MU, history=history,
            passive_band=PASSIVE_BAND, stop_first=stop_on_first, grad_tol=opts.lm_grad_tol,
            f_abs=0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2)
    rows = _ClosedRows(kern, opts.tol_phi) if closed_chain else _OpenRows(kern)
    passive_bounded = closed_chain and kern.passive_bounded
    qv = kern.project(q_v0)
    tgt = rows.prepare(T_P)
    x, J, closed, carry = rows(qv, tgt, (q_w0, None), qv)
    closed_ok = np.ones(m, dtype=bool) if closed is None else closed.copy()
    f = 0.5 * np.einsum("mi,mi->m", x, w * x)
    qw = carry[0] if closed_chain else q_w0
    iters = np.zeros(m, dtype=int)
    nev = np.ones(m, dtype=int)
    gnorm = np.zeros(m)
    lam = np.full(m, 1e-2)
    hist: list[list[float]] = [[float(v)] for v in f] if history else []
    eye = np.eye(nv)
    mu_eye = LM_MU * eye
    # converged: weighted errors far below the verification tolerances
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    done = ~closed_ok | (f < f_abs)
    stall_check = opts.restarts > 0 and not kern.mech.cuts  # closed chains crawl by nature
    act = np.flatnonzero(~done)
    # compacted working set of the active rows
    qa, xa, Ja, fa, la, wa = qv[act], x[act], J[act], f[act], lam[act], w[act]
    tga = tgt[act]
    ca = tuple(c[act] for c in carry) if closed_chain else ()
    fref = fa.copy()
    ga_norm = np.zeros(act.size)
    its = 0
    for it in range(max_iter):
        if act.size == 0:
            break
        JW = np.swapaxes(Ja, 1, 2) * wa[:, None, :]
        g = (JW @ xa[:, :, None])[:, :, 0]
        H = JW @ Ja
        if bounded:
            # active bounds: a joint on a limit whose gradient pushes outward is frozen
            blocked = ((qa <= lo + 1e-12) & (g > 0)) | ((qa >= hi - 1e-12) & (g < 0))
            if blocked.any():
                g = np.where(blocked, 0.0, g)
                free = ~blocked
                H = H * (free[:, :, None] & free[:, None, :]) + eye * blocked[:, :, None]
        ga_norm = np.sqrt(np.einsum("mi,mi->m", g, g))
        gstop = ga_norm < opts.lm_grad_tol  # ||grad E|| below tolerances.grad: stop, no step
        A = H + la[:, None, None] * (H * eye + mu_eye)
        try:
            step = np.linalg.solve(A, g[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            step = np.stack([np.linalg.lstsq(a, b, rcond=None)[0]
                             for a, b in zip(A, g, strict=False)])
        if passive_bounded:
            step = passive_limited_steps(A, g, step, ca[0], ca[1], kern.lo_w, kern.hi_w)
        qn = qa - step
        if bounded:
            qn = kern.project(qn)
        xn, Jn, cl, cn = rows(qn, tga, ca, qa)
        if passive_bounded and cl is not None:
            band = PASSIVE_BAND * kern.range_w
            cl = cl & np.all((cn[0] >= kern.lo_w - band) & (cn[0] <= kern.hi_w + band), axis=1)
        fn = 0.5 * np.einsum("mi,mi->m", xn, wa * xn)
        its += 1
        good = (fn < fa if cl is None else cl & (fn < fa)) & ~gstop
        gain = fa - fn
        if good.all():
            fin = (fn < f_abs) | (gain <= 1e-14 * np.maximum(fn, 1e-300))
            qa, xa, Ja, fa, ca = qn, xn, Jn, fn, cn
            la = np.maximum(la * 0.1, 1e-12)
        else:
            gm = good[:, None]
            qa = np.where(gm, qn, qa)
            xa = np.where(gm, xn, xa)
            Ja = np.where(good[:, None, None], Jn, Ja)
            fa = np.where(good, fn, fa)
            ca = tuple(np.where(good.reshape((-1,) + (1,) * (o.ndim - 1)), n_, o)
                       for n_, o in zip(cn, ca, strict=True))
            la = np.where(good, np.maximum(la * 0.1, 1e-12), la * 4.0)
            # finished: converged, no measurable progress, or a rejected step that is tiny
            fin = np.where(good, (fn < f_abs) | (gain <= 1e-14 * np.maximum(fn, 1e-300)),
                           (np.sqrt(np.einsum("mi,mi->m", step, step)) < 1e-13) | (la > 1e10))
        fin = fin | gstop
        if history:
            for r_, fv in zip(act, fa, strict=True):
                hist[r_].append(float(fv))
        if stall_check and (it + 1) % STALL_WINDOW == 0:
            # a row whose E has not halved in STALL_WINDOW steps is crawling (a limit, a
            # singularity or a local minimum): let the restarts have it
            fin = fin | (fa > 0.5 * fref)
            fref = fa.copy()
        if stop_on_first and np.any(fa < f_abs):
            fin = np.ones(act.size, dtype=bool)
        if fin.any():
            # write the finished rows back and compact the working set
            r_ = act[fin]
            qv[r_], x[r_], f[r_], lam[r_], gnorm[r_] = qa[fin], xa[fin], fa[fin], la[fin], \
                ga_norm[fin]
            iters[r_] = its - gstop[fin]  # a gradient stop takes no step (as compiled)
            if closed_chain:
                qw[r_] = ca[0][fin]
            done[r_] = True
            keep = ~fin
            act = act[keep]
            qa, xa, Ja, fa, la, wa = qa[keep], xa[keep], Ja[keep], fa[keep], la[keep], wa[keep]
            tga, fref, ga_norm = tga[keep], fref[keep], ga_norm[keep]
            ca = tuple(c[keep] for c in ca)
    if act.size:  # out of iterations
        qv[act], x[act], f[act], gnorm[act] = qa, xa, fa, ga_norm
        iters[act] = its
        if closed_chain:
            qw[act] = ca[0]
    nev += iters
    if kern.coupling is not None:
        q = kern.coupling.full(qv)
        qw = q[:, kern.iw]
    else:
        q = np.empty((m, kern.n))
        q[:, kern.iv] = qv
        q[:, kern.iw] = qw
    return dict(q=q, qv=qv, qw=qw, f=f, iters=iters, nev=nev, gnorm=gnorm,
                closed=closed_ok, converged=done, hist=hist)


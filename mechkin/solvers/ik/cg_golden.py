r"""kim1995 §5.2: Fletcher-Reeves conjugate gradient with a golden-section line search, in two
variants (``IkOptions.cg_variant``).

Every function evaluation runs the §5.1 loop closure warm-started from the current dependent
joints (the compiled closed-chain evaluation when available).

``printed`` (:func:`cg_golden_printed`) is §5.2 Steps 3-8 as printed: Fletcher-Reeves
directions (Step 5) that are never reset, Arora's (1989 §8.2) three-phase golden section
(bracket with steps growing by the golden ratio without a cap, reduce the interval below the
stated length, take its midpoint), and Step 6 (``||grad f|| < epsilon``) as the only
convergence test.

``robust`` (:func:`cg_golden`, the default) differs:

1. the direction is reset to -grad every ``cg_restart`` (default n_v) iterations and whenever
   it is not a descent direction (a safeguard: the golden section is inexact and the reduced
   objective of closed chains is not quadratic, so FR directions can lose descent);
2. each bracket is capped at a joint change of ``max_step = 0.1`` (a safeguard keeping the
   trials near the assembly the warm-started loop closure is in; it also means a minimum
   farther away takes several iterations: on (alpha - 0.3)^2 the search returns 0.1309);
3. the line search returns the best point it evaluated, not the interval's midpoint (never
   worse than the start of the search, which the midpoint need not be);
4. the passive joints' limits are kept by Rosen's gradient projection (Arora 1989 §11), and
   the Step 6 test uses the projected gradient (measured: without it, the kim1995
   end-effector robot's 3-RPS stage runs into the gimbal lock of a spherical joint, beyond
   its limit);
5. the search also stops when neither the direction nor -grad decreases f (a numerical
   stationary point) instead of running to ``max_iter``.

Both project the independent joints onto their limits (the mechanism file's limits; §5.2
states none, and the kim1995 examples do not reach them).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel`, :mod:`mechkin.solvers.ik.results`,
:mod:`mechkin.solvers.ik.accel` and lazily :mod:`mechkin.solvers.ik.tree_jit`; never ``io/``,
``cli/`` or ``tasks/``.

References
----------
kim1995_complex_chain_ik §5.2 Steps 1-8; Arora, *Introduction to Optimum Design* (1989)
§8.2 (golden section), §8.3 (Fletcher-Reeves), §11 (projection).
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

MAX_ITER_CG = 2000
ACTIVE_BAND = 1e-3  # cg-golden: a passive joint this close to a limit (share of range) is active
GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)  # 0.618...


def _point_evaluator(kern: IkKernel, opts: IkOptions):
    """``(q_v, q_w guess, T_P, jac) -> (closed, x, J_r | None, q, S | None)`` for one point:
    the compiled closed-chain evaluation when available, else :func:`evaluate`."""
    # the tree kernel also serves open chains (no cuts) and joint couplings (rows of phi)
    if accel.compiled_lm_available():
        from mechkin.solvers.ik.tree_jit import ClosedEvaluator, evaluate_one

        accel.announce(evaluate_one, "tree_jit.evaluate_one")
        ce = ClosedEvaluator(kern, opts.tol_phi, TOL_DQ_CLOSURE, MAX_ITER_CLOSURE)
        return lambda qv, qw, T_P, jac: ce(qv, qw, T_P)

    def ev(qv, qw, T_P, jac):
        e = evaluate(kern, qv[None], qw[None], T_P[None], jac=jac, tol_phi=opts.tol_phi)
        return (bool(e.closed[0]), e.x[0], None if e.J is None else e.J[0], e.q[0],
                None if e.S is None else e.S[0])

    return ev


def cg_golden(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
               w: np.ndarray, opts: IkOptions):
    """kim1995 §5.2 Steps 3-8 for one precision point (arrays (n_v,), (n_w,), (4, 4), (6,)),
    ``robust`` variant (see the module docstring for its differences from the printed text;
    ``opts.cg_variant == "printed"`` hands over to :func:`cg_golden_printed`).

    §5.2 has no constraints. Independent joints are projected onto their limits (as in lm);
    the dependent (passive) joints' limits, which are nonlinear constraints on q_v, are kept by
    Rosen's gradient projection (Arora 1989 §11): a line-search trial with a passive joint
    beyond its limit is infeasible (f = inf), and at a point where passive joints sit on their
    limits the search direction is projected onto the tangent of those limits,
    ``d <- (I - A^T (A A^T)^-1 A) d`` with the rows ``A = +-dq_w/dq_v`` of the active limits the
    direction would cross. The convergence test (Step 6) uses the projected gradient. Without
    it, steepest descent on the kim1995 end-effector robot drives the 3-RPS stage into the
    gimbal lock of a spherical joint (s1_2 = 90 deg, beyond its 80 deg limit) and stops.
    """
    if opts.cg_variant == "printed":
        return cg_golden_printed(kern, q_v0, q_w0, T_P, w, opts)
    max_iter = opts.max_iter or MAX_ITER_CG
    nv = q_v0.size
    restart = nv if opts.cg_restart is None else opts.cg_restart
    nev = 0
    lo_w, hi_w = kern.mech.lower[kern.iw], kern.mech.upper[kern.iw]
    evaluate_at = _point_evaluator(kern, opts)

    S = None  # dq_w/dq_v = -S at the current iterate

    def fval(qv: np.ndarray, qw: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, bool]:
        # kim1995 §5.2 Steps 7.1-7.3: closure warm-started from q_w^(k), then f; a trial
        # beyond passive limits is restored onto them (Rosen), up to 3 linearized steps
        nonlocal nev
        for _ in range(4):
            nev += 1
            closed_e, x, _, q_e, _ = evaluate_at(qv, qw, T_P, False)
            if not closed_e:
                return np.inf, qv, qw, False
            qwe = q_e[kern.iw]
            over = np.maximum(qwe - hi_w, 0.0) - np.maximum(lo_w - qwe, 0.0)
            if not np.any(np.abs(over) > 1e-9):
                return 0.5 * float(x @ (w * x)), qv, qwe, True
            if S is None:
                break
            J_ = np.flatnonzero(np.abs(over) > 1e-9)
            A = -S[J_]  # dq_w/dq_v of the violated joints
            qv = kern.project(qv - A.T @ np.linalg.lstsq(A @ A.T, over[J_], rcond=None)[0])
            qw = qwe
        return np.inf, qv, qw, False

    def project_dir(d: np.ndarray, qv: np.ndarray, qw: np.ndarray, S: np.ndarray | None
                    ) -> np.ndarray:
        """Rosen's projection of d onto the tangent of the limits it would cross: independent
        joints on a limit keep still, passive ones move along their limit."""
        band_v = 1e-6 * np.minimum(kern.upper_v - kern.lower_v, 2 * np.pi)
        d = np.where(((qv <= kern.bound_lo + band_v) & (d < 0))
                     | ((qv >= kern.bound_hi - band_v) & (d > 0)), 0.0, d)
        if S is None or not S.size:
            return d
        rng_w = np.minimum(hi_w - lo_w, 2 * np.pi)
        at_hi = qw >= hi_w - ACTIVE_BAND * rng_w
        at_lo = qw <= lo_w + ACTIVE_BAND * rng_w
        if not (at_hi.any() or at_lo.any()):
            return d
        G = -S  # dq_w/dq_v (n_w, n_v)
        rows = np.concatenate([G[at_hi], -G[at_lo]])  # outward normals
        act = np.zeros(len(rows), dtype=bool)
        for _ in range(len(rows) + 1):
            viol = (rows @ d > 1e-12 * np.linalg.norm(d)) & ~act
            if not viol.any():
                break
            act |= viol
            A = rows[act]
            d = d - A.T @ np.linalg.lstsq(A @ A.T, A @ d, rcond=None)[0]
        return d

    qv = kern.project(q_v0)
    closed_e, x, Jr, q_e, S = evaluate_at(qv, q_w0, T_P, True)  # Step 3
    nev += 1
    if not closed_e:
        return dict(qv=qv, qw=q_w0, f=np.inf, iters=0, nev=nev, gnorm=np.inf, closed=False,
                    converged=False, hist=[np.inf])
    qw = q_e[kern.iw]
    f = 0.5 * float(x @ (w * x))
    g = Jr.T @ (w * x)  # Step 4, kim1995 Eq. (10)
    gp = -project_dir(-g, qv, qw, S)
    d = -gp
    g_prev_n2 = float(gp @ gp)
    hist = [f]
    k = 0
    converged = False
    alpha_prev = 0.0
    for k in range(max_iter):  # noqa: B007 - k is reported
        gn = float(np.sqrt(gp @ gp))
        if gn < opts.grad_tol:  # Step 6 (projected gradient)
            converged = True
            break
        if k > 0:  # Step 5: Fletcher-Reeves
            beta = float(gp @ gp) / g_prev_n2
            d = project_dir(-gp + beta * d, qv, qw, S)
            if (restart and k % restart == 0) or float(d @ g) >= 0.0:
                d = -gp
        g_prev_n2 = float(gp @ gp)
        # Step 7: golden-section search for alpha* along d, with bracketing
        dn = float(np.linalg.norm(d))
        delta = (alpha_prev * 0.5 if alpha_prev > 0 else 0.05 / dn)
        alpha, f_new, qv_new, qw_new = golden_line(fval, qv, qw, d, f, delta, kern.project,
                                                    opts.line_tol / dn)
        if not np.isfinite(f_new) or f_new >= f:
            # no decrease along d: steepest descent once more, then stop
            if not np.array_equal(d, -gp):
                d = -gp
                dn = float(np.linalg.norm(d))
                alpha, f_new, qv_new, qw_new = golden_line(
                    fval, qv, qw, d, f, 0.05 / dn, kern.project, opts.line_tol / dn)
            if not np.isfinite(f_new) or f_new >= f:
                converged = True  # no descent along -grad: a numerical stationary point
                break
        alpha_prev = alpha
        qv = qv_new  # Step 8: q_v + alpha d (projected, restored onto passive limits)
        _, x, Jr, q_e, S = evaluate_at(qv, qw_new, T_P, True)
        nev += 1
        qw = q_e[kern.iw]
        f = 0.5 * float(x @ (w * x))
        g = Jr.T @ (w * x)
        gp = -project_dir(-g, qv, qw, S)
        hist.append(f)
    else:
        k = max_iter
    gn = float(np.sqrt(gp @ gp))
    converged = converged or gn < opts.grad_tol
    closed = True
    if kern.n_cuts and kern.coupling is None and kern.passive_bounded:
        # a start beyond a passive limit is kept when no step improves on it: brought onto
        # the limits like every lm answer (mechkin.solvers.ik.passive)
        from mechkin.solvers.ik.passive import restore_one

        qv, qw, f, closed = restore_one(kern, qv, qw, T_P, w, f, opts.tol_phi)
    return dict(qv=qv, qw=qw, f=f if closed else np.inf, iters=k, nev=nev, gnorm=gn,
                closed=closed, converged=converged, hist=hist)


def golden_line(fval, qv: np.ndarray, qw: np.ndarray, d: np.ndarray, f0: float, delta: float,
                 project, tol: float, max_step: float = 0.1):
    """Golden-section search of min_alpha f(q_v + alpha d) (Arora 1989 §8.2), robust variant:
    bracket with steps growing by the golden ratio up to a joint change of ``max_step``, shrink
    the interval until shorter than ``tol``, return the best point evaluated."""
    cache: dict[float, tuple[float, np.ndarray, np.ndarray]] = {}

    def F(a: float) -> float:
        if a not in cache:
            fa, qva, qwa, ok = fval(project(qv + a * d), qw)
            cache[a] = (fa if ok else np.inf, qva, qwa)
        return cache[a][0]

    # phase 1: bracketing, alpha_q = sum_j delta (1.618)^j, up to a joint change of max_step
    amax = max_step / max(float(np.abs(d).max()), 1e-300)
    delta = min(delta, amax)
    a_prev2, a_prev, f_prev = 0.0, 0.0, f0
    a = delta
    fa = F(a)
    if fa >= f0:
        lo_a, hi_a = 0.0, a
    else:
        step = delta
        while True:
            step *= 1.0 / GOLDEN
            a_next = a + step
            fn = F(a_next)
            if fn >= fa or a_next > amax:
                lo_a, hi_a = a_prev, a_next
                break
            a_prev2, a_prev, f_prev = a_prev, a, fa
            a, fa = a_next, fn
    del a_prev2, f_prev
    # phase 2: golden-section reduction of [lo_a, hi_a]
    aL, aU = lo_a, hi_a
    a1 = aL + (1.0 - GOLDEN) * (aU - aL)
    a2 = aL + GOLDEN * (aU - aL)
    f1, f2 = F(a1), F(a2)
    while aU - aL > tol:
        if f1 < f2 or (f1 == f2 == np.inf):  # both infeasible: the feasible side is near 0
            aU, a2, f2 = a2, a1, f1
            a1 = aL + (1.0 - GOLDEN) * (aU - aL)
            f1 = F(a1)
        elif f1 > f2:
            aL, a1, f1 = a1, a2, f2
            a2 = aL + GOLDEN * (aU - aL)
            f2 = F(a2)
        else:
            aL, aU = a1, a2
            a1 = aL + (1.0 - GOLDEN) * (aU - aL)
            a2 = aL + GOLDEN * (aU - aL)
            f1, f2 = F(a1), F(a2)
    # phase 3: the best point evaluated
    best = min(cache, key=lambda t: cache[t][0])
    return best, *cache[best]



# ---- the printed variant -------------------------------------------------------------------------

DELTA_PRINTED = 1e-3  # printed: Arora's first bracketing step delta, as a joint change


def golden_section(F, f0: float, delta: float, tol: float, max_eval: int = 10_000
                   ) -> tuple[float, int]:
    r"""Arora (1989) §8.2 golden-section search of :math:`\min_{\alpha \ge 0} F(\alpha)` with
    ``F(0) = f0``, the three phases of kim1995 §5.2 Step 7.

    Phase 1 (initial interval): trial points :math:`\alpha_q = \sum_{j=0}^{q} \delta\,
    1.618^j` until :math:`F(\alpha_{q-1}) < F(\alpha_q)`; the minimum lies in
    :math:`[\alpha_{q-2}, \alpha_q]` (``[0, delta]`` when ``F(delta) >= f0``). No cap.
    Phase 2 (reduction): :math:`\alpha_a = \alpha_l + 0.382 I`, :math:`\alpha_b = \alpha_l +
    0.618 I`; keep :math:`[\alpha_l, \alpha_b]` if :math:`F(\alpha_a) < F(\alpha_b)`,
    :math:`[\alpha_a, \alpha_u]` if greater, :math:`[\alpha_a, \alpha_b]` if equal, until
    :math:`I = \alpha_u - \alpha_l < ` ``tol``. Phase 3: :math:`\alpha^* = (\alpha_l +
    \alpha_u) / 2`.

    Returns ``(alpha*, number of evaluations of F)``. ``max_eval`` only guards against an F
    that decreases without bound (then the last trial is returned).
    """
    nev = 0
    # phase 1
    a_l, a_m, f_m = 0.0, 0.0, f0  # alpha_{q-2}, alpha_{q-1}
    step = delta
    a = delta
    fa = F(a)
    nev += 1
    while fa <= f_m:
        if nev >= max_eval or not np.isfinite(a):
            return a, nev
        a_l, a_m, f_m = a_m, a, fa
        step /= GOLDEN  # x 1.618
        a = a + step
        fa = F(a)
        nev += 1
    a_u = a
    # phase 2
    ln = a_u - a_l
    aa, ab = a_l + (1.0 - GOLDEN) * ln, a_l + GOLDEN * ln
    fa_, fb_ = F(aa), F(ab)
    nev += 2
    while a_u - a_l >= tol and nev < max_eval:
        if fa_ < fb_:
            a_u, ab, fb_ = ab, aa, fa_
            aa = a_l + (1.0 - GOLDEN) * (a_u - a_l)
            fa_ = F(aa)
            nev += 1
        elif fa_ > fb_:
            a_l, aa, fa_ = aa, ab, fb_
            ab = a_l + GOLDEN * (a_u - a_l)
            fb_ = F(ab)
            nev += 1
        else:
            a_l, a_u = aa, ab
            ln = a_u - a_l
            aa, ab = a_l + (1.0 - GOLDEN) * ln, a_l + GOLDEN * ln
            fa_, fb_ = F(aa), F(ab)
            nev += 2
    # phase 3
    return 0.5 * (a_l + a_u), nev


def fletcher_reeves(point, line, x0: np.ndarray, grad_tol: float, line_tol: float,
                    max_iter: int):
    r"""kim1995 §5.2 Steps 4-8 on any smooth f: Fletcher-Reeves conjugate gradient with the
    golden-section line search :func:`golden_section`, as printed.

    ``point(x) -> (f, grad) | None`` evaluates the iterate (None: it cannot be evaluated, e.g.
    the loops do not close); ``line(x, d) -> F`` gives :math:`F(\alpha) = f(x + \alpha d)` for
    the search from x (inf where f cannot be evaluated). Step 5:
    :math:`d^{(k)} = -\nabla f^{(k)} + \beta_k d^{(k-1)}`, :math:`\beta_k = (\|\nabla
    f^{(k)}\| / \|\nabla f^{(k-1)}\|)^2`, never reset; Step 6: stop when :math:`\|\nabla
    f^{(k)}\| <` ``grad_tol``; Step 7: the interval is ``line_tol`` as a change of x, the first
    bracketing step ``DELTA_PRINTED`` (both divided by ``||d||`` in alpha).

    Returns a dict: x, f, g, iters, nev, converged, ok (False: ``point`` failed), hist.
    """
    x = np.asarray(x0, dtype=float)
    e = point(x)
    nev = 1
    if e is None:
        return dict(x=x, f=np.inf, g=np.full_like(x, np.inf), iters=0, nev=nev,
                    converged=False, ok=False, hist=[np.inf])
    f, g = e
    hist = [f]
    d = -g
    g2_prev = float(g @ g)
    k = 0
    for k in range(max_iter):  # noqa: B007 - k is reported
        g2 = float(g @ g)
        if k > 0:  # Step 5
            d = -g + (g2 / g2_prev) * d
        g2_prev = g2
        if np.sqrt(g2) < grad_tol:  # Step 6
            return dict(x=x, f=f, g=g, iters=k, nev=nev, converged=True, ok=True, hist=hist)
        dn = float(np.linalg.norm(d))
        alpha, n_ls = golden_section(line(x, d), f, DELTA_PRINTED / dn, line_tol / dn)  # Step 7
        nev += n_ls + 1
        x = x + alpha * d  # Step 8 (then Steps 3-4 at the new point)
        e = point(x)
        if e is None:
            return dict(x=x, f=np.inf, g=g, iters=k + 1, nev=nev, converged=False, ok=False,
                        hist=hist + [np.inf])
        f, g = e
        hist.append(f)
    gn = float(np.sqrt(g @ g))
    return dict(x=x, f=f, g=g, iters=max_iter, nev=nev, converged=gn < grad_tol, ok=True,
                hist=hist)


def cg_golden_printed(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
                      w: np.ndarray, opts: IkOptions):
    r"""kim1995 §5.2 Steps 3-8 as printed, for one precision point (:func:`fletcher_reeves`).

    Step 3 closes the loops at :math:`q_v^{(k)}` warm-started from the previous dependent
    joints; Step 4 :math:`\nabla f^{(k)} = J_r^T W x` (Eq. (10)); Steps 5-8 by
    :func:`fletcher_reeves`, each line-search trial (Steps 7.1-7.3) a loop closure
    warm-started from :math:`q_w^{(k)}` (a trial whose loops do not close has f = inf).
    Step 6 with ``opts.grad_tol`` is the only convergence test. Independent joints are
    projected onto their limits; passive limits are not enforced.
    """
    evaluate_at = _point_evaluator(kern, opts)
    state = {"qw": np.asarray(q_w0, dtype=float)}

    def point(qv):  # Steps 3-4
        ok, x, Jr, q_e, _ = evaluate_at(kern.project(qv), state["qw"], T_P, True)
        if not ok:
            return None
        state["qw"] = q_e[kern.iw]
        return 0.5 * float(x @ (w * x)), Jr.T @ (w * x)

    def line(qv, d):  # Steps 7.1-7.3, warm-started from q_w^(k)
        qw_k = state["qw"]

        def F(a: float) -> float:
            ok, xa, _, _, _ = evaluate_at(kern.project(qv + a * d), qw_k, T_P, False)
            return 0.5 * float(xa @ (w * xa)) if ok else np.inf

        return F

    r = fletcher_reeves(point, line, kern.project(q_v0), opts.grad_tol, opts.line_tol,
                        opts.max_iter or MAX_ITER_CG)
    gn = float(np.sqrt(r["g"] @ r["g"]))
    return dict(qv=kern.project(r["x"]), qw=state["qw"], f=r["f"], iters=r["iters"],
                nev=r["nev"], gnorm=gn if r["ok"] else np.inf, closed=r["ok"],
                converged=r["converged"], hist=r["hist"])

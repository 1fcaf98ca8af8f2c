"""Warm-started chains of IK targets (kim1995 §5.2 Step 2): each target from the previous
answer; on a closed chain a target that fails so is solved again exactly as a lone target would
be (issue 24).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`; builds on :mod:`.solve`.
"""

from __future__ import annotations

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.kernel import IkKernel, kernel_for
from mechkin.solvers.ik.results import IkOptions, IkResult, IkStatus, better
from mechkin.solvers.ik.solve import solve_ik


def solve_ik_warm(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray, q_w0: np.ndarray,
                  cold: tuple[np.ndarray, np.ndarray] | None,
                  weights: np.ndarray | None = None, options: IkOptions | None = None,
                  kernel: IkKernel | None = None) -> IkResult:
    """One target of a warm-started chain (kim1995 §5.2 Step 2): :func:`solve_ik` from the
    previous answer; on a closed chain, a target that fails so is solved again exactly as a lone
    target would be, from ``cold`` (the chain's initial guess, with its restarts), and the
    better answer kept, so a chain never loses a target the same defaults solve alone
    (issue 24)."""
    r = solve_ik(mech, T_P, q_v0=q_v0, q_w0=q_w0, weights=weights, options=options,
                 kernel=kernel)
    if r.status is IkStatus.OK or not mech.is_closed:
        return r
    if cold is not None and not (np.array_equal(cold[0], q_v0)
                                 and np.array_equal(cold[1], q_w0)):
        r2 = solve_ik(mech, T_P, q_v0=cold[0], q_w0=cold[1], weights=weights,
                      options=options, kernel=kernel)
        from dataclasses import replace

        a, b = (r2, r) if better(vars(r2), vars(r)) else (r, r2)
        r = replace(a, iterations=a.iterations + b.iterations,
                    evaluations=a.evaluations + b.evaluations, time_s=a.time_s + b.time_s)
    if r.status is IkStatus.OK:
        return r
    start = (q_v0, q_w0) if cold is None else cold
    return _rescue(mech, T_P, r, start, weights, options or IkOptions(), kernel)


def _rescue(mech: Mechanism, T_P: np.ndarray, r: IkResult, start: tuple[np.ndarray, np.ndarray],
            weights: np.ndarray | None, opts: IkOptions, kernel: IkKernel | None) -> IkResult:
    """A closed-chain lm target still failed: once more as a one-target batch
    (:func:`mechkin.solvers.ik.solve.solve_ik_batch`, whose restarts start from the codebook
    and from seeded random q_v within the limits, not from a jitter about the guess), kept when
    it is better (a better status, then a lower f: the answer a batch would give, issue 24);
    else ``r`` as it was. Measured on the Cassie-like leg with rod limits [-30, 30] deg: 5 of 59
    targets at within-limit configurations lost alone with the defaults, none after."""
    from mechkin.solvers.ik.solve import solve_ik_batch

    if opts.method != "lm" or opts.restarts <= 0 or not mech.cuts:
        return r
    w = None if weights is None else np.asarray(weights, dtype=np.float64)[None]
    b = solve_ik_batch(mech, np.asarray(T_P, dtype=np.float64)[None], q_v0=start[0],
                       q_w0=start[1], weights=w, options=opts,
                       frame=None if kernel is None else kernel.frame, lone_restarts=False)
    if not better({"status": b.status[0], "f": float(b.f[0])}, vars(r)):
        return r
    q = b.q[0]
    at = tuple(mech.joint_names[j] for j in np.flatnonzero((q <= mech.lower + 1e-9)
                                                             | (q >= mech.upper - 1e-9)))
    it = int(b.iterations[0])
    return IkResult(q_v=b.q_v[0], q_w=b.q_w[0], q=q, status=b.status[0],
                    position_error=float(b.position_error[0]),
                    orientation_error=float(b.orientation_error[0]), f=float(b.f[0]),
                    grad_norm=0.0, iterations=r.iterations + it,
                    evaluations=r.evaluations + it + 1, time_s=r.time_s + b.time_s,
                    f_history=np.array([float(b.f[0])]), at_limit=at,
                    restarts_used=opts.restarts, method="lm")


def solve_ik_sequence(mech: Mechanism, targets: list[np.ndarray] | np.ndarray, *,
                      q_v0: np.ndarray | None = None, q_w0: np.ndarray | None = None,
                      weights: np.ndarray | list[np.ndarray] | None = None,
                      options: IkOptions | None = None, frame: int | None = None,
                      ) -> list[IkResult]:
    """Solve precision points in order, each warm-started from the previous solution
    (kim1995 §5.2 Step 2). ``weights`` (6,) for all or (k, 6) per point."""
    kern = kernel_for(mech, frame)
    Ts = np.asarray(targets, dtype=np.float64).reshape(-1, 4, 4)
    W = np.ones((len(Ts), 6)) if weights is None else np.broadcast_to(
        np.asarray(weights, dtype=np.float64), (len(Ts), 6))
    qv = mech.home[kern.iv].copy() if q_v0 is None else np.asarray(q_v0, dtype=np.float64)
    qw = mech.home[kern.iw].copy() if q_w0 is None else np.asarray(q_w0, dtype=np.float64)
    out = []
    cold = (qv.copy(), qw.copy())
    for T, w in zip(Ts, W, strict=False):
        r = solve_ik_warm(mech, T, q_v0=qv, q_w0=qw, cold=cold, weights=w, options=options,
                          kernel=kern)
        out.append(r)
        if r.status is not IkStatus.SINGULAR:
            qv, qw = r.q_v, r.q_w
    return out

r"""The analytic route of :func:`mechkin.ik` (``method: auto | analytic``), single or batched.

Sequences (``batch=False``): each target's answer is the solution nearest the previous answer
(the first: nearest ``q_v0``), so the sequence stays on its branch; ``batch=True``: every
target at once (one compiled call, :func:`mechkin.solvers.ik.analytic.solutions.
analytic_batch`), each nearest ``q_v0``. ``auto`` re-solves targets without an analytic
solution by lm (and returns None when the mechanism does not decompose: the caller runs lm).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; never ``io/``, ``tasks/`` or ``cli/``.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from mechkin.errors import ConfigError
from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.classify import NotDecomposable, held_chain
from mechkin.solvers.ik.analytic.dispatch import analytic_ik, chain_for
from mechkin.solvers.ik.analytic.solutions import analytic_batch
from mechkin.solvers.ik.results import IkOptions, IkResult, IkStatus


def ik_analytic(mech: Mechanism, T: np.ndarray, *, method: str, weights: np.ndarray,
                q_v0: np.ndarray, q_w0: np.ndarray, options: IkOptions, batch: bool,
                fixed: dict[str, float] | None = None) -> list[IkResult] | None:
    """IkResults of targets T (k, 4, 4) by the analytic route, or None (``auto`` on a
    mechanism that does not decompose, or with a zero weight). ``analytic`` there raises
    ConfigError naming the axes or the weights. ``fixed`` {joint name: value}: those
    independent joints are held (a 7R arm's redundant joint) and the remaining 6R solved;
    a held set that does not decompose is a ConfigError for either method."""
    from mechkin.solvers.ik.solve import solve_ik

    try:
        if fixed:
            if not bool((np.asarray(weights) > 0).all()):
                raise NotDecomposable("the analytic route solves the whole pose: give all six "
                                      "weights positive")
            chain = held_chain(mech, fixed)
        else:
            chain = chain_for(mech, method, weights)
    except NotDecomposable as exc:
        raise ConfigError(f"{'fixed' if fixed else 'method: analytic'}: {exc}") from None
    if chain is None and mech.cuts and not fixed:
        from mechkin.solvers.ik.analytic.dispatch import solve_ik_method
        from mechkin.solvers.ik.analytic.legs import legs_for

        if legs_for(mech) is None or not bool((np.asarray(weights) > 0).all()):
            return None
        out, qv, qw = [], np.asarray(q_v0, float), np.asarray(q_w0, float)
        for Tk in T:  # a parallel mechanism by its legs, each target from the previous one
            r = solve_ik_method(mech, Tk, method=method, q_v0=qv, q_w0=qw, weights=weights,
                                options=options)
            out.append(r)
            if not batch and r.ok:
                qv, qw = r.q_v, r.q_w
        return out
    if chain is None:
        return None
    lm = options if options.method == "lm" else replace(options, method="lm")
    out: list[IkResult] = []
    if batch:
        t0 = time.perf_counter()
        b = analytic_batch(mech, chain, T, q_v0)
        per = (time.perf_counter() - t0) / max(len(T), 1)
        for i in range(len(T)):
            if b.count[i] == 0 or b.position_error[i, 0] > options.tol_pos or \
                    b.orientation_error[i, 0] > options.tol_ori:
                if method == "auto" and not fixed:
                    r = solve_ik(mech, T[i], q_v0=q_v0, q_w0=q_w0, weights=weights,
                                 options=lm)
                else:
                    r = analytic_ik(mech, chain, T[i], q_v0, weights, options)
                out.append(r)
                continue
            q = mech.home.astype(np.float64).copy()
            q[mech.independent] = b.q_v[i, 0]
            pe, oe = float(b.position_error[i, 0]), float(b.orientation_error[i, 0])
            f = 0.5 * (float(weights[:3].sum()) * pe * pe + float(weights[3:].sum()) * oe * oe) / 3
            out.append(IkResult(q_v=b.q_v[i, 0].copy(), q_w=q[mech.dependent], q=q,
                                status=IkStatus.OK, position_error=pe, orientation_error=oe,
                                f=f, grad_norm=0.0, iterations=0, evaluations=1, time_s=per,
                                f_history=np.array([f]), method="analytic"))
        return out
    qv = np.asarray(q_v0, dtype=np.float64)
    for Tk in T:
        r = analytic_ik(mech, chain, Tk, qv, weights, options)
        if not r.ok and method == "auto" and not fixed:
            r = solve_ik(mech, Tk, q_v0=qv, q_w0=q_w0, weights=weights, options=lm)
        out.append(r)
        if np.all(np.isfinite(r.q)):
            qv = r.q_v
    return out


def ik_one_fast(mech: Mechanism, target: object, method: str, weights: object,
                q_v0: object, batch: bool) -> list[IkResult] | None:
    """The shortest route of :func:`mechkin.ik` for one (4, 4) ndarray target with default
    weights on a mechanism that decomposes (``auto`` / ``analytic``): the analytic answer
    nearest the guess when it is verified (status ok); else None (the general route decides,
    e.g. ``auto`` goes on to lm)."""
    if batch or weights is not None or method not in ("auto", "analytic") or \
            type(target) is not np.ndarray or target.shape != (4, 4):
        return None
    chain = mech.__dict__.get("_analytic_chain", ())
    if chain == ():
        from mechkin.solvers.ik.analytic.classify import analytic_chain

        chain = analytic_chain(mech)
    if chain is None:
        return None
    guess = mech.home[mech.independent] if q_v0 is None else q_v0
    r = analytic_ik(mech, chain, target, guess)
    return [r] if r.ok else None


def all_solutions_sampled(mech: Mechanism, T: np.ndarray, joint: str, values: np.ndarray,
                          ref: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Every solution of the pose T (4, 4) of a redundant arm with ``joint`` held at each of
    ``values`` in turn (a sample of the self-motion): (q_v (k, n_v), value index (k,)), each
    list ordered from ``ref`` (default home). The values that leave the rest non-decomposable
    raise ConfigError."""
    ref = mech.home[mech.independent] if ref is None else np.asarray(ref, float)
    out, idx = [], []
    for i, v in enumerate(np.asarray(values, dtype=float)):
        try:
            chain = held_chain(mech, {joint: float(v)})
        except NotDecomposable as exc:
            raise ConfigError(f"fixed: {exc}") from None
        b = analytic_batch(mech, chain, np.asarray(T, float)[None], ref)
        out.append(b.q_v[0, :b.count[0]])
        idx += [i] * int(b.count[0])
    nv = len(mech.independent)
    return (np.vstack(out) if out else np.zeros((0, nv))), np.array(idx, dtype=int)

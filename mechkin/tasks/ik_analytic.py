"""The ik task's analytic route (``method: auto | analytic``): the check that ``analytic``
applies, the batched solve and the complete ``solutions: all``.

Imports: config, model, solvers, tasks.common (a part of :mod:`mechkin.tasks.ik`).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.model import Mechanism
from mechkin.solvers.ik import IkOptions, IkResult
from mechkin.solvers.ik.all_solutions import IkSolutions
from mechkin.solvers.ik.analytic.classify import NotDecomposable
from mechkin.solvers.ik.analytic.dispatch import ANALYTIC_METHODS, chain_for
from mechkin.solvers.ik.analytic.solutions import analytic_batch


def analytic_problem(sc: Scenario, mech: Mechanism) -> str | None:
    """Why ``method: analytic`` cannot solve this scenario (one line naming the file, the key
    and the axes or weights that break it), or None."""
    from mechkin.errors import ConfigError

    spec = sc.section
    if spec.fixed:
        try:
            held_values(sc, mech)
        except ConfigError as exc:
            return str(exc)
        return None
    ws = [t.weights for t in spec.targets if t.weights is not None]
    if spec.random_targets is not None or any(t.weights is None for t in spec.targets):
        ws.append(spec.weights)
    try:
        for w in ws or [None]:
            chain_for(mech, "analytic", None if w is None else np.asarray(w, float))
    except NotDecomposable as exc:
        return f"{sc.doc.where(('ik', 'method'))}: analytic: {exc}"
    return None


def held_values(sc: Scenario, mech: Mechanism) -> dict[str, float] | None:
    """``ik.fixed`` in SI (joint name -> value), checked against the mechanism: a joint that is
    not independent, a value outside the limits, or a held set that leaves the rest
    non-decomposable is bad input naming the key."""
    from mechkin.errors import ConfigError
    from mechkin.solvers.ik.analytic.classify import held_chain
    from mechkin.tasks.common import joint_factor

    given = sc.section.fixed
    if not given:
        return None
    out = {}
    for name, v in given.items():
        if name not in mech.independent_names:
            raise ConfigError(f"{sc.doc.where(('ik', 'fixed', name))}: not an independent "
                              f"joint of {mech.name} ({', '.join(mech.independent_names)})")
        out[name] = float(v) * joint_factor(mech, mech.joint_index(name), sc.spec.units)
    try:
        held_chain(mech, out)
    except NotDecomposable as exc:
        raise ConfigError(f"{sc.doc.where(('ik', 'fixed'))}: {exc}") from None
    return out


def solve_held(mech: Mechanism, fixed: dict[str, float], T_P: np.ndarray, W: np.ndarray,
               qv0: np.ndarray, opts: IkOptions, warm: bool
               ) -> tuple[list[IkResult], list[tuple[np.ndarray, np.ndarray]]]:
    """Every target with the ``fixed`` joints held: the analytic solution nearest the guess
    (the previous answer when ``warm``); (results, guesses)."""
    from mechkin.solvers.ik.analytic.classify import held_chain
    from mechkin.solvers.ik.analytic.dispatch import analytic_ik

    chain = held_chain(mech, fixed)
    qv = np.array(qv0, dtype=float)
    qv[chain.fixed_cols] = chain.fixed_values
    qw = mech.home[mech.dependent]
    results, guesses = [], []
    for T, w in zip(T_P, W, strict=True):
        guesses.append((qv, qw))
        r = analytic_ik(mech, chain, T, qv, w, opts)
        results.append(r)
        if warm and r.ok:
            qv = r.q_v
    return results, guesses


def analytic_rows(mech: Mechanism, method: str, W: np.ndarray,
                  fixed: dict[str, float] | None = None) -> np.ndarray:
    """Which targets (k,) the analytic route solves: ``auto`` / ``analytic`` on a mechanism
    that decomposes (with the ``fixed`` joints held), targets with all six weights
    positive."""
    if method not in ANALYTIC_METHODS:
        return np.zeros(len(W), dtype=bool)
    if fixed:
        from mechkin.solvers.ik.analytic.classify import held_chain

        chain = held_chain(mech, fixed)
    else:
        try:
            chain = chain_for(mech, method, None)
        except NotDecomposable:
            chain = None
    if chain is None:
        return np.zeros(len(W), dtype=bool)
    return np.all(W > 0, axis=1)


def solve_batch_analytic(mech: Mechanism, method: str, T_P: np.ndarray, W: np.ndarray,
                         qv0: np.ndarray, qw0: np.ndarray, opts: IkOptions
                         ) -> list[IkResult] | None:
    """``batch: true`` by the analytic route (one compiled call for every target, each
    answer nearest the initial guess; ``auto`` re-solves the targets without a solution by
    lm), or None when the route does not apply to every target."""
    from mechkin.solvers.ik.analytic.api_ik import ik_analytic

    rows = analytic_rows(mech, method, W)
    if not rows.all() or not np.allclose(W, W[:1]):
        return None
    return ik_analytic(mech, T_P, method=method, weights=W[0], q_v0=qv0, q_w0=qw0,
                       options=opts, batch=True)


def analytic_all(mech: Mechanism, T_P: np.ndarray, refs: np.ndarray,
                 fixed: dict[str, float] | None = None) -> list[IkSolutions]:
    """Every solution within the limits of each target T_P (k, 4, 4), ordered from its guess
    refs (k, n_v): the analytic branches, complete (``complete: true``; with ``fixed``
    joints held: complete for those values), except the 1-D search's (``complete: false``)."""
    from mechkin.solvers.ik.analytic.classify import analytic_chain, held_chain

    chain = held_chain(mech, fixed) if fixed else \
        (analytic_chain(mech) or analytic_chain(mech, search=True))
    assert chain is not None
    t0 = time.perf_counter()
    b = analytic_batch(mech, chain, T_P, refs)
    per = (time.perf_counter() - t0) / max(len(T_P), 1)
    out = []
    iv = mech.independent
    for i in range(len(T_P)):
        n = int(b.count[i])
        q = np.repeat(np.where(np.isfinite(mech.home), mech.home, 0.0)[None], n, axis=0)
        q[:, iv] = b.q_v[i, :n]
        out.append(IkSolutions(q=q, q_v=b.q_v[i, :n].copy(),
                               position_error=b.position_error[i, :n].copy(),
                               orientation_error=b.orientation_error[i, :n].copy(),
                               distance=b.distance[i, :n].copy(), source="analytic", starts=8,
                               time_s=per, complete=chain.complete))
    return out


def methods_used(results: list[IkResult]) -> list[str]:
    """The methods that produced the answers (``auto`` resolves to analytic or lm)."""
    return sorted({r.method for r in results})


def solutions_summary_extra(all_sols: list[IkSolutions]) -> dict[str, Any]:
    """``complete``: every target's list is every solution within the limits."""
    return {"complete": bool(all(a.complete for a in all_sols))}


def parallel_legs(mech: Mechanism, method: str) -> Any:
    """The legs of a parallel mechanism (:mod:`mechkin.solvers.ik.analytic.legs`) that
    ``auto`` / ``analytic`` solve through, or None."""
    if method not in ANALYTIC_METHODS or not mech.cuts:
        return None
    from mechkin.solvers.ik.analytic.legs import legs_for

    return legs_for(mech)


def legs_all_solutions(mech: Mechanism, legs: Any, T: np.ndarray, qv: np.ndarray,
                       qw: np.ndarray, w: np.ndarray) -> IkSolutions:
    """Every solution of a parallel mechanism at the pose T (4, 4): every combination of its
    legs' branches (complete), verified by FK and the loop closure, merged and ordered from
    the guess like the other sources (:mod:`mechkin.solvers.ik.all_solutions`)."""
    from dataclasses import replace

    from mechkin.solvers.ik.all_solutions import SAME_TOL, TOL_ORI_ALL, TOL_POS_ALL, _finish
    from mechkin.solvers.ik.analytic.legs import legs_all

    t0 = time.perf_counter()
    ref = np.where(np.isfinite(mech.home), mech.home, 0.0)
    ref[mech.independent], ref[mech.dependent] = qv, qw
    q = legs_all(mech, legs, np.asarray(T, dtype=np.float64), ref)
    a = _finish(mech, q, np.asarray(T, dtype=np.float64), np.asarray(w, float),
                np.asarray(qv, float), TOL_POS_ALL, TOL_ORI_ALL, SAME_TOL, "analytic legs",
                len(q), t0)
    return replace(a, complete=True)

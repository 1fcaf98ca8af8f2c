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
    ws = _target_weights(spec)
    if spec.fixed:
        try:
            held_values(sc, mech)
        except ConfigError as exc:
            return str(exc)
        return None
    try:
        for w in ws or [None]:
            chain_for(mech, "analytic", None if w is None else np.asarray(w, float))
    except NotDecomposable as exc:
        return f"{sc.doc.where(('ik', 'method'))}: analytic: {exc}"
    return None


def _target_weights(spec: Any) -> list[Any]:
    """The weights the targets use: each target's own, and the section's when a target (or
    the random targets) takes them."""
    ws = [t.weights for t in spec.targets if t.weights is not None]
    if spec.random_targets is not None or any(t.weights is None for t in spec.targets):
        ws.append(spec.weights)
    return ws


def held_values(sc: Scenario, mech: Mechanism) -> dict[str, float] | None:
    """``ik.fixed`` in SI (joint name -> value), checked against the mechanism: a joint that is
    not independent, a value outside the limits, a held set that leaves the rest
    non-decomposable, or targets that do not weigh the whole pose (the held route solves all
    six components exactly, so it would ignore zero weights) is bad input naming the key."""
    from mechkin.errors import ConfigError
    from mechkin.solvers.ik.analytic.classify import held_chain
    from mechkin.tasks.common import joint_factor

    given = sc.section.fixed
    if not given:
        return None
    spec = sc.section
    for i, t in enumerate(spec.targets):
        if t.weights is not None and not all(w > 0 for w in t.weights):
            raise ConfigError(f"{sc.doc.where(('ik', 'targets', i, 'weights'))}: fixed: "
                              "solves the whole pose with the held joints, so every weight "
                              f"must be positive, got {list(t.weights)} (drop fixed: and use "
                              "method lm to weigh components)")
    if (spec.random_targets is not None or any(t.weights is None for t in spec.targets)) and \
            not all(w > 0 for w in spec.weights):
        raise ConfigError(f"{sc.doc.where(('ik', 'weights'))}: fixed: solves the whole pose "
                          "with the held joints, so every weight must be positive, got "
                          f"{list(spec.weights)} (drop fixed: and use method lm to weigh "
                          "components)")
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

    if mech.cuts and method in ANALYTIC_METHODS and bool((W > 0).all()):
        # Stewart-type legs: each leg's targets in one compiled loop, each from the guess
        seq = _legs_sequence_batched(mech, T_P, W, np.zeros(len(T_P), dtype=bool), method,
                                     opts, qv0, qw0, False)
        if seq is not None:
            return seq[0]
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
    iv = mech.independent
    # every target's rows at once (views of fresh arrays, one per field), no per-row work
    Q = np.broadcast_to(np.where(np.isfinite(mech.home), mech.home, 0.0),
                        b.q_v.shape[:2] + (mech.n,)).copy()
    Q[:, :, iv] = b.q_v
    QV, PE = b.q_v.copy(), b.position_error.copy()
    OE, D = b.orientation_error.copy(), b.distance.copy()
    return [IkSolutions(q=Q[i, :n], q_v=QV[i, :n], position_error=PE[i, :n],
                        orientation_error=OE[i, :n], distance=D[i, :n], source="analytic",
                        starts=8, time_s=per, complete=chain.complete)
            for i, n in enumerate(b.count.tolist())]


def methods_used(results: list[IkResult]) -> list[str]:
    """The methods that produced the answers (``auto`` resolves to analytic or lm)."""
    return sorted({r.method for r in results})


def analytic_structure(mech: Mechanism, fixed: dict[str, float] | None = None) -> str | None:
    """The decomposition the analytic answers came from, for the summary: the serial class
    (:func:`mechkin.solvers.ik.analytic.classify.classify`'s description, e.g. "spherical
    wrist, h2 || h3") or the parallel mechanism's legs by kind; None when there is none."""
    from mechkin.solvers.ik.analytic.classify import NotDecomposable, analytic_chain, held_chain

    try:
        if mech.cuts:
            legs = parallel_legs(mech, "analytic")
            if not legs:
                return None
            kinds = sorted({leg.kind for leg in legs})
            return f"{len(legs)} legs solved one by one ({', '.join(kinds)})"
        chain = held_chain(mech, fixed) if fixed else \
            (analytic_chain(mech) or analytic_chain(mech, search=True))  # search: analytic only
    except NotDecomposable:
        return None
    return None if chain is None else str(chain.description)


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


#: Targets from which the ik task solves an analytic sequence in one compiled loop
#: (:func:`solve_sequence_batched`); fewer go one by one (same answers, no extra compile).
BATCH_MIN = 200


def solve_sequence_batched(mech: Mechanism, T_P: np.ndarray, W: np.ndarray, far: np.ndarray,
                           method: str, opts: IkOptions, qv0: np.ndarray, qw0: np.ndarray,
                           warm: bool) -> tuple[list[IkResult],
                                                list[tuple[np.ndarray, np.ndarray]]] | None:
    """The ik task's sequence (:func:`mechkin.tasks.ik_solve.solve_sequence`) of an open chain
    that decomposes (``auto`` / ``analytic``, all six weights positive), solved in one compiled
    loop (:func:`mechkin.solvers.ik.analytic.sequence.solve_sequence_into`): each target from
    the previous answer when ``warm`` (else from the initial guess), every answer, status and
    error identical to the per-target route; a target the loop cannot settle (beyond reach,
    no analytic solution) goes through the per-target route there, and its answer becomes the
    next guess as in the sequence. None when the route does not apply (the caller goes one by
    one)."""
    from mechkin.solvers.ik.analytic.dispatch import solve_ik_method
    from mechkin.solvers.ik.analytic.finish import solve_one
    from mechkin.solvers.ik.analytic.sequence import solve_sequence_into
    from mechkin.solvers.ik.analytic.solve6r import KIND_ARM5, KIND_SCARA, KIND_SEARCH
    from mechkin.solvers.ik.results import IkStatus
    from mechkin.tasks.ik_solve import _out_of_reach

    if method not in ANALYTIC_METHODS or len(T_P) < BATCH_MIN or not bool((W > 0).all()):
        return None
    chain = chain_for(mech, method, W[0])
    if chain is None and mech.cuts:
        return _legs_sequence_batched(mech, T_P, W, far, method, opts, qv0, qw0, warm)
    if chain is None or chain.kind in (KIND_SCARA, KIND_ARM5, KIND_SEARCH) or \
            not chain.identity:
        return None
    from mechkin.solvers.ik.accel import announce

    announce(solve_one, "analytic IK (finish.solve_one)")
    announce(solve_sequence_into, "analytic IK (sequence.solve_sequence_into)")
    t0 = time.perf_counter()
    m = len(T_P)
    Ts = np.ascontiguousarray(T_P, dtype=np.float64)
    q6 = np.empty((m, 6))
    e3 = np.empty((m, 3))
    mask = np.zeros(m, dtype=np.int64)
    settled = np.zeros(m, dtype=bool)
    lone: dict[int, IkResult] = {}
    guess_of: list[tuple[np.ndarray, np.ndarray]] = [None] * m  # type: ignore[list-item]
    skip = np.ascontiguousarray(far, dtype=bool)
    qv, qw = np.asarray(qv0, dtype=np.float64), np.asarray(qw0, dtype=np.float64)
    start = 0
    while start < m:
        stop = int(solve_sequence_into(chain.packed, Ts, np.ascontiguousarray(qv), skip,
                                       float(opts.tol_pos), float(opts.tol_ori), bool(warm),
                                       start, q6, e3, mask))
        settled[start:stop] = True
        for r in range(start, stop):  # the guesses the sequence had
            guess_of[r] = (qv, qw)
            if warm:
                qv = q6[r]
        if stop == m:
            break
        guess_of[stop] = (qv, qw)
        if far[stop]:
            res = _out_of_reach(mech, qv, qw)
        else:
            res = solve_ik_method(mech, T_P[stop], method=method, q_v0=qv, q_w0=qw,
                                  weights=W[stop], options=opts)
            if warm and res.status is not IkStatus.SINGULAR:
                qv, qw = res.q_v, res.q_w
        lone[stop] = res
        start = stop + 1
    per = (time.perf_counter() - t0) / m
    iv, dep = mech.independent, mech.dependent
    names = [mech.joint_names[j] for j in iv]
    Q = np.array(q6) if chain.all_joints else np.repeat(mech.home[None].astype(np.float64),
                                                        m, axis=0)
    if not chain.all_joints:
        Q[:, iv] = q6
    QV = np.array(q6)
    QW = np.zeros((m, 0)) if chain.all_joints else Q[:, dep]
    PE, OE = e3[:, 0].copy(), e3[:, 1].copy()
    # the per-target route's f, elementwise in the same order of operations
    F = 0.5 * ((W[:, 0] + W[:, 1] + W[:, 2]) * PE * PE + (W[:, 3] + W[:, 4] + W[:, 5]) * OE
               * OE) / 3.0
    FH = F[:, None].copy()
    ok = IkStatus.OK
    results: list[IkResult] = [
        lone[r] if not settled[r] else IkResult(
            q_v=QV[r], q_w=QW[r], q=Q[r], status=ok, position_error=float(PE[r]),
            orientation_error=float(OE[r]), f=float(F[r]), grad_norm=0.0, iterations=0,
            evaluations=1, time_s=per, f_history=FH[r],
            at_limit=tuple(names[j] for j in range(6) if int(mask[r]) >> j & 1),
            method="analytic")
        for r in range(m)]
    return results, guess_of


def _legs_sequence_batched(mech: Mechanism, T_P: np.ndarray, W: np.ndarray, far: np.ndarray,
                           method: str, opts: IkOptions, qv0: np.ndarray, qw0: np.ndarray,
                           warm: bool
                           ) -> tuple[list[IkResult],
                                      list[tuple[np.ndarray, np.ndarray]]] | None:
    """:func:`solve_sequence_batched` of a parallel mechanism whose legs are all arms of the
    compiled classes (Stewart-type U-P-S legs, :mod:`mechkin.solvers.ik.analytic.legs`): each
    leg's sequence in one compiled loop (each target from the previous answer when ``warm``),
    the answers verified together (FK of {E}, the loop closure); a target where a leg has no
    solution, or the verification fails, goes through the per-target route there (``auto``:
    lm) and the legs go on from its answer. The joints equal the per-target route's bit for
    bit (the same compiled call per leg and target); the verification errors are the batched
    FK's (equal to round-off). None when a leg is of another kind."""
    from mechkin.model.kinematics import closure_residual, forward_kinematics
    from mechkin.solvers.ik.analytic.dispatch import solve_ik_method
    from mechkin.solvers.ik.analytic.legs import _leg_targets, legs_for
    from mechkin.solvers.ik.analytic.sequence import solve_sequence_into
    from mechkin.solvers.ik.analytic.solve6r import KIND_ARM5, KIND_SCARA
    from mechkin.solvers.ik.kernel import pose_errors
    from mechkin.solvers.ik.results import IkStatus
    from mechkin.tasks.ik_solve import _out_of_reach

    legs = legs_for(mech)
    if legs is None or any(
            leg.kind != "chain" or leg.prefix.size or not leg.chain.identity or
            leg.chain.kind in (KIND_SCARA, KIND_ARM5) for leg in legs):
        return None
    t0 = time.perf_counter()
    m, n = len(T_P), mech.n
    iv, dep = mech.independent, mech.dependent
    e = int(mech.end_effector)
    # the legs' targets exactly as solve_legs forms them, one pose at a time
    inv_e = np.linalg.inv(mech.frame_offset[e])
    T_ends = [np.empty((m, 4, 4)) for _ in legs]
    q_dummy = np.zeros((1, n))
    for k in range(m):
        Tp = (np.asarray(T_P[k], dtype=np.float64) @ inv_e)[None]
        for leg, out in zip(legs, T_ends, strict=True):
            out[k] = _leg_targets(mech, leg, Tp, q_dummy)[0]
    skip = np.ascontiguousarray(far, dtype=bool)
    cur = np.where(np.isfinite(mech.home), mech.home, 0.0)
    cur[iv], cur[dep] = qv0, qw0
    Q = np.empty((m, n))
    PE, OE = np.empty(m), np.empty(m)
    settled = np.zeros(m, dtype=bool)
    lone: dict[int, IkResult] = {}
    guess_of: list[tuple[np.ndarray, np.ndarray]] = [None] * m  # type: ignore[list-item]
    q6, e3, mask = np.empty((m, 6)), np.empty((m, 3)), np.zeros(m, dtype=np.int64)
    inf = float("inf")
    start = 0
    while start < m:
        stop = m
        Q[start:] = cur
        for leg, T_end in zip(legs, T_ends, strict=True):
            s = int(solve_sequence_into(leg.chain.packed, T_end,
                                        np.ascontiguousarray(cur[leg.joints]), skip, inf,
                                        inf, bool(warm), start, q6, e3, mask))
            stop = min(stop, s)
            Q[start:s, leg.joints] = q6[start:s]
        if stop > start:  # verified like legs_ik: FK of {E}, the loops closed, the tolerances
            kin = forward_kinematics(mech, Q[start:stop])
            T_E = kin.frames(mech, [mech.end_effector])[:, 0]
            pe, oe = pose_errors(T_E, np.asarray(T_P[start:stop], dtype=np.float64))
            phi = closure_residual(mech, kin)
            closed = (np.linalg.norm(phi, axis=1) < 1e-8 if phi.shape[1]
                      else np.ones(stop - start, dtype=bool))
            good = closed & (pe <= opts.tol_pos) & (oe <= opts.tol_ori)
            if not good.all():
                stop = start + int(np.argmin(good))
            PE[start:stop], OE[start:stop] = pe[:stop - start], oe[:stop - start]
        settled[start:stop] = True
        for r in range(start, stop):  # the guesses the sequence had
            guess_of[r] = (cur[iv], cur[dep])
            if warm:
                cur = Q[r]
        if stop == m:
            break
        guess_of[stop] = (cur[iv], cur[dep])
        if far[stop]:
            res = _out_of_reach(mech, cur[iv], cur[dep])
        else:
            res = solve_ik_method(mech, T_P[stop], method=method, q_v0=cur[iv], q_w0=cur[dep],
                                  options=opts, weights=W[stop])
        if warm and res.status is not IkStatus.SINGULAR:
            cur = cur.copy()
            cur[iv], cur[dep] = res.q_v, res.q_w
        lone[stop] = res
        start = stop + 1
    per = (time.perf_counter() - t0) / m
    QV, QW = Q[:, iv], Q[:, dep]
    ok = IkStatus.OK
    results = [
        lone[r] if not settled[r] else IkResult(
            q_v=QV[r], q_w=QW[r], q=Q[r], status=ok, position_error=float(PE[r]),
            orientation_error=float(OE[r]), f=0.0, grad_norm=0.0, iterations=0,
            evaluations=1, time_s=per, f_history=np.zeros(1), method="analytic legs")
        for r in range(m)]
    return results, guess_of

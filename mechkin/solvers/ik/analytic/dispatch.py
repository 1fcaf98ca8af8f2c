r"""``method: auto | analytic`` for one precision point: the analytic branch nearest the guess.

* ``analytic``: the mechanism must decompose (:func:`mechkin.solvers.ik.analytic.classify.
  classify`) and the pose be weighted in full (all six weights positive: the subproblems
  solve the whole pose); otherwise :class:`NotDecomposable` says which axes, or the weights,
  break it. The answer is the solution within the limits nearest the guess ``q_v0`` (joint
  distance, revolute joints modulo 2 pi, each at the representative nearest the guess), so a
  warm-started sequence stays on its branch; none: status ``unreachable`` (the pose has no
  solution within the limits; the list is complete) at the guess; for the 1-D search
  (:mod:`mechkin.solvers.ik.analytic.search1d`, not proved complete) ``not converged``.
  The search classes are taken by ``analytic`` only: ``auto`` keeps lm for them (on two test
  arms the search found the generating joints of 99.8-100 % of 1000 random poses, not always
  the 99.9 % asked of an automatic choice, in ~1.3-4 ms a pose; lm from zero joints solved
  200 of 200 in ~1-3 ms).
* ``auto``: ``analytic`` where it applies, else (and where it finds no solution within the
  tolerances) :func:`mechkin.solvers.ik.solve_ik` with lm, its seeds and restarts.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports the IK family's records and
:func:`mechkin.solvers.ik.solve.solve_ik`; never ``io/``, ``tasks/`` or ``cli/``.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.accel import announce
from mechkin.solvers.ik.analytic.classify import (
    AnalyticChain,
    NotDecomposable,
    analytic_chain,
    classify,
)
from mechkin.solvers.ik.analytic.finish import solve_one_into
from mechkin.solvers.ik.analytic.scara import poe_fk
from mechkin.solvers.ik.analytic.solutions import analytic_batch, full_qv
from mechkin.solvers.ik.analytic.solve6r import (
    KIND_ARM5,
    KIND_SCARA,
    KIND_SEARCH,
    MAX_BRANCHES,
    fk_error,
    pris_bits,
)
from mechkin.solvers.ik.results import IkOptions, IkResult, IkStatus

ANALYTIC_METHODS = ("auto", "analytic")
_DEFAULT = IkOptions()
_NONE = np.zeros(0)
_NONE.flags.writeable = False


def chain_for(mech: Mechanism, method: str, weights: np.ndarray | None = None
              ) -> AnalyticChain | None:
    """The analytic chain ``method`` uses for ``mech`` (None: lm). ``analytic`` on a chain that
    does not decompose, or with a zero weight, raises NotDecomposable naming why."""
    full = weights is None or min(np.asarray(weights).tolist()) > 0
    if method == "analytic" and mech.cuts and full:
        from mechkin.solvers.ik.analytic.legs import platform_legs

        platform_legs(mech)  # a parallel mechanism by its legs, or NotDecomposable naming one
        return None
    if method == "analytic":
        if not full:
            raise NotDecomposable("method analytic solves the whole pose: give all six "
                                  "weights positive (or use method auto / lm)")
        chain = analytic_chain(mech, search=True)
        return classify(mech, search=True) if chain is None else chain
    if method == "auto" and full:
        return analytic_chain(mech)
    return None


def analytic_ik(mech: Mechanism, chain: AnalyticChain, T_P: np.ndarray, q_v0: np.ndarray,
                weights: np.ndarray | None = None, options: IkOptions | None = None
                ) -> IkResult:
    """The solution of T_P (4, 4) nearest the guess q_v0 (n_v,) (module docstring), verified
    to :data:`~mechkin.solvers.ik.analytic.solutions.TOL_POS` / ``TOL_ORI`` by the solver's
    FK; status ok when also within ``options.tol_pos`` / ``tol_ori``."""
    t0 = time.perf_counter()
    opts = options or _DEFAULT
    iv = mech.independent
    T = np.ascontiguousarray(T_P, dtype=np.float64)
    ref = np.asarray(q_v0, dtype=np.float64)
    if chain.kind in (KIND_SCARA, KIND_ARM5, KIND_SEARCH):
        b = analytic_batch(mech, chain, T[None], ref)
        n, qv = int(b.count[0]), b.q_v[0, 0]
        pe, oe = float(b.position_error[0, 0]), float(b.orientation_error[0, 0])
    else:
        announce(solve_one_into, "analytic IK (finish.solve_one_into)")
        buf = np.empty((MAX_BRANCHES, 9))
        n, mask = solve_one_into(chain.packed, T, ref if chain.identity else ref[chain.order],
                                 buf)
        qv = buf[0, :6] if chain.identity else full_qv(chain, buf[0, :6], len(iv))
        pe, oe = float(buf[0, 6]), float(buf[0, 7])
    if n > 0:
        ok = pe <= opts.tol_pos and oe <= opts.tol_ori
    else:
        qv = ref.copy()
        qv[chain.fixed_cols] = chain.fixed_values
        ok = False
        if chain.kind in (KIND_SCARA, KIND_ARM5):
            Te = poe_fk(chain.H, chain.P, chain.M, chain.pos_kind, qv[chain.order][None])[0]
            pe = float(np.linalg.norm(Te[:3, 3] - T[:3, 3]))
            oe = float(np.linalg.norm(Te[:3, :3] - T[:3, :3]) / np.sqrt(2.0))
        else:
            pe, oe = fk_error(chain.Hf, chain.Pf, chain.Mf,
                              np.ascontiguousarray(qv[chain.order]), T,
                              pris_bits(chain.kind, chain.pos_kind))
    if chain.all_joints:  # q is q_v: no copy of home, no dependent joints
        q = qv.copy()
    else:
        q = mech.home.copy()
        q[iv] = qv
    if chain.kind in (KIND_SCARA, KIND_ARM5, KIND_SEARCH) or not chain.identity or n == 0:
        lo, hi = chain.limits_list
        at = tuple(mech.joint_names[iv[j]] for j, x in enumerate(qv.tolist())
                   if abs(x - lo[j]) < 1e-9 or abs(x - hi[j]) < 1e-9)
    else:
        at = tuple(mech.joint_names[iv[j]] for j in range(6) if mask >> j & 1) if mask else ()
    if weights is None:
        f = 0.5 * (pe * pe + oe * oe)
    else:
        w = weights.tolist()
        f = 0.5 * ((w[0] + w[1] + w[2]) * pe * pe + (w[3] + w[4] + w[5]) * oe * oe) / 3.0
    return IkResult(q_v=qv, q_w=_NONE if chain.all_joints else q[mech.dependent], q=q,
                    status=IkStatus.OK if ok else (IkStatus.UNREACHABLE if chain.complete
                                                   else IkStatus.NOT_CONVERGED),
                    position_error=pe, orientation_error=oe, f=f, grad_norm=0.0,
                    iterations=0, evaluations=1, time_s=time.perf_counter() - t0,
                    f_history=np.array([f]), at_limit=at, method="analytic")


def solve_ik_method(mech: Mechanism, T_P: np.ndarray, *, method: str,
                    q_v0: np.ndarray | None = None, q_w0: np.ndarray | None = None,
                    weights: np.ndarray | None = None, options: IkOptions | None = None
                    ) -> IkResult:
    """One precision point by ``method`` (``auto``, ``analytic``, ``lm``, ``cg-golden``)."""
    from mechkin.solvers.ik.solve import solve_ik

    opts = options or IkOptions()
    if method in ANALYTIC_METHODS:
        chain = chain_for(mech, method, weights)
        full = weights is None or min(np.asarray(weights).tolist()) > 0
        if chain is None and mech.cuts and full:  # a parallel mechanism: by its legs
            from mechkin.solvers.ik.analytic.legs import legs_for, legs_ik

            legs = legs_for(mech)
            if legs is not None:
                qv = mech.home[mech.independent] if q_v0 is None else q_v0
                qw = mech.home[mech.dependent] if q_w0 is None else q_w0
                r = legs_ik(mech, legs, T_P, qv, qw, opts.tol_pos, opts.tol_ori)
                if r.ok or method == "analytic":
                    return r
        if chain is not None:
            guess = mech.home[mech.independent] if q_v0 is None else q_v0
            r = analytic_ik(mech, chain, T_P, np.asarray(guess, dtype=np.float64), weights,
                            opts)
            if r.ok or method == "analytic":
                return r
        opts = replace(opts, method="lm")
    else:
        opts = replace(opts, method=method)  # type: ignore[arg-type]
    return solve_ik(mech, T_P, q_v0=q_v0, q_w0=q_w0, weights=weights, options=opts)


__all__ = ["ANALYTIC_METHODS", "NotDecomposable", "analytic_ik", "chain_for",
           "solve_ik_method"]

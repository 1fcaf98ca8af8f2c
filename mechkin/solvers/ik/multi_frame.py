r"""Inverse kinematics of several frames at once: a biped's two feet, a humanoid's feet and
hands, a gripper's two fingertips (issue 25), in one least-squares problem with the loop
closure and the joint couplings.

Each target names its frame {E_k}, its pose {P_k} and its weights W_k (6: position x, y, z in
{P_k}'s axes, then orientation); a zero weight leaves that component free (a pelvis height alone
is ``weights: [0, 0, 1, 0, 0, 0]``). The residual stacks the weighted pose errors of every frame,

.. math:: r(q_v) = \big[W_1^{1/2} x_1;\ \dots;\ W_K^{1/2} x_K\big],\qquad
          x_k = \big(R_{P_k}^T (p_{E_k} - p_{P_k}),\ \log(R_{P_k}^T R_{E_k})\big)

(kim1995 Eq. (7)-(8), the orientation as a rotation vector), over the independent joints q_v
(with a floating base, its six virtual joints base_x..base_roll among them); the dependent
joints (cut loops and coupled joints) follow from phi(q_v, q_w) = 0 by Newton-Raphson
(:func:`mechkin.model.closure.solve_closure`), and each frame's Jacobian is reduced as in
kim1995 Eq. (10): ``J_r = J_v - J_w Phi_w^+ Phi_v``. The step is Levenberg-Marquardt's
``(J_r^T J_r + lambda (I + diag J_r^T J_r)) dq = -J_r^T r`` with the independent joints projected
onto their limits; a run that stalls restarts from seeded random joints around the start.

Every result is verified per frame by forward kinematics at the returned joints: the weighted
components of the position and orientation errors against ``tol_pos`` / ``tol_ori``.

Imports: numpy, model, solvers.ik.results.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import (
    Kinematics,
    closure_jacobian,
    forward_kinematics,
    relative_jacobians,
)
from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.results import TOL_ORI_RAD, TOL_POS_M, pose_and_weighted_errors
from mechkin.solvers.result import Status

MAX_ITER = 200
RESTARTS = 20
#: relative decrease of ||r||^2 below which an iteration counts as stalled
STALL_RTOL = 1e-12
#: an attempt that has not halved ||r||^2 over this many iterations is abandoned (restart)
STALL_WINDOW = 15


@dataclass(frozen=True)
class FrameTarget:
    """One frame's target: ``frame`` (name), ``T`` (4, 4) pose in the base frame [m],
    ``weights`` (6,) (position x, y, z in the target's axes, then orientation; zero = free)."""

    frame: str
    T: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class MultiFrameResult:
    """One target set solved together.

    q : (n,) all joints; q_v, q_w; status; ``frames`` the names; ``position_error``,
    ``orientation_error`` (k,) the weighted components' errors per frame [m, rad] by forward
    kinematics at ``q``; ``closure_residual`` ||phi||; iterations, restarts_used, time_s.
    """

    q: np.ndarray
    q_v: np.ndarray
    q_w: np.ndarray
    status: Status
    frames: tuple[str, ...]
    position_error: np.ndarray
    orientation_error: np.ndarray
    closure_residual: float
    iterations: int
    restarts_used: int
    time_s: float

    @property
    def ok(self) -> bool:
        return self.status is Status.OK


class _Problem:
    """Per-mechanism and per-target-set constants."""

    def __init__(self, mech: Mechanism, targets: list[FrameTarget],
                 held: dict[int, float] | None = None) -> None:
        self.mech = mech
        self.fb = np.array([mech.frame_index(t.frame) for t in targets], dtype=int)
        self.T_P = np.stack([np.asarray(t.T, dtype=np.float64) for t in targets])  # (k, 4, 4)
        self.w = np.stack([np.asarray(t.weights, dtype=np.float64) for t in targets])  # (k, 6)
        if self.w.shape[1] != 6 or np.any(self.w < 0) or not np.all(np.isfinite(self.w)):
            raise ValueError("weights: expected 6 finite non-negative numbers per target")
        self.sw = np.sqrt(self.w).reshape(-1)  # (6k,)
        self.iv, self.iw = mech.independent, mech.dependent
        lo, hi = mech.lower[self.iv], mech.upper[self.iv]
        self.cont = (mech.s[self.iv] == 0) & (hi - lo >= 2 * np.pi - 1e-9)
        self.lo = np.where(self.cont, -np.inf, lo)
        self.hi = np.where(self.cont, np.inf, hi)
        # held independent joints (a known floating-base pose): bounds pinned, no Jacobian column
        self.held = np.zeros(self.iv.size, dtype=bool)
        for i, v in (held or {}).items():
            self.held[i] = True
            self.lo[i] = self.hi[i] = float(v)
        c = mech.couplings
        self.cj = np.array([x.joint for x in c], dtype=int)
        self.ci = np.array([x.master for x in c], dtype=int)
        self.cm = np.array([x.multiplier for x in c])
        self.cc = np.array([x.offset for x in c])
        if c and not mech.cuts and self.iw.size:  # dq_w/dq_v = -Phi_w^-1 Phi_v, constant
            from mechkin.model.couplings import coupling_jacobian

            Phi = coupling_jacobian(mech)
            self.S_coupled = np.linalg.solve(Phi[:, self.iw], Phi[:, self.iv])

    def residual(self, kin: Kinematics, jac: bool):
        """r (6k,) and dr/dq (6k, n) at one configuration."""
        x, J = relative_jacobians(self.mech, kin, None, self.fb, self.T_P[None], rotation="log")
        r = x[0].reshape(-1) * self.sw
        return r, (J[0].reshape(-1, self.mech.n) * self.sw[:, None]) if jac else None

    def evaluate(self, q_v: np.ndarray, q_w: np.ndarray, jac: bool = True):
        """(ok, q, r, J_r) at q_v with the loop closure from the guess q_w."""
        mech = self.mech
        if self.iw.size and not mech.cuts:  # couplings only: q_w in closed form
            q = mech.assemble(q_v, q_w)
            for _ in range(len(mech.couplings)):  # chained couplings settle in as many passes
                q[self.cj] = self.cm * q[self.ci] + self.cc
            kin = forward_kinematics(mech, q[None])
            r, Jq = self.residual(kin, jac)
            if not jac:
                return True, q, r, None
            return True, q, r, self._free(Jq[:, self.iv] - Jq[:, self.iw] @ self.S_coupled)
        if mech.is_closed and self.iw.size:
            res = solve_closure(mech, q_v[None], q_w[None], keep_kinematics=True)
            if not res.ok[0] or not np.all(np.isfinite(res.q[0])):
                return False, res.q[0], None, None
            q = res.q[0]
            kin = (forward_kinematics(mech, q[None]) if res.T_links is None
                   else Kinematics(q=res.q, T_links=res.T_links, mech=mech))
        else:
            q = mech.assemble(q_v, q_w)
            kin = forward_kinematics(mech, q[None])
        r, Jq = self.residual(kin, jac)
        if not jac:
            return True, q, r, None
        Jr = Jq[:, self.iv]
        if self.iw.size:
            Phi = (closure_jacobian(mech, kin)[1] if res.jacobian is None else res.jacobian)[0]
            S = np.linalg.lstsq(Phi[:, self.iw], Phi[:, self.iv], rcond=None)[0]
            Jr = Jr - Jq[:, self.iw] @ S  # kim1995 Eq. (10)
        return True, q, r, self._free(Jr)

    def _free(self, Jr: np.ndarray) -> np.ndarray:
        """The reduced Jacobian with the held joints' columns zero (their step is then 0)."""
        if self.held.any():
            Jr = Jr.copy()
            Jr[:, self.held] = 0.0
        return Jr

    def project(self, q_v: np.ndarray) -> np.ndarray:
        return np.clip(q_v, self.lo, self.hi)


def _lm(P: _Problem, q_v: np.ndarray, q_w: np.ndarray, max_iter: int, f_tol: float):
    """Levenberg-Marquardt from (q_v, q_w): (ok, q, iterations)."""
    ok, q, r, J = P.evaluate(q_v, q_w)
    if not ok:
        return False, q, 0
    f = float(r @ r)
    lam = 1e-3
    nv = q_v.size
    it = 0
    hist = [f]
    for it in range(1, max_iter + 1):
        if f < f_tol:
            break
        if it > STALL_WINDOW and f > 0.5 * hist[-STALL_WINDOW]:  # crawling: restart instead
            break
        hist.append(f)
        JtJ = J.T @ J
        g = J.T @ r
        improved = False
        for _ in range(12):
            A = JtJ + lam * (np.eye(nv) + np.diag(np.diag(JtJ)))
            try:
                dq = -np.linalg.solve(A, g)
                # joints on a limit that the step pushes outward are held (active set), so
                # the others take the whole step instead of a clipped one
                held = ((q_v <= P.lo) & (dq < 0)) | ((q_v >= P.hi) & (dq > 0))
                if held.any():
                    free = ~held
                    dq = np.zeros(nv)
                    dq[free] = -np.linalg.solve(A[np.ix_(free, free)], g[free])
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            qv_new = P.project(q_v + dq)
            ok_n, q_n, r_n, J_n = P.evaluate(qv_new, q[P.iw])
            if ok_n and float(r_n @ r_n) < f:
                f_new = float(r_n @ r_n)
                stalled = f - f_new < STALL_RTOL * f
                q_v, q, r, J, f = qv_new, q_n, r_n, J_n, f_new
                lam = max(lam / 3.0, 1e-9)
                improved = not stalled
                break
            lam *= 4.0
        if not improved:
            break
    return True, q, it


def verify(mech: Mechanism, q: np.ndarray, targets: list[FrameTarget]
           ) -> tuple[np.ndarray, np.ndarray]:
    """Weighted-component position and orientation errors (k,) of every target frame by
    forward kinematics at q (n,)."""
    fb = [mech.frame_index(t.frame) for t in targets]
    T_E = forward_kinematics(mech, q[None]).frames(mech, fb)[0]
    T_P = np.stack([t.T for t in targets])
    w = np.stack([t.weights for t in targets])
    _, _, wpe, woe = pose_and_weighted_errors(T_E, T_P, w)
    return wpe, woe


def solve_multi_frame(mech: Mechanism, targets: list[FrameTarget], *,
                      q_v0: np.ndarray | None = None, q_w0: np.ndarray | None = None,
                      tol_pos: float = TOL_POS_M, tol_ori: float = TOL_ORI_RAD,
                      max_iter: int = MAX_ITER, restarts: int = RESTARTS,
                      seed: int = 0, held: dict[int, float] | None = None
                      ) -> MultiFrameResult:
    """Solve one target set (several frames) together; see the module docstring.

    ``q_v0`` / ``q_w0``: the start (default home). Restarts: seeded random independent joints
    around the start (a tenth of each range, at most 0.3 rad or m), then uniform within the
    limits for the bounded joints; a floating base always restarts near the start. ``held``:
    independent joints (index into ``mech.independent`` -> value [rad | m]) held at a known
    value, e.g. the six joints of a floating base whose pose is given; the rest are solved.
    """
    t0 = time.perf_counter()
    P = _Problem(mech, targets, held)
    home = np.where(np.isfinite(mech.home), mech.home, 0.0)
    qv0 = home[P.iv].copy() if q_v0 is None else np.asarray(q_v0, dtype=np.float64).copy()
    qw0 = home[P.iw].copy() if q_w0 is None else np.asarray(q_w0, dtype=np.float64).copy()
    f_tol = 1e-6 * min(tol_pos, tol_ori) ** 2
    rng = np.random.default_rng(seed)
    width = np.where(np.isfinite(P.hi - P.lo), P.hi - P.lo, 2 * np.pi)
    best = None
    iters = 0
    used = 0
    for attempt in range(restarts + 1):
        if attempt == 0:
            start = P.project(qv0)
        else:
            spread = np.minimum(0.1 * width, 0.3) * min(1.0 + attempt / 5.0, 4.0)
            start = P.project(qv0 + rng.normal(0.0, 1.0, qv0.size) * spread)
        ok, q, it = _lm(P, start, qw0, max_iter, f_tol)
        iters += it
        used = attempt
        if not ok:
            continue
        pe, oe = verify(mech, q, targets)
        score = float(np.max(pe / tol_pos, initial=0.0) + np.max(oe / tol_ori, initial=0.0))
        if best is None or score < best[0]:
            best = (score, q, pe, oe)
        if np.all(pe <= tol_pos) and np.all(oe <= tol_ori):
            break
    names = tuple(t.frame for t in targets)
    if best is None:
        nan = np.full(len(targets), np.inf)
        q = mech.assemble(qv0, qw0)
        return MultiFrameResult(q, qv0, qw0, Status.NOT_CONVERGED, names, nan, nan, np.inf,
                                iters, used, time.perf_counter() - t0)
    _, q, pe, oe = best
    phi = closure_jacobian(mech, forward_kinematics(mech, q[None]))[0]
    res = float(np.linalg.norm(phi)) if phi.size else 0.0
    reached = bool(np.all(pe <= tol_pos) and np.all(oe <= tol_ori)) and res < 1e-9
    return MultiFrameResult(q, q[P.iv], q[P.iw], Status.OK if reached else Status.NOT_CONVERGED,
                            names, pe, oe, res, iters, used, time.perf_counter() - t0)

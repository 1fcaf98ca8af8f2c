r"""Path inverse kinematics of a closed chain: in the independent joints, the loops closed.

Design
------
:class:`mechkin.solvers.track.path_ik.HandPathIK` continues ``q = f(r)`` along the hand's path by
Newton's method on the task coordinates (park Eq. (9)-(11)). For a closed chain the unknowns
are the independent joints ``q_v`` (kim1995 Eq. (3)); every evaluation closes the loops for the
dependent ones, ``phi_R(q_v, q_w) = 0`` (kim1995 Eq. (4), :func:`mechkin.model.closure.
solve_closure`), and the task Jacobian is the reduced one through the closure,

.. math:: J_r = J_E (L_v + L_w S), \qquad S = -\Phi_w^+ \Phi_v

(kim1995 Eq. (10), :func:`mechkin.model.reduced.reduced_jacobian`). :class:`ClosedHandPathIK`
is that subclass (any path geometry and orientation; :class:`ClosedHandLineIK` the line): it
hands the parent a view of the mechanism with the independent joints only
(so the continuation table, the rank, the redundancy and the branch signs are those of
``q_v``) and overrides the parent's kinematics hooks ``_poses``, ``_task`` and ``jacobian``.
The loops are closed from the nearest configuration already closed (first-order predictor
``q_w + S (q_v - q_v')``), so the assembly mode of the start is kept along the path.

To the DP it answers with **all** joints (``n_joints = mech.n``): ``q(r)`` assembled, and

.. math:: f'_w = S f'_v, \qquad f''_w = -\Phi_w^+(\Phi_v f''_v + \gamma(q, f'))

(the closure differentiated along r, :func:`mechkin.solvers.dynamics.closed_chain.closed_motion`),
which is what :class:`mechkin.solvers.dynamics.closed_chain.ClosedChainDynamics` takes; the joint
position limits of the passive joints are DP constraints like the others. A branch sign on a
dependent joint is checked on the assembled table.

Imports: numpy, model, solvers.path_ik, solvers.closed_dynamics.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.continuation import MAX_STEP as CONT_MAX_STEP
from mechkin.model.continuation import continue_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.model.reduced import reduced_jacobian
from mechkin.model.singularity import crossings_along
from mechkin.solvers.dynamics.closed_chain import closed_motion, sensitivity
from mechkin.solvers.track.path_geometry import LineGeometry, PathGeometry, SlerpOrientation
from mechkin.solvers.track.path_ik import (
    FD_F2,
    FD_F2_REDUNDANT,
    HandPathIK,
    PathIKError,
    left_jacobian_inverse,
)
from mechkin.spatial.rotations import rotation_log

__all__ = ["ClosedHandLineIK", "ClosedHandPathIK"]

#: Closed configurations kept as starting points of the loop closure.
MAX_ANCHORS = 4000
#: Loop closures remembered (the parent evaluates the same q several times in a row).
CLOSE_CACHE = 8


class _IndependentJoints:
    """The mechanism as the path IK's unknowns see it: its independent joints only (names,
    kinds, limits, home); everything else is the mechanism's."""

    def __init__(self, mech: Mechanism) -> None:
        iv = np.asarray(mech.independent)
        self._mech = mech
        self.n = len(iv)
        self.joint_names = tuple(mech.joint_names[i] for i in iv)
        self.s = np.asarray(mech.s)[iv]
        self.lower = np.asarray(mech.lower)[iv]
        self.upper = np.asarray(mech.upper)[iv]
        self.home = np.asarray(mech.home)[iv]

    def joint_unit(self, j: int) -> str:
        return "m" if self.s[j] == 1 else "rad"

    def joint_index(self, name: str) -> int:
        return self.joint_names.index(name)

    def __getattr__(self, key: str):
        return getattr(self._mech, key)


class ClosedHandPathIK(HandPathIK):
    """:class:`HandPathIK` of a closed chain, solved in the independent joints (module
    docstring): any path geometry (line, arc, spline) and orientation (held, slerped, free).

    Parameters are those of :class:`HandPathIK` with ``mech`` a closed chain, ``q0 (n,)`` all
    joints (the dependent ones are the first guess of the loop closure) and ``branch`` keyed by
    mechanism joint index (independent or dependent joints).

    Raises
    ------
    PathIKError
        ``start`` when the initial guess does not close the loops; otherwise as
        :class:`HandPathIK`.
    """

    #: one table point at a time (each continuation step adds an anchor of the loop closure)
    BLOCK = 1

    def __init__(self, mech: Mechanism, frame: int, geometry: PathGeometry, q0: np.ndarray,
                 tol: float, branch: dict[int, int] | None = None,
                 mask: Sequence[str] | None = None, tol_rot: float | None = None,
                 orientation: SlerpOrientation | None = None) -> None:
        if not len(mech.dependent):
            raise ValueError(f"{mech.name}: no dependent joints; use HandPathIK")
        self.closed_mech = mech
        self._iv = np.asarray(mech.independent)
        self._iw = np.asarray(mech.dependent)
        q0 = np.asarray(q0, dtype=float).reshape(mech.n)
        res = solve_closure(mech, q0[self._iv][None], q0[self._iw][None])
        if not res.ok[0]:
            raise PathIKError("start", "the initial guess does not close the loops "
                              f"({res.status[0].value}, residual {res.residual[0]:.3g}); "
                              "change ik.initial_guess")
        self._anchor_q = res.q.copy()
        self._anchor_S = sensitivity(mech, res.q)
        self._full_cache: tuple[bytes, np.ndarray] | None = None
        self._close_cache: dict = {}
        self._task_cache: dict = {}
        col = {int(j): k for k, j in enumerate(self._iv)}
        branch = branch or {}
        branch_v = {col[j]: s for j, s in branch.items() if j in col}
        branch_w = {j: s for j, s in branch.items() if j not in col}
        super().__init__(_IndependentJoints(mech), frame, geometry, q0[self._iv], tol, branch_v,
                         mask=mask, tol_rot=tol_rot, orientation=orientation)
        self.tab_full = self._close(self.tab)[0]
        if not np.all(np.isfinite(self.tab_full)):
            k = int(np.flatnonzero(~np.isfinite(self.tab_full).all(axis=1))[0])
            r = float(self.r_tab[k])
            raise PathIKError("path", f"the loops do not close near r = {r:.3g}", r=r,
                              point=self.hand(np.array([r]))[0])
        self._add_anchors(self.tab_full)
        for j, sgn in branch_w.items():
            name = mech.joint_names[j]
            qj = self.tab_full[:, j]
            if mech.s[j] == 0:
                qj = np.angle(np.exp(1j * qj))
            bad = np.flatnonzero((sgn * qj <= 0.0) & (self.r_tab >= 0.0) & (self.r_tab <= 1.0))
            if bad.size:
                k = int(bad[0])
                raise PathIKError(
                    "branch", f"{name} is not {'positive' if sgn > 0 else 'negative'} at r = "
                    f"{self.r_tab[k]:.3g} ({name} = {self.tab_full[k, j]:.6g} "
                    f"{mech.joint_unit(j)}); change ik.initial_guess to start on that branch",
                    joint=name)

    def singularities_crossed(self) -> int:
        """Constraint singularities the assembled path crosses on r in [0, 1]: sign changes of
        the orientation of the nondimensionalised ``dphi/dq_w`` between consecutive regular
        points of the continuation table (a change point such as a parallelogram folding flat;
        :func:`mechkin.model.singularity.crossings_along`)."""
        sel = (self.r_tab >= 0.0) & (self.r_tab <= 1.0)
        return int(crossings_along(self.closed_mech, self.tab_full[sel]).sum())

    # ---- loop closure -------------------------------------------------------------------------

    def _add_anchors(self, q: np.ndarray, S: np.ndarray | None = None) -> None:
        """Remember closed configurations (and their ``S``) as starts of the loop closure."""
        ok = np.isfinite(q).all(axis=1)
        if not ok.any() or self._anchor_q.shape[0] >= MAX_ANCHORS:
            return
        q = q[ok]
        S = sensitivity(self.closed_mech, q) if S is None else S[ok]
        self._anchor_q = np.vstack([self._anchor_q, q])
        self._anchor_S = np.concatenate([self._anchor_S, S])

    def _close_with_S(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Assembled ``q (m, n)``, the rows that closed and ``S = dq_w/dq_v (m, n_w, n_v)`` for
        ``q_v (m, n_v)`` (or ``q (m, n)`` already assembled, returned as given); rows that do
        not close are nan. Each batch of q_v starts from the nearest remembered configuration,
        moved to first order (``q_w + S (q_v - q_v')``)."""
        mech = self.closed_mech
        q = np.atleast_2d(np.asarray(q, dtype=float))
        key = (q.shape, q.tobytes())
        hit = self._close_cache.get(key)
        if hit is not None:
            return tuple(a.copy() for a in hit)
        nw, nv = len(self._iw), len(self._iv)
        S = np.full((q.shape[0], nw, nv), np.nan)
        if q.shape[1] == mech.n:
            out = q.copy()
        else:
            out = np.full((q.shape[0], mech.n), np.nan)
            fin = np.flatnonzero(np.isfinite(q).all(axis=1))
            if fin.size:
                qv = q[fin]
                av = self._anchor_q[:, self._iv]
                d = np.sum((qv[:, None, :] - av[None]) ** 2, axis=2)
                k = np.argmin(d, axis=1)
                guess = (self._anchor_q[k][:, self._iw]
                         + np.einsum("mwv,mv->mw", self._anchor_S[k], qv - av[k]))
                res = solve_closure(mech, qv, guess)
                out[fin[res.ok]] = res.q[res.ok]
                # far from every anchor, or lost: continuation from the nearest anchor, so the
                # answer stays on the anchors' assembly mode (mechkin.model.continuation)
                far = ~res.ok | (np.abs(qv - av[k]).max(axis=1) > 2 * CONT_MAX_STEP)
                if far.any():
                    rc = continue_closure(mech, qv[far], self._anchor_q[k[far]])
                    fi = fin[far]
                    out[fi] = np.nan
                    out[fi[rc.ok]] = rc.q[rc.ok]
        ok = np.isfinite(out).all(axis=1)
        if ok.any():
            S[ok] = sensitivity(mech, out[ok])
        if q.shape[0] == 1 and q.shape[1] != mech.n and ok.all():  # a continuation step
            self._add_anchors(out, S)
        if len(self._close_cache) >= CLOSE_CACHE:
            self._close_cache.pop(next(iter(self._close_cache)))
        self._close_cache[key] = (out, ok, S)
        return out.copy(), ok.copy(), S.copy()

    def _close(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Assembled ``q (m, n)`` and the rows that closed (:meth:`_close_with_S`)."""
        return self._close_with_S(q)[:2]

    # ---- the parent's kinematics hooks (independent joints in, reduced Jacobian out) ---------

    def _poses(self, q: np.ndarray) -> np.ndarray:
        mech = self.closed_mech
        qf, _ = self._close(q)
        return forward_kinematics(mech, qf).frames(mech, [self.f])[:, 0]

    def _task(self, q: np.ndarray, r: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hand poses (m, 4, 4), task coordinates x (m, 6) and the reduced task Jacobian
        (m, 6, n_v) (rows that do not close: x nan, Jacobian 0); the orientation relative to
        ``R*(r)`` (r only matters when the orientation varies)."""
        mech = self.closed_mech
        q = np.atleast_2d(np.asarray(q, dtype=float))
        varying = self._varying and r is not None
        key = (q.shape, q.tobytes(), None if not varying else np.asarray(r, float).tobytes())
        hit = self._task_cache.get(key)
        if hit is not None:
            return tuple(a.copy() for a in hit)
        qf, ok, S = self._close_with_S(q)
        m = qf.shape[0]
        T = np.full((m, 4, 4), np.nan)
        x = np.full((m, 6), np.nan)
        A = np.zeros((m, 6, self.n))
        if ok.any():
            kin = forward_kinematics(mech, qf[ok])
            Tk = kin.frames(mech, [self.f])[:, 0]
            J = reduced_jacobian(mech, qf[ok], self.f, kin=kin, S=S[ok])  # kim1995 Eq. (10)
            T[ok] = Tk
            x[ok, :3] = Tk[:, :3, 3]
            A[ok, :3] = J[:, 3:]
            if self.orientation_held:
                ref = (np.swapaxes(self._ref(np.broadcast_to(r, (m,))[ok]), 1, 2) if varying
                       else self.R0.T)
                phi = rotation_log(Tk[:, :3, :3] @ ref)
                x[ok, 3:] = phi
                A[ok, 3:] = left_jacobian_inverse(phi) @ J[:, :3]
            else:
                x[ok, 3:] = 0.0
                A[ok, 3:] = J[:, :3]
        if len(self._task_cache) >= CLOSE_CACHE:
            self._task_cache.pop(next(iter(self._task_cache)))
        self._task_cache[key] = (T, x, A)
        return T.copy(), x.copy(), A.copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Hand position Jacobian through the closure ``(m, 3, n_v)`` (kim1995 Eq. (10))."""
        qf, _ = self._close(q)
        return reduced_jacobian(self.closed_mech, qf, self.f)[:, 3:, :]

    # ---- JointPath: all joints ----------------------------------------------------------------

    @property
    def n_joints(self) -> int:
        """Number of joints n (all joints, assembled)."""
        return int(self.closed_mech.n)

    def q_independent(self, r: np.ndarray) -> np.ndarray:
        """``f_v(r) (m, n_v)``: the independent joints (the parent's joint map)."""
        return super().q(r)

    def q(self, r: np.ndarray) -> np.ndarray:
        """``f(r) (m, n)``: all joints, the loops closed (park Eq. (9))."""
        r = np.atleast_1d(np.asarray(r, dtype=float))
        key = r.tobytes()
        if self._full_cache is not None and self._full_cache[0] == key:
            return self._full_cache[1].copy()
        qf, ok = self._close(self.q_independent(r))
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise PathIKError("path", f"the loops do not close near r = {r[k]:.4g}",
                              r=float(r[k]), point=self.hand(r[k:k + 1])[0])
        self._full_cache = (key, qf)
        return qf.copy()

    def _derivatives(self, r: np.ndarray, second: bool):
        qf = self.q(r)
        qv = qf[:, self._iv]
        # a line with the orientation held or free: f'(q) only
        f1 = self.dq_of(qv) if self._const_rate else self.dq_of(qv, r)
        f2 = None
        if second:
            h = FD_F2_REDUNDANT if self.redundancy else FD_F2
            if self._const_rate:
                f2 = (self.dq_of(qv + h * f1) - self.dq_of(qv - h * f1)) / (2.0 * h)
            else:
                f2 = (self.dq_of(qv + h * f1, r + h) - self.dq_of(qv - h * f1, r - h)) / (2.0 * h)
        return qf, f1, f2

    def dq(self, r: np.ndarray) -> np.ndarray:
        """``df/dr (m, n)``: ``f'_v`` (park Eq. (10)) and ``f'_w = S f'_v``."""
        qf, f1, _ = self._derivatives(np.atleast_1d(np.asarray(r, dtype=float)), False)
        return closed_motion(self.closed_mech, qf, f1).qd

    def ddq(self, r: np.ndarray) -> np.ndarray:
        """``d2f/dr2 (m, n)``: ``f''_v`` (park Eq. (11), central difference of ``f'_v`` along
        ``f'_v``) and ``f''_w = -Phi_w^+ (Phi_v f''_v + gamma(q, f'))``."""
        qf, f1, f2 = self._derivatives(np.atleast_1d(np.asarray(r, dtype=float)), True)
        return closed_motion(self.closed_mech, qf, f1, f2).qdd


class ClosedHandLineIK(ClosedHandPathIK):
    """:class:`ClosedHandPathIK` on the straight line ``p0 -> p1`` (the signature of
    :class:`~mechkin.solvers.track.path_ik.HandLineIK`)."""

    def __init__(self, mech: Mechanism, frame: int, p0: np.ndarray, p1: np.ndarray,
                 q0: np.ndarray, tol: float, branch: dict[int, int] | None = None,
                 mask: Sequence[str] | None = None, tol_rot: float | None = None) -> None:
        super().__init__(mech, frame, LineGeometry(p0, p1), q0, tol, branch, mask, tol_rot)

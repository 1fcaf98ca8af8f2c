r"""Inverse kinematics of a hand frame along a straight line, on one branch (park Eq. (9)).

The hand moves on ``X_h(r) = p0 + r (p1 - p0)`` (park Eq. (7)). A table ``q(r)`` is built once
by continuation: each point's Newton-Raphson (pseudo-inverse steps, step length capped at
0.5 rad | m) starts from the previous point's solution, so the branch chosen at the start is
kept along the whole line. A batch of points is then solved by Newton-Raphson from the table
interpolated at their r. :class:`HandLineIK` is the ``ik`` / ``jacobian`` pair that
:class:`mechkin.solvers.path.IKLinePath` needs.

Failures raise :class:`PathIKError`, whose ``key`` says which part of the problem is at fault
(``start``: the start point is not reached from the initial guess; ``path``: the line leaves
the workspace or meets a singularity; ``branch``: a joint leaves its required sign); the task
turns it into a located ConfigError.

Imports: numpy, model.kinematics, errors.
"""

from __future__ import annotations

import numpy as np

from mechkin.errors import ConfigError
from mechkin.model.kinematics import forward_kinematics, frame_jacobian, frame_poses

#: Continuation table of the inverse kinematics: r from -IK_MARGIN to 1 + IK_MARGIN.
IK_MARGIN = 0.02
IK_STEP = 0.005
IK_MAX_ITER = 100
#: Largest joint change [rad | m] between two neighbouring table points (else: a jump).
IK_MAX_JUMP = 0.5


class PathIKError(ConfigError):
    """The path inverse kinematics failed; ``key`` is ``start``, ``path`` or ``branch``
    (``joint`` names the joint of a branch failure)."""

    def __init__(self, key: str, message: str, joint: str | None = None) -> None:
        super().__init__(message)
        self.key = key
        self.joint = joint
        self.message = message


class HandLineIK:
    """Position inverse kinematics of frame ``frame`` along the line ``p0 -> p1``, one branch.

    Parameters
    ----------
    mech : Mechanism
        An open chain (every joint independent).
    frame : int
        Index of the hand frame.
    p0, p1 : array (3,)
        Hand positions at ``r = 0`` and ``r = 1`` [m].
    q0 : array (n,)
        Initial guess of the start solution [rad | m].
    tol : float
        Position tolerance of Newton-Raphson [m].
    branch : dict, optional
        ``joint index -> +1 | -1``: the sign each named joint must keep on ``0 <= r <= 1``.

    Raises
    ------
    PathIKError
        The start point is not reached, the line leaves the workspace or meets a singularity,
        or a branch sign is violated.
    """

    def __init__(self, mech, frame: int, p0: np.ndarray, p1: np.ndarray, q0: np.ndarray,
                 tol: float, branch: dict[int, int] | None = None) -> None:
        self.mech, self.p0, self.p1 = mech, p0, p1
        self.dp = p1 - p0
        self.tol = tol
        self.f = int(frame)
        q_start, ok, err = self._newton(np.asarray(q0, dtype=float)[None, :], p0[None, :],
                                        IK_MAX_ITER)
        if not ok:
            raise PathIKError("start", f"the hand cannot reach {p0.tolist()} m from the initial "
                                       f"guess (error {err:.3g} m)")
        self.r_tab = np.arange(-IK_MARGIN, 1.0 + IK_MARGIN + IK_STEP / 2, IK_STEP)
        self.r_tab[np.argmin(np.abs(self.r_tab))] = 0.0
        i0 = int(np.argmin(np.abs(self.r_tab)))
        tab = np.empty((len(self.r_tab), mech.n))
        tab[i0] = q_start[0]
        for rng in (range(i0 + 1, len(self.r_tab)), range(i0 - 1, -1, -1)):
            prev = i0
            for i in rng:
                X = (p0 + self.r_tab[i] * self.dp)[None, :]
                q, ok, err = self._newton(tab[prev][None, :], X, IK_MAX_ITER)
                if not ok or np.max(np.abs(q[0] - tab[prev])) > IK_MAX_JUMP:
                    raise PathIKError(
                        "path", "the hand line leaves the reachable workspace or meets a "
                        f"singularity near r = {self.r_tab[i]:.3g} (point "
                        f"{np.round(X[0], 6).tolist()} m, IK error {err:.3g} m)")
                tab[i] = q[0]
                prev = i
        for j, s in (branch or {}).items():
            name = mech.joint_names[j]
            sign = "positive" if s > 0 else "negative"
            qj = np.angle(np.exp(1j * tab[:, j])) if mech.s[j] == 0 else tab[:, j]
            bad = np.flatnonzero(s * qj <= 0.0)
            inside = bad[(self.r_tab[bad] >= 0.0) & (self.r_tab[bad] <= 1.0)]
            if inside.size:
                k = int(inside[0])
                raise PathIKError(
                    "branch", f"{name} is not {sign} at r = {self.r_tab[k]:.3g} ({name} = "
                    f"{tab[k, j]:.6g} {mech.joint_unit(j)}); change ik.initial_guess to start "
                    "on that branch", joint=name)
        self.tab = tab

    def _pos(self, q: np.ndarray) -> np.ndarray:
        return frame_poses(self.mech, q, [self.f])[:, 0, :3, 3]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Hand position Jacobian ``(m, 3, n)``."""
        q = np.asarray(q, dtype=float)
        kin = forward_kinematics(self.mech, q)
        return frame_jacobian(self.mech, kin, self.f)[:, 3:, :]

    def _newton(self, q: np.ndarray, X: np.ndarray, max_iter: int
                ) -> tuple[np.ndarray, bool, float]:
        q = np.array(q, dtype=float)
        err = np.inf
        for _ in range(max_iter):
            e = X - self._pos(q)
            err = float(np.max(np.linalg.norm(e, axis=1)))
            if err <= self.tol:
                return q, True, err
            step = np.einsum("mij,mj->mi", np.linalg.pinv(self.jacobian(q)), e)
            big = np.max(np.abs(step), axis=1, keepdims=True)
            q = q + step * np.minimum(1.0, 0.5 / np.maximum(big, 1e-300))
        return q, err <= self.tol, err

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Joint values ``(m, n)`` at hand points ``X (m, 3)`` on the line (park Eq. (9))."""
        X = np.asarray(X, dtype=float)
        r = (X - self.p0) @ self.dp / float(self.dp @ self.dp)
        q0 = np.column_stack([np.interp(r, self.r_tab, self.tab[:, j])
                              for j in range(self.mech.n)])
        q, ok, err = self._newton(q0, X, 30)
        if not ok:
            raise ConfigError(f"track.path: inverse kinematics failed near r = "
                              f"{float(np.max(r)):.4g} (error {err:.3g} m)")
        return q

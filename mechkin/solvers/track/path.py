r"""Straight-line hand paths parameterised by a scalar r, and the dynamics along them (park §3.1).

The hand moves on the segment from ``p0`` to ``p1`` with fixed orientation (park Eq. (7)):

.. math:: X_h(r) = X_h(t_0) + r \, [X_h(t_r) - X_h(t_0)], \qquad 0 \le r \le 1

so the joints are functions of r alone, ``q = f(r)`` (Eq. (9)), and

.. math::

    \dot q = f'(r) \dot r \quad (10), \qquad
    \ddot q = f''(r) \dot r^2 + f'(r) \ddot r \quad (11), \qquad
    U = M f' \ddot r + M f'' \dot r^2 + h(q, f' \dot r) \quad (12).

Any object with the :class:`JointPath` methods can be used by the DP; two are provided:
:class:`PlanarTwoLinkLinePath` (analytic inverse kinematics of a planar 2R arm, park Table 1)
and :class:`IKLinePath` (any inverse-kinematics and Jacobian callables, e.g. from
``mechkin.model`` and the ik solver).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from mechkin.errors import SingularityError
from mechkin.solvers.dynamics.open_chain import InverseDynamics

#: Smallest |sin q2| accepted by the planar 2R inverse kinematics (stretched or folded arm).
SINGULAR_SIN_Q2 = 1e-9


@runtime_checkable
class JointPath(Protocol):
    """A hand path ``X_h(r)``, its joint map ``q = f(r)`` and two r-derivatives (park Eq. (9))."""

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        ...

    def hand(self, r: np.ndarray) -> np.ndarray:
        """Hand position ``X_h (m, d)`` for ``r (m,)`` (park Eq. (7))."""
        ...

    def q(self, r: np.ndarray) -> np.ndarray:
        """Joint values ``f(r) (m, n)`` (park Eq. (9))."""
        ...

    def dq(self, r: np.ndarray) -> np.ndarray:
        """First derivative ``df/dr (m, n)`` (park Eq. (10))."""
        ...

    def ddq(self, r: np.ndarray) -> np.ndarray:
        """Second derivative ``d2f/dr2 (m, n)`` (park Eq. (11))."""
        ...


def _check_point(p: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(p, dtype=np.float64)
    if a.ndim != 1 or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected a finite vector, got {p!r}")
    a.setflags(write=False)
    return a


def _as_r(r: np.ndarray | float) -> np.ndarray:
    return np.atleast_1d(np.asarray(r, dtype=np.float64))


@dataclass(frozen=True)
class PlanarTwoLinkLinePath:
    r"""Straight hand line for a planar 2R arm, with the analytic inverse kinematics.

    Forward kinematics ``x = l1 c1 + l2 c12``, ``y = l1 s1 + l2 s12``; the inverse takes the
    branch ``sign(q2) = elbow`` (park uses ``q2 > 0``, ``elbow = +1``):

    .. math::

        c_2 = \frac{x^2 + y^2 - l_1^2 - l_2^2}{2 l_1 l_2}, \quad
        q_2 = \mathrm{elbow} \cdot \arccos c_2, \quad
        q_1 = \operatorname{atan2}(y, x) - \operatorname{atan2}(l_2 s_2, l_1 + l_2 c_2).

    Derivatives from ``J(q) f' = p1 - p0`` and ``J f'' = -(dJ/dr) f'``: with ``w = f'_1 + f'_2``,
    ``J f'' = [l1 c1 f'_1^2 + l2 c12 w^2, l1 s1 f'_1^2 + l2 s12 w^2]``. For park's arm this is
    ``f' = (0.5 / s2) [c12, -c1 - c12]`` (Table 1, whose ``x_2`` is an OCR'd ``s_2``).

    Parameters
    ----------
    p0, p1 : array, shape (2,)
        Hand positions at ``r = 0`` and ``r = 1`` [m] (park Eq. (7)).
    l1, l2 : float
        Link lengths [m].
    elbow : {+1, -1}
        Sign of q2 on the chosen branch.

    References
    ----------
    park_conveyor_tracking_dp, Eq. (7), (9)-(11) and Table 1.
    """

    p0: np.ndarray
    p1: np.ndarray
    l1: float = 1.0
    l2: float = 1.0
    elbow: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "p0", _check_point(self.p0, "p0"))
        object.__setattr__(self, "p1", _check_point(self.p1, "p1"))
        if self.p0.shape != (2,) or self.p1.shape != (2,):
            raise ValueError(f"p0, p1: expected shape (2,), got {self.p0.shape}, {self.p1.shape}")
        if self.elbow not in (1, -1):
            raise ValueError(f"elbow: expected +1 or -1, got {self.elbow}")

    @property
    def n_joints(self) -> int:
        """Two joints."""
        return 2

    def hand(self, r: np.ndarray) -> np.ndarray:
        """``X_h(r) (m, 2)`` (park Eq. (7))."""
        return self.p0 + _as_r(r)[:, None] * (self.p1 - self.p0)

    def q(self, r: np.ndarray) -> np.ndarray:
        """``f(r) (m, 2)`` by the analytic inverse kinematics (park Eq. (9), Table 1).

        Raises
        ------
        SingularityError
            If a point is out of reach or on the stretched/folded boundary.
        """
        X = self.hand(r)
        x, y = X[:, 0], X[:, 1]
        c2 = (x**2 + y**2 - self.l1**2 - self.l2**2) / (2.0 * self.l1 * self.l2)
        s2sq = 1.0 - c2**2
        if np.any(s2sq < SINGULAR_SIN_Q2**2):
            k = int(np.argmin(s2sq))
            raise SingularityError(
                f"hand path: point {X[k].tolist()} (r = {_as_r(r)[k]:.6g}) is out of reach "
                "or on the workspace boundary of the 2-link arm"
            )
        s2 = self.elbow * np.sqrt(s2sq)
        q2 = np.arctan2(s2, c2)
        q1 = np.arctan2(y, x) - np.arctan2(self.l2 * s2, self.l1 + self.l2 * c2)
        return np.stack([q1, q2], axis=1)

    def _jac_parts(self, q: np.ndarray) -> tuple[np.ndarray, ...]:
        c1, s1 = np.cos(q[:, 0]), np.sin(q[:, 0])
        c12, s12 = np.cos(q[:, 0] + q[:, 1]), np.sin(q[:, 0] + q[:, 1])
        return c1, s1, c12, s12, np.sin(q[:, 1])

    def _solve_J(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``J(q)^{-1} v`` in closed form, ``det J = l1 l2 s2``."""
        c1, s1, c12, s12, s2 = self._jac_parts(q)
        det = self.l1 * self.l2 * s2
        out = np.empty_like(v)
        out[:, 0] = self.l2 * (c12 * v[:, 0] + s12 * v[:, 1]) / det
        out[:, 1] = (
            -(self.l1 * c1 + self.l2 * c12) * v[:, 0] - (self.l1 * s1 + self.l2 * s12) * v[:, 1]
        ) / det
        return out

    def dq(self, r: np.ndarray) -> np.ndarray:
        """``df/dr (m, 2) = J^{-1} (p1 - p0)`` (park Eq. (10), Table 1)."""
        q = self.q(r)
        dp = np.broadcast_to(self.p1 - self.p0, q.shape)
        return self._solve_J(q, dp)

    def ddq(self, r: np.ndarray) -> np.ndarray:
        """``d2f/dr2 (m, 2) = -J^{-1} (dJ/dr) f'`` (park Eq. (11), Table 1)."""
        q = self.q(r)
        f1 = self._solve_J(q, np.broadcast_to(self.p1 - self.p0, q.shape))
        c1, s1, c12, s12, _ = self._jac_parts(q)
        w2 = (f1[:, 0] + f1[:, 1]) ** 2
        rhs = np.stack(
            [
                self.l1 * c1 * f1[:, 0] ** 2 + self.l2 * c12 * w2,
                self.l1 * s1 * f1[:, 0] ** 2 + self.l2 * s12 * w2,
            ],
            axis=1,
        )
        return self._solve_J(q, rhs)


@dataclass(frozen=True)
class IKLinePath:
    r"""Straight hand line for any mechanism, given inverse-kinematics and Jacobian callables.

    ``q = ik(X_h)`` (park Eq. (9)); ``f' = J^+ (p1 - p0)`` with ``J = jacobian(q)`` the hand
    position Jacobian (least squares when J is not square or singular: a redundant arm gets
    the minimum-norm f', which is not the derivative of a posture-consistent f; for that use
    :class:`mechkin.solvers.track.path_ik.HandLineIK`); ``f''`` by a central difference of
    ``f'`` in r with step ``fd_step`` (the line extends past ``[0, 1]``, so the ends need no
    special case), which keeps the interface to two callables.

    Parameters
    ----------
    p0, p1 : array, shape (d,)
        Hand positions at ``r = 0`` and ``r = 1``.
    ik : callable
        ``ik(X (m, d)) -> q (m, n)``; must stay on one branch along the line.
    jacobian : callable
        ``jacobian(q (m, n)) -> J (m, d, n)``, ``dX_h = J dq``.
    n : int
        Number of joints.
    fd_step : float
        Step in r of the difference for ``f''``.
    """

    p0: np.ndarray
    p1: np.ndarray
    ik: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    n: int
    fd_step: float = field(default=1e-5)

    def __post_init__(self) -> None:
        object.__setattr__(self, "p0", _check_point(self.p0, "p0"))
        object.__setattr__(self, "p1", _check_point(self.p1, "p1"))
        if self.p0.shape != self.p1.shape:
            raise ValueError(f"p0, p1: shapes differ, {self.p0.shape} vs {self.p1.shape}")

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.n

    def hand(self, r: np.ndarray) -> np.ndarray:
        """``X_h(r) (m, d)`` (park Eq. (7))."""
        return self.p0 + _as_r(r)[:, None] * (self.p1 - self.p0)

    def q(self, r: np.ndarray) -> np.ndarray:
        """``f(r) (m, n)`` from the inverse-kinematics callable (park Eq. (9))."""
        return np.asarray(self.ik(self.hand(r)), dtype=np.float64).reshape(-1, self.n)

    def _dq_at(self, r: np.ndarray) -> np.ndarray:
        q = self.q(r)
        J = np.asarray(self.jacobian(q), dtype=np.float64)
        dp = np.broadcast_to(self.p1 - self.p0, (q.shape[0], self.p0.shape[0]))
        if J.shape[1] == J.shape[2]:
            try:
                return np.linalg.solve(J, dp[..., None])[..., 0]
            except np.linalg.LinAlgError:  # e.g. the zero z row of a planar 3R arm
                pass
        return np.einsum("mij,mj->mi", np.linalg.pinv(J), dp)

    def dq(self, r: np.ndarray) -> np.ndarray:
        """``df/dr (m, n) = J^+ (p1 - p0)`` (park Eq. (10))."""
        return self._dq_at(_as_r(r))

    def ddq(self, r: np.ndarray) -> np.ndarray:
        """``d2f/dr2 (m, n)`` by a central difference of ``df/dr`` (park Eq. (11))."""
        r = _as_r(r)
        h = self.fd_step
        return (self._dq_at(r + h) - self._dq_at(r - h)) / (2.0 * h)


@dataclass(frozen=True)
class PhaseCoefficients:
    r"""Torque along the path as a function of ``(r, r', r'')`` (park Eq. (12)), per grid point.

    .. math:: U = a(r) \ddot r + b(r) \dot r^2 + g(r)

    with ``a = M f'``, ``b = M f'' + C(q, f') f'`` (the velocity-quadratic part of h with
    ``qd = f'``) and ``g = h(q, 0)`` (gravity). This is park's ``[M f', M f'' + h]`` of Eq. (12)
    split by powers of r' (h is quadratic in qd); park Eq. (13)-(14) project it on ``M f'`` to get
    the scalar state equation, which the DP does not need because it checks every joint torque.

    Attributes
    ----------
    r : array, shape (K,)
    q, dq, ddq : array, shape (K, n)
        ``f``, ``f'``, ``f''`` (park Eq. (9)-(11)).
    a, b, g : array, shape (K, n)
    """

    r: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    a: np.ndarray
    b: np.ndarray
    g: np.ndarray

    def torque(self, rd: np.ndarray, rdd: np.ndarray) -> np.ndarray:
        """``U (K, n)`` for ``r' (K,)`` and ``r'' (K,)`` at the grid points (park Eq. (12))."""
        return self.a * rdd[:, None] + self.b * (rd**2)[:, None] + self.g


def phase_coefficients(
    dynamics: InverseDynamics, path: JointPath, r: np.ndarray
) -> PhaseCoefficients:
    """Evaluate park Eq. (12) coefficients at ``r (K,)`` with three inverse-dynamics calls.

    ``g = ID(q, 0, 0)``, ``a = ID(q, 0, f') - g``, ``b = ID(q, f', f'') - g``, because
    ``ID(q, f' s, f'' s^2 + f' u) = a u + b s^2 + g`` for any ``s = r'``, ``u = r''``.

    References
    ----------
    park_conveyor_tracking_dp, Eq. (8)-(12).
    """
    r = _as_r(r)
    q = path.q(r)
    f1 = path.dq(r)
    f2 = path.ddq(r)
    zero = np.zeros_like(q)
    g = dynamics.inverse_dynamics(q, zero, zero)
    a = dynamics.inverse_dynamics(q, zero, f1) - g  # park Eq. (12): M f'
    b = dynamics.inverse_dynamics(q, f1, f2) - g  # park Eq. (12): M f'' + h(q, f')
    return PhaseCoefficients(r=r, q=q, dq=f1, ddq=f2, a=a, b=b, g=g)


def path_torques(
    dynamics: InverseDynamics,
    path: JointPath,
    r: np.ndarray,
    rd: np.ndarray,
    rdd: np.ndarray,
) -> np.ndarray:
    """Joint torques ``U (m, n)`` along the path for ``r, r', r'' (m,)`` (park Eq. (12)).

    ``U = M(q) (f'' r'^2 + f' r'') + h(q, f' r')`` with ``q = f(r)`` (park Eq. (9)-(12)).
    """
    r = _as_r(r)
    rd = np.broadcast_to(np.asarray(rd, dtype=np.float64), r.shape)
    rdd = np.broadcast_to(np.asarray(rdd, dtype=np.float64), r.shape)
    q = path.q(r)
    f1 = path.dq(r)
    qd = f1 * rd[:, None]  # park Eq. (10)
    qdd = path.ddq(r) * (rd**2)[:, None] + f1 * rdd[:, None]  # park Eq. (11)
    return dynamics.inverse_dynamics(q, qd, qdd)  # park Eq. (8) -> (12)

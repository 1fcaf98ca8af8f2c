r"""Inverse kinematics of a hand frame along a path, on one branch (park Eq. (7), (9)-(11)).

The hand moves on a path ``p(r)`` of :mod:`mechkin.solvers.track.path_geometry` (a straight line
``p0 + r (p1 - p0)``, park Eq. (7); a circular arc; a C2 spline through via points; ``r`` the
normalised arc length) with its orientation held at the start orientation ``R0`` ("fixed
orientation", park §3.1), interpolated between given orientations ``R*(r)`` (slerp,
:class:`mechkin.solvers.track.path_geometry.SlerpOrientation`) or free. The task coordinates are the
components of

.. math:: x(q, r) = [\,p(q);\ \varphi(q, r)\,], \qquad \varphi = \log(R(q) R^*(r)^T)

that the ``mask`` selects (``x, y, z, rx, ry, rz``; rotation vector in the base frame;
``R^* = R_0`` when held), with the task Jacobian ``A = [J_v; J_l(\varphi)^{-1} J_\omega]``
(rows of the mask; ``J_l`` the left Jacobian of SO(3), the identity on the path, where
``\varphi = 0``).

**Joint map q = f(r)** (park Eq. (9)). With ``k`` task components of rank ``m`` and ``n``
joints, the redundancy is ``n - m``. ``f(r)`` is the solution of

.. math:: G(q, r) = A^+ (x^*(r) - x(q, r)) + N (q_s - q) = 0, \qquad N = I - A^+ A,

with ``x^*(r) = [p(r); 0]``: the task reached (first term) and, for a redundant arm, the
posture closest to the start solution ``q_s`` on the self-motion manifold (second term: the
null-space posture term). It is found by Newton's method on G, continued along a table
``r = -0.02 .. 1.02`` from the start solution (each point starts from the previous one, moved
along the tangent ``f'``), so the branch chosen at the start is kept; points between are solved
from the table interpolated at their r. ``A^+`` is the pseudo-inverse truncated at the task's
generic rank (zero rows such as z of a planar arm drop out).

**Derivatives** (park Eq. (10)-(11)), by the implicit function theorem on ``G = 0``:

.. math:: f' = (I - D)^{-1} (A^+ \dot x^* + D_r), \qquad
          D = \frac{\partial N}{\partial q}(q_s - q), \quad
          D_r = \frac{\partial N}{\partial r}(q_s - q), \qquad f'' = \frac{d}{dr} f'(f(r), r)

with the task velocity ``\dot x^* = [p'(r);\ J_l(\varphi)^{-1} E\, \omega^*(r)]`` (masked;
``E = R R^{*T}``, the identity on the path, where it is ``[p'; \omega^*]``; ``\omega^* = 0`` when
the orientation is held), from ``d\varphi/dr = J_l^{-1}(J_\omega f' - E \omega^*)``. ``D = 0``
without redundancy, where ``A f' = \dot x^*`` and, differentiated along the path,

.. math:: A f'' + \dot A f' = \ddot x^* = [p''(r);\ \omega^{*\prime}(r)]

(the path's curvature and the orientation's angular acceleration; for the line with the
orientation held the right side is 0: the hand does not accelerate along r nor turn). ``D`` is
a central difference of ``N`` over the joints; ``f''`` a central difference of the tangent field
``f'(q, r)`` along ``(f', 1)``, which is that total derivative. ``N`` depends on r only when
the orientation varies and the mask holds some but not all rotation rows (the span of all three
does not change with ``J_l^{-1}``); ``D_r`` is then a central difference in r, else 0.

Failures raise :class:`PathIKError`, whose ``key`` says which part of the problem is at fault
(``start``: the start pose is not reached from the initial guess; ``path``: the path leaves the
workspace or meets a singularity, the message names r and the point; ``branch``: a joint leaves
its required sign); the task turns it into a located ConfigError.

Overridable kinematics hooks (a closed-chain subclass replaces them): ``_poses(q)`` (hand poses)
and ``_task(q, r=None)`` / ``_task_jacobian(q, r=None)``; ``r`` is passed only when the
orientation varies along the path (slerp), so a subclass written for held orientations may keep
``_task_jacobian(q)``.

Imports: numpy, model.kinematics, spatial.rotations, solvers.track.path_geometry and
path_blocks, errors.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mechkin.errors import ConfigError
from mechkin.model.kinematics import forward_kinematics, frame_jacobian
from mechkin.solvers.track.path_blocks import continue_blocks, newton_rows
from mechkin.solvers.track.path_geometry import LineGeometry, PathGeometry, SlerpOrientation
from mechkin.spatial.rotations import rotation_log

#: Continuation table of the inverse kinematics: r from -IK_MARGIN to 1 + IK_MARGIN.
IK_MARGIN = 0.02
IK_STEP = 0.005
IK_MAX_ITER = 100
#: Largest joint change [rad | m] between two neighbouring table points (else: a jump).
IK_MAX_JUMP = 0.5
#: Singular values below RANK_RTOL * the largest do not count to the task's rank (at the start).
RANK_RTOL = 1e-9
#: Perturbed configurations that decide the task's generic rank.
RANK_SAMPLES = 6
#: Along the path, sigma_m / sigma_1 of the task Jacobian below this is a singularity.
SINGULAR_RTOL = 1e-7
#: Tolerance of the posture condition N (q_s - q) = 0 [rad | m].
NULL_TOL = 1e-10
#: Steps of the central differences: D over the joints, f'' along f'.
FD_D = 1e-6
FD_F2 = 1e-5
FD_F2_REDUNDANT = 1e-4
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")
#: Table points solved at once by the continuation (:meth:`HandPathIK._continue_blocks`).
IK_BLOCK = 16
#: Largest distance [rad | m] of a block's solution from its prediction along the tangent
#: (farther: the point is solved alone, from its neighbour).
BLOCK_DRIFT = 0.1


class PathIKError(ConfigError):
    """The path inverse kinematics failed; ``key`` is ``start``, ``path`` or ``branch``
    (``joint`` names the joint of a branch failure; ``r`` and ``point`` where it failed)."""

    def __init__(self, key: str, message: str, joint: str | None = None,
                 r: float | None = None, point: np.ndarray | None = None) -> None:
        super().__init__(message)
        self.key = key
        self.joint = joint
        self.message = message
        self.r = r
        self.point = point


def _skew(v: np.ndarray) -> np.ndarray:
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def left_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    r"""``J_l(phi)^{-1} (m, 3, 3)``: ``d phi / dt = J_l^{-1} omega`` for ``exp([phi]) = R R0^T``.

    ``J_l^{-1} = I - [phi]/2 + (1/t^2 - (1 + cos t) / (2 t sin t)) [phi]^2``, ``t = |phi|``
    (series ``1/12 + t^2/720`` near 0).
    """
    t = np.linalg.norm(phi, axis=-1)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    c = np.where(small, 1.0 / 12.0 + t * t / 720.0,
                 1.0 / ts**2 - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(ts)))
    S = _skew(phi)
    return np.eye(3) - 0.5 * S + c[..., None, None] * (S @ S)


class HandPathIK:
    """Inverse kinematics of frame ``frame`` along a path geometry, on one branch.

    Implements :class:`mechkin.solvers.track.path.JointPath` (``hand``, ``q``, ``dq``, ``ddq``).

    Parameters
    ----------
    mech : Mechanism
        An open chain (every joint independent).
    frame : int
        Index of the hand frame.
    geometry : PathGeometry
        The hand path ``p(r)`` (:mod:`mechkin.solvers.track.path_geometry`; r is the normalised arc
        length).
    q0 : array (n,)
        Initial guess of the start solution [rad | m]; the held orientation ``R0`` is the
        hand's orientation there unless ``orientation`` is given.
    tol : float
        Position tolerance [m].
    branch : dict, optional
        ``joint index -> +1 | -1``: the sign each named joint must keep on ``0 <= r <= 1``.
    mask : sequence of str, optional
        Task components (``x, y, z, rx, ry, rz``); default the position ``x, y, z``.
    tol_rot : float
        Orientation tolerance [rad] (default ``tol``).
    orientation : SlerpOrientation, optional
        The hand orientation ``R*(r)`` along the path (one keyframe: held at that orientation;
        several: interpolated; the mask's rotation rows are the components held to it).
        Default: held at the orientation of ``q0``.

    Raises
    ------
    PathIKError
        The start pose is not reached, the path leaves the workspace or meets a singularity,
        or a branch sign is violated.
    """

    #: Table points per continuation block (1: one at a time, from the previous point).
    BLOCK = IK_BLOCK

    def __init__(self, mech, frame: int, geometry: PathGeometry, q0: np.ndarray, tol: float,
                 branch: dict[int, int] | None = None, mask: Sequence[str] | None = None,
                 tol_rot: float | None = None,
                 orientation: SlerpOrientation | None = None) -> None:
        self.mech = mech
        self.geometry = geometry
        if geometry.straight:
            self.p0, self.p1, self.dp = geometry.p0, geometry.p1, geometry.dp
        else:
            self.p0, self.p1 = geometry.position(np.array([0.0, 1.0]))
            self.dp = self.p1 - self.p0
        self.tol = float(tol)
        self.tol_rot = float(tol if tol_rot is None else tol_rot)
        self.f = int(frame)
        self.n = int(mech.n)
        names = tuple(mask) if mask is not None else COMPONENTS[:3]
        bad = [c for c in names if c not in COMPONENTS]
        if bad or not names:
            raise ValueError(f"mask: expected components of {COMPONENTS}, got {list(names)}")
        self.mask = tuple(c for c in COMPONENTS if c in names)
        self.rows = np.array([COMPONENTS.index(c) for c in self.mask])
        self.pos_rows = np.flatnonzero(self.rows < 3)
        self.rot_rows = np.flatnonzero(self.rows >= 3)
        self.orientation_held = bool(self.rot_rows.size)
        self.orientation = orientation
        self._varying = bool(orientation is not None and orientation.varying)
        if orientation is not None and not self.orientation_held:
            raise ValueError("orientation: given, but the mask names no rotation component")
        #: a varying orientation with only some rotation rows: the null space turns with r
        self._partial_varying = bool(self._varying and self.rot_rows.size < 3)
        self.orientation_mode = ("free" if not self.orientation_held else
                                 "slerp" if self._varying else "fixed")
        #: constant task velocity (the line with a held orientation: the original solver)
        self._const_rate = bool(geometry.straight and not self._varying)
        q0 = np.asarray(q0, dtype=float)
        self.R0 = (self._poses(q0[None])[0, :3, :3] if orientation is None
                   else orientation.rotation(np.zeros(1))[0])
        xdot = np.zeros(6)
        xdot[:3] = self.dp
        self.xdot = xdot[self.rows]
        self._cache: tuple[bytes, np.ndarray] | None = None
        # the task's generic rank (largest over the guess and seeded perturbations of it: the
        # guess may be singular, e.g. a wrist at q5 = 0) fixes the pseudo-inverse's truncation
        rng = np.random.default_rng(0)
        qs = np.vstack([q0, q0 + rng.uniform(-0.3, 0.3, size=(RANK_SAMPLES, self.n))])
        s = np.linalg.svd(self._tj(qs, np.zeros(qs.shape[0])), compute_uv=False)
        tol_s = RANK_RTOL * np.maximum(s[:, :1], 1e-300)
        self.rank = int(np.max(np.sum(s > tol_s, axis=1)))
        self.redundancy = self.n - self.rank
        self.q_ref = q0.copy()
        noun = geometry.kind
        q_start, ok, err = self._newton(q0[None, :], np.zeros(1), IK_MAX_ITER)
        if not ok:
            what = ("" if not self.orientation_held else " with the initial orientation"
                    if orientation is None else " with the orientation given at r = 0")
            raise PathIKError("start", f"the hand cannot reach {self.p0.tolist()} m" + what
                              + f" from the initial guess (error {err:.3g})")
        self.q_ref = q_start[0].copy()  # the posture the null-space term keeps close to
        sig0 = self._sigma_ratio(q_start, np.zeros(1))[0]
        if sig0 < SINGULAR_RTOL:
            raise PathIKError("path", "the hand starts at a singularity, r = 0 (point "
                              f"{np.round(self.p0, 6).tolist()} m, sigma_min / sigma_max of the "
                              f"task Jacobian {sig0:.3g})", r=0.0, point=self.p0.copy())
        self.r_tab = np.arange(-IK_MARGIN, 1.0 + IK_MARGIN + IK_STEP / 2, IK_STEP)
        self.r_tab[np.argmin(np.abs(self.r_tab))] = 0.0
        i0 = int(np.argmin(np.abs(self.r_tab)))
        tab = np.empty((len(self.r_tab), self.n))
        tab[i0] = q_start[0]
        for idx in (range(i0 + 1, len(self.r_tab)), range(i0 - 1, -1, -1)):
            if self.BLOCK > 1 and not self.redundancy:  # redundant: the posture term's
                # tolerance (NULL_TOL) makes q(r) depend on the start at 1e-10: one at a time
                self._continue_blocks(tab, i0, list(idx), noun)
            else:
                prev = i0
                for i in idx:
                    self._step(tab, prev, i, noun)
                    prev = i
        for j, sgn in (branch or {}).items():
            name = mech.joint_names[j]
            sign = "positive" if sgn > 0 else "negative"
            qj = np.angle(np.exp(1j * tab[:, j])) if mech.s[j] == 0 else tab[:, j]
            bad_i = np.flatnonzero(sgn * qj <= 0.0)
            inside = bad_i[(self.r_tab[bad_i] >= 0.0) & (self.r_tab[bad_i] <= 1.0)]
            if inside.size:
                k = int(inside[0])
                raise PathIKError(
                    "branch", f"{name} is not {sign} at r = {self.r_tab[k]:.3g} ({name} = "
                    f"{tab[k, j]:.6g} {mech.joint_unit(j)}); change ik.initial_guess to start "
                    "on that branch", joint=name)
        self.tab = tab

    # ---- continuation along the table ---------------------------------------------------------

    def _step(self, tab: np.ndarray, prev: int, i: int, noun: str) -> None:
        """Solve table point ``i`` from its solved neighbour ``prev``: an Euler predictor along
        the tangent f' (Eq. (10)), then Newton's corrector; raises :class:`PathIKError` where
        the path leaves the workspace, jumps or meets a singularity."""
        r = self.r_tab[i]
        r_prev = self.r_tab[prev:prev + 1]
        guess = tab[prev] + (r - self.r_tab[prev]) * self.dq_of(tab[prev][None, :], r_prev)[0]
        if not np.all(np.isfinite(guess)):
            guess = tab[prev]
        q, ok, err = self._newton(guess[None, :], np.array([r]), IK_MAX_ITER)
        point = np.round(self.geometry.position(np.array([r]))[0], 6).tolist()
        if not ok or np.max(np.abs(q[0] - tab[prev])) > IK_MAX_JUMP:
            raise PathIKError(
                "path", f"the hand {noun} leaves the reachable workspace or meets a "
                f"singularity near r = {r:.3g} (point {point} m, IK error {err:.3g})",
                r=float(r), point=np.asarray(point))
        sig = self._sigma_ratio(q, np.array([r]))[0]
        if sig < SINGULAR_RTOL:
            raise PathIKError(
                "path", f"the hand {noun} meets a singularity near r = {r:.3g} (point "
                f"{point} m, sigma_min / sigma_max of the task Jacobian {sig:.3g})",
                r=float(r), point=np.asarray(point))
        tab[i] = q[0]

    def _continue_blocks(self, tab: np.ndarray, i0: int, idx: list[int], noun: str) -> None:
        """Continuation in blocks (:func:`mechkin.solvers.track.path_blocks.continue_blocks`),
        falling back to :meth:`_step` at a point a block does not pass."""
        continue_blocks(self, tab, i0, idx, lambda prev, i: self._step(tab, prev, i, noun),
                        max_iter=IK_MAX_ITER, max_jump=IK_MAX_JUMP, drift=BLOCK_DRIFT,
                        singular_rtol=SINGULAR_RTOL, null_tol=NULL_TOL)

    def _newton_rows(self, q: np.ndarray, r: np.ndarray, max_iter: int):
        """Row-by-row Newton (:func:`mechkin.solvers.track.path_blocks.newton_rows`)."""
        return newton_rows(self, q, r, max_iter, NULL_TOL)

    # ---- kinematics of the task ---------------------------------------------------------------

    def _poses(self, q: np.ndarray) -> np.ndarray:
        return forward_kinematics(self.mech, q).frames(self.mech, [self.f])[:, 0]

    def _ref(self, r: np.ndarray) -> np.ndarray:
        """Target orientations ``R*(r) (m, 3, 3)`` (the held ``R0`` broadcast when fixed)."""
        if self._varying:
            return self.orientation.rotation(r)
        return np.broadcast_to(self.R0, (np.size(r), 3, 3))

    def _task(self, q: np.ndarray, r: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hand poses (m, 4, 4), task coordinates x (m, 6) and task Jacobian (m, 6, n) (the
        orientation relative to ``R*(r)``; r only matters when the orientation varies)."""
        kin = forward_kinematics(self.mech, q)
        T = kin.frames(self.mech, [self.f])[:, 0]
        J = frame_jacobian(self.mech, kin, self.f)  # rows (omega, v)
        x = np.empty((q.shape[0], 6))
        x[:, :3] = T[:, :3, 3]
        A = np.empty((q.shape[0], 6, self.n))
        A[:, :3] = J[:, 3:]
        if self.orientation_held:
            if self._varying:
                phi = rotation_log(T[:, :3, :3] @ np.swapaxes(self._ref(r), 1, 2))
            else:
                phi = rotation_log(T[:, :3, :3] @ self.R0.T)
            x[:, 3:] = phi
            A[:, 3:] = left_jacobian_inverse(phi) @ J[:, :3]
        else:
            x[:, 3:] = 0.0
            A[:, 3:] = J[:, :3]
        return T, x, A

    def _task_jacobian(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        return self._task(q, r)[2][:, self.rows]

    def _tk(self, q: np.ndarray, r: np.ndarray):
        """``_task`` with r passed only when the orientation varies (subclass hooks)."""
        return self._task(q, r) if self._varying else self._task(q)

    def _tj(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        return self._task_jacobian(q, r) if self._varying else self._task_jacobian(q)

    def target(self, r: np.ndarray) -> np.ndarray:
        """Task coordinates ``x*(r) (m, k)``: the path's point and zero orientation error."""
        x = np.zeros((np.size(r), 6))
        x[:, :3] = self.geometry.position(np.asarray(r, dtype=float))
        return x[:, self.rows]

    def _task_velocity(self, q: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Task Jacobian ``A (m, k, n)`` and task velocity ``xdot* (m, k)`` at ``(q, r)``:
        ``[p'(r); J_l(phi)^{-1} E omega*(r)]`` (module docstring)."""
        b = np.zeros((q.shape[0], 6))
        b[:, :3] = self.geometry.d1(r)
        if self._varying:
            T, x, A = self._task(q, r)
            A = A[:, self.rows]
            E = T[:, :3, :3] @ np.swapaxes(self._ref(r), 1, 2)
            w = np.einsum("mij,mj->mi", E, self.orientation.omega(r))
            b[:, 3:] = np.einsum("mij,mj->mi", left_jacobian_inverse(x[:, 3:]), w)
        else:
            A = self._task_jacobian(q)
        return A, b[:, self.rows]

    def _pinv(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pseudo-inverse truncated at the task's rank (m, n, k), null projector (m, n, n) and
        sigma_rank / sigma_1 (m,)."""
        U, s, Vt = np.linalg.svd(A, full_matrices=False)
        m = self.rank
        Ur, sr, Vr = U[:, :, :m], s[:, :m], np.swapaxes(Vt[:, :m, :], 1, 2)
        with np.errstate(divide="ignore"):
            inv = np.where(sr > 0.0, 1.0 / sr, 0.0)
        P = (Vr * inv[:, None, :]) @ np.swapaxes(Ur, 1, 2)
        N = np.eye(self.n) - Vr @ np.swapaxes(Vr, 1, 2)
        ratio = sr[:, -1] / np.maximum(s[:, 0], 1e-300) if m else np.ones(A.shape[0])
        return P, N, ratio

    def _sigma_ratio(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        return self._pinv(self._tj(q, r))[2]

    def _null(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        return self._pinv(self._tj(q, r))[1]

    def _D(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        """``D = dN/dq (q_s - q)`` (m, n, n) by central differences over the joints."""
        m, n = q.shape
        h = FD_D
        E = np.eye(n) * h
        qq = np.concatenate([(q[:, None, :] + E[None]).reshape(-1, n),
                             (q[:, None, :] - E[None]).reshape(-1, n)])
        rr = np.tile(np.repeat(np.broadcast_to(np.asarray(r, dtype=float), (m,)), n), 2)
        Nq = self._null(qq, rr).reshape(2, m, n, n, n)  # [+/-, m, k, :, :]
        w = self.q_ref - q
        dN = (Nq[0] - Nq[1]) / (2.0 * h)  # (m, k, n, n): dN/dq_k
        return np.einsum("mkij,mj->mik", dN, w)

    def _D_r(self, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        """``D_r = dN/dr (q_s - q)`` (m, n) by a central difference in r (a varying orientation
        with only some rotation rows: N turns with R*(r))."""
        h = FD_D
        dN = (self._null(q, r + h) - self._null(q, r - h)) / (2.0 * h)
        return np.einsum("mij,mj->mi", dN, self.q_ref - q)

    def _residual(self, q: np.ndarray, r: np.ndarray):
        _, x, A = self._tk(q, r)
        e = self.target(r) - x[:, self.rows]
        P, N, ratio = self._pinv(A[:, self.rows])
        g = np.einsum("mij,mj->mi", N, self.q_ref - q) if self.redundancy else None
        return e, P, g, ratio

    def _errors(self, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pos = np.linalg.norm(e[:, self.pos_rows], axis=1) if self.pos_rows.size else \
            np.zeros(e.shape[0])
        rot = np.linalg.norm(e[:, self.rot_rows], axis=1) if self.rot_rows.size else \
            np.zeros(e.shape[0])
        return pos, rot

    def _newton(self, q: np.ndarray, r: np.ndarray, max_iter: int
                ) -> tuple[np.ndarray, bool, float]:
        """Newton's method on ``G(q, r) = 0`` (module docstring) from ``q (m, n)``; returns
        q, whether every point converged, and the largest task error."""
        q = np.array(q, dtype=float)
        err = np.inf
        for _ in range(max_iter):
            e, P, g, _ = self._residual(q, r)
            pos, rot = self._errors(e)
            err = float(max(np.max(pos), np.max(rot)))
            null = 0.0 if g is None else float(np.max(np.abs(g)))
            if np.all(pos <= self.tol) and np.all(rot <= self.tol_rot) and null <= NULL_TOL:
                return q, True, err
            step = np.einsum("mij,mj->mi", P, e)
            if g is not None:
                M = np.eye(self.n) - self._D(q, r)
                step = np.linalg.solve(M, (step + g)[..., None])[..., 0]
            big = np.max(np.abs(step), axis=1, keepdims=True)
            q = q + step * np.minimum(1.0, 0.5 / np.maximum(big, 1e-300))
        null = 0.0 if g is None else float(np.max(np.abs(g)))
        ok = bool(np.all(pos <= self.tol) and np.all(rot <= self.tol_rot) and null <= NULL_TOL)
        return q, ok, err

    # ---- JointPath ----------------------------------------------------------------------------

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.n

    def hand(self, r: np.ndarray) -> np.ndarray:
        """Hand position ``X_h(r) (m, 3)`` (park Eq. (7) for the line)."""
        return self.geometry.position(np.atleast_1d(np.asarray(r, dtype=float)))

    def q(self, r: np.ndarray) -> np.ndarray:
        """``f(r) (m, n)`` (park Eq. (9)): Newton from the table interpolated at r."""
        r = np.atleast_1d(np.asarray(r, dtype=float))
        key = r.tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1].copy()
        q0 = np.column_stack([np.interp(r, self.r_tab, self.tab[:, j]) for j in range(self.n)])
        q, ok, err = self._newton(q0, r, 30)
        if not ok:
            raise ConfigError(f"track.path: inverse kinematics failed near r = "
                              f"{float(np.max(r)):.4g} (error {err:.3g} m)")
        self._cache = (key, q)
        return q.copy()

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Joint values ``(m, n)`` at hand points ``X (m, 3)`` on the path (park Eq. (9))."""
        X = np.asarray(X, dtype=float)
        if self.geometry.straight:
            return self.q((X - self.p0) @ self.dp / float(self.dp @ self.dp))
        return self.q(self.geometry.project(X))

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Hand position Jacobian ``(m, 3, n)``."""
        kin = forward_kinematics(self.mech, np.asarray(q, dtype=float))
        return frame_jacobian(self.mech, kin, self.f)[:, 3:, :]

    def dq_of(self, q: np.ndarray, r: np.ndarray | None = None) -> np.ndarray:
        """``f'`` as a function of the configuration (and of r, unless the path is a line with
        the orientation held), ``(I - D)^{-1} A^+ xdot*`` (m, n)."""
        if self._const_rate:
            P, _, _ = self._pinv(self._task_jacobian(q))
            v = np.einsum("mij,j->mi", P, self.xdot)
        else:
            if r is None:
                raise ValueError("dq_of: r is needed on a curved path or a varying orientation")
            r = np.broadcast_to(np.asarray(r, dtype=float), (q.shape[0],))
            A, b = self._task_velocity(q, r)
            P, _, _ = self._pinv(A)
            v = np.einsum("mij,mj->mi", P, b)
        if self.redundancy:
            if self._partial_varying:
                v = v + self._D_r(q, r)
            M = np.eye(self.n) - self._D(q, r)
            v = np.linalg.solve(M, v[..., None])[..., 0]
        return v

    def dq(self, r: np.ndarray) -> np.ndarray:
        """``df/dr (m, n)`` (park Eq. (10)), module docstring."""
        r = np.atleast_1d(np.asarray(r, dtype=float))
        return self.dq_of(self.q(r), r)

    def ddq(self, r: np.ndarray) -> np.ndarray:
        """``d2f/dr2 (m, n)`` (park Eq. (11)): central difference of the tangent field
        ``f'(q, r)`` along ``(f', 1)`` (module docstring)."""
        r = np.atleast_1d(np.asarray(r, dtype=float))
        q = self.q(r)
        f1 = self.dq_of(q, r)
        h = FD_F2_REDUNDANT if self.redundancy else FD_F2
        if self._const_rate:
            return (self.dq_of(q + h * f1) - self.dq_of(q - h * f1)) / (2.0 * h)
        return (self.dq_of(q + h * f1, r + h) - self.dq_of(q - h * f1, r - h)) / (2.0 * h)

    # ---- verification -------------------------------------------------------------------------

    def pose_errors(self, q: np.ndarray, r: np.ndarray) -> dict[str, float]:
        """Largest errors of configurations ``q (m, n)`` at path parameters ``r (m,)`` by
        forward kinematics: distance from the path point (held position components) [m],
        angle of the held orientation components from ``R*(r)`` [rad] (None when free), and
        the largest rotation of the hand from the start orientation ``R0`` [rad]."""
        T = self._poses(np.asarray(q, dtype=float))
        r = np.atleast_1d(np.asarray(r, dtype=float))
        p = self.hand(r)
        pos_idx = self.rows[self.pos_rows]
        pos = np.linalg.norm((T[:, :3, 3] - p)[:, pos_idx], axis=1)
        phi = rotation_log(T[:, :3, :3] @ self.R0.T)
        err = (rotation_log(T[:, :3, :3] @ np.swapaxes(self._ref(r), 1, 2)) if self._varying
               else phi)
        rot_idx = self.rows[self.rot_rows] - 3
        return {
            "max_position_error_m": float(np.max(pos, initial=0.0)),
            "max_orientation_error_rad": (float(np.max(np.linalg.norm(err[:, rot_idx], axis=1)))
                                          if self.orientation_held else None),
            "max_rotation_from_start_rad": float(np.max(np.linalg.norm(phi, axis=1))),
        }


class HandLineIK(HandPathIK):
    """:class:`HandPathIK` on the straight line ``p0 -> p1`` (park Eq. (7)), with the
    orientation held at that of ``q0`` or free (the original signature).

    Parameters
    ----------
    mech, frame, q0, tol, branch, mask, tol_rot
        As for :class:`HandPathIK`.
    p0, p1 : array (3,)
        Hand positions at ``r = 0`` and ``r = 1`` [m].
    """

    def __init__(self, mech, frame: int, p0: np.ndarray, p1: np.ndarray, q0: np.ndarray,
                 tol: float, branch: dict[int, int] | None = None,
                 mask: Sequence[str] | None = None, tol_rot: float | None = None) -> None:
        super().__init__(mech, frame, LineGeometry(p0, p1), q0, tol, branch, mask, tol_rot)

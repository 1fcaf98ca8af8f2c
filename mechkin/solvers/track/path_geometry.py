r"""Hand path geometry for ``mechkin track``: position ``p(r)`` and orientation ``R*(r)`` on
``0 <= r <= 1``, with their first two r-derivatives (the task-space terms of park Eq. (9)-(11)).

Every curve is parametrised by **normalised arc length**: ``r = s / L`` with ``L`` the arc
length of the path, so ``|p'(r)| = L`` everywhere and the part on the belt, whose position is
its arc length along the path, moves with a constant ``r' = v / L`` (park Eq. (16)-(17)).

* :class:`LineGeometry` -- ``p(r) = p0 + r (p1 - p0)`` (park Eq. (7)); bit-identical to the
  straight line mechkin has always tracked.
* :class:`ArcGeometry` -- the circle through three points ``start, via, end``, travelled from
  ``start`` through ``via`` to ``end``: centre ``c``, radius ``rho``, in-plane basis
  ``e1 = (start - c) / rho``, ``e2 = n x e1`` with ``n`` the unit normal of
  ``(via - start) x (end - start)``; swept angle ``Theta`` in ``(0, 2 pi)``,

  .. math:: p(r) = c + \rho (\cos\Theta r\, e_1 + \sin\Theta r\, e_2), \quad
            p' = \rho\Theta(-\sin\Theta r\, e_1 + \cos\Theta r\, e_2), \quad
            p'' = -\Theta^2 (p - c).

  Outside ``[0, 1]`` the circle continues.
* :class:`SplineGeometry` -- a C2 cubic spline through via points ``P_0 .. P_k``: a natural
  ``scipy.interpolate.CubicSpline`` ``P(u)`` on the chord-length parameter ``u``, then
  re-parametrised by arc length, ``s(u) = \int_0^u |P'(w)| dw`` (Gauss-Legendre quadrature,
  inverted by Newton's method to rounding error), so that with ``t = P' / |P'|``

  .. math:: p'(r) = L\, t, \qquad p''(r) = L^2 \, \frac{P'' - t\,(t \cdot P'')}{|P'|^2}.

  ``p`` is C2 in r (``P`` is C2 in u and ``du/ds = 1 / |P'| > 0`` is C1). The natural end
  conditions ``P'' = 0`` make the curvature zero at the ends, so the path continues outside
  ``[0, 1]`` along its end tangents with ``p'' = 0``, still C2.

Orientation (:class:`SlerpOrientation`): keyframe rotations ``R_i`` at ``r_i``; between two
keyframes the geodesic (slerp, ``scipy.spatial.transform.Slerp``)

.. math:: R^*(r) = \exp([\sigma(\tau) v_i]) R_i, \quad v_i = \log(R_{i+1} R_i^T), \quad
          \tau = \frac{r - r_i}{r_{i+1} - r_i},

with ``sigma(tau) = tau`` (``blend: linear``, constant angular rate) or
``sigma = 10 tau^3 - 15 tau^4 + 6 tau^5`` (``blend: smooth``: zero rate and acceleration at every
keyframe, so the angular velocity is continuous across via points; with ``linear`` it jumps
at an interior keyframe). Outside the keyframes ``linear`` continues the end geodesics and
``smooth`` holds the end orientations. Its angular velocity and
acceleration per unit r, in the base frame: ``omega(r) = sigma'(tau) v_i / dr_i`` and
``omega'(r) = sigma''(tau) v_i / dr_i^2``. One keyframe holds that orientation.

Imports: numpy, scipy, errors, spatial.rotations.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from mechkin.errors import ConfigError
from mechkin.spatial.rotations import rotation_log

#: Part on a curved path: largest distance of ``part_start`` from the path and of the belt
#: velocity from the path's tangent, relative to max(L, 1) [m] and |v| [m/s].
ON_PATH_RTOL = 1e-6
#: Gauss-Legendre nodes per sub-interval and sub-intervals per spline piece (arc length).
_GL_NODES = 16
_GL_SPLIT = 8
_GL_X, _GL_W = np.polynomial.legendre.leggauss(_GL_NODES)


def _as_r(r) -> np.ndarray:
    return np.atleast_1d(np.asarray(r, dtype=float))


class PathGeometry:
    """Base class: a hand path ``p(r)`` parametrised by normalised arc length.

    Attributes
    ----------
    kind : str
        ``line``, ``arc`` or ``spline``.
    straight : bool
        Whether the path is a straight line (the conveyor then uses park Eq. (17) as is).
    arc_length : float
        Length ``L`` of the path from ``r = 0`` to ``r = 1`` [m].
    """

    kind = "path"
    straight = False
    arc_length: float

    def position(self, r) -> np.ndarray:
        """``p(r) (m, 3)`` [m]."""
        raise NotImplementedError

    def d1(self, r) -> np.ndarray:
        """``p'(r) (m, 3)`` [m]: ``|p'| = L``."""
        raise NotImplementedError

    def d2(self, r) -> np.ndarray:
        """``p''(r) (m, 3)`` [m]: ``L^2`` times the curvature vector."""
        raise NotImplementedError

    def tangent(self, r) -> np.ndarray:
        """Unit tangent ``p' / |p'| (m, 3)``."""
        d = self.d1(r)
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def project(self, X) -> np.ndarray:
        """Path parameter ``r (m,)`` of the path point (the path continued beyond its ends)
        nearest to each point ``X (m, 3)``."""
        raise NotImplementedError

    def summary(self) -> dict:
        """The geometry for summary.json (SI)."""
        return {"type": self.kind, "length_m": float(self.arc_length)}

    def conveyor_phase(self, part_start: np.ndarray, belt_velocity: np.ndarray
                       ) -> tuple[float, float]:
        """``(r0, rd)``: the part's path parameter at t = 0 and its constant rate (park Eq.
        (16)-(17) with arc length): ``r0 = project(part_start)``, ``rd = v . t(r0) / L``.

        Raises
        ------
        ConfigError
            The part does not start on the path (or its continuation), the belt velocity is
            not along the path's tangent there, or it carries the part backwards.
        """
        x = np.zeros(3)
        v = np.zeros(3)
        x[: len(part_start)] = part_start
        v[: len(belt_velocity)] = belt_velocity
        r0 = float(self.project(x[None])[0])
        p = self.position(np.array([r0]))[0]
        t = self.tangent(np.array([r0]))[0]
        L = float(self.arc_length)
        speed = float(v @ t)
        off_p = float(np.linalg.norm(x - p))
        off_v = float(np.linalg.norm(v - speed * t))
        if off_p > ON_PATH_RTOL * max(L, 1.0):
            raise ConfigError(
                f"conveyor: the part starts {off_p:.3g} m off the hand's {self.kind} (nearest "
                f"path point {np.round(p, 6).tolist()} m at r = {r0:.6g}); on a curved path the "
                "part moves along the path, so part_start must lie on it")
        if off_v > ON_PATH_RTOL * max(float(np.linalg.norm(v)), 1e-300):
            raise ConfigError(
                f"conveyor: the belt velocity is not along the hand's {self.kind} at the part's "
                f"start (r = {r0:.6g}, unit tangent {np.round(t, 9).tolist()}; off by "
                f"{off_v:.3g} m/s): give belt_velocity = speed x that tangent")
        rd = speed / L
        if rd <= 0.0:
            raise ConfigError(
                f"conveyor: the belt moves the part away from the path's end (r' = {rd:.3g} /s)")
        return r0, rd


class LineGeometry(PathGeometry):
    """Straight line ``p(r) = p0 + r (p1 - p0)`` (park Eq. (7))."""

    kind = "line"
    straight = True

    def __init__(self, p0, p1) -> None:
        self.p0 = np.asarray(p0, dtype=float)
        self.p1 = np.asarray(p1, dtype=float)
        self.dp = self.p1 - self.p0
        self.arc_length = float(np.linalg.norm(self.dp))
        if not self.arc_length > 0.0:
            raise ValueError("line: start and end are the same point")

    def position(self, r) -> np.ndarray:
        return self.p0 + _as_r(r)[:, None] * self.dp

    def d1(self, r) -> np.ndarray:
        return np.broadcast_to(self.dp, (_as_r(r).size, 3)).copy()

    def d2(self, r) -> np.ndarray:
        return np.zeros((_as_r(r).size, 3))

    def project(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return (X - self.p0) @ self.dp / float(self.dp @ self.dp)

    def summary(self) -> dict:
        return {"type": "line", "start_m": self.p0.tolist(), "end_m": self.p1.tolist(),
                "length_m": self.arc_length}


def circumcircle(a, b, c) -> tuple[np.ndarray, float, np.ndarray]:
    """Centre, radius and unit normal (of ``(b - a) x (c - a)``) of the circle through three
    points; ValueError when they are (nearly) collinear."""
    a, b, c = (np.asarray(x, dtype=float) for x in (a, b, c))
    u, v = b - a, c - a
    w = np.cross(u, v)
    ww = float(w @ w)
    scale = max(float(u @ u), float(v @ v))
    if ww <= (1e-9 * scale) ** 2 or scale == 0.0:
        raise ValueError("arc: start, via and end are collinear (or coincide); use a line")
    x = (float(u @ u) * np.cross(v, w) + float(v @ v) * np.cross(w, u)) / (2.0 * ww)
    return a + x, float(np.linalg.norm(x)), w / np.sqrt(ww)


class ArcGeometry(PathGeometry):
    """Circular arc through ``start``, ``via`` and ``end`` (module docstring)."""

    kind = "arc"

    def __init__(self, start, via, end) -> None:
        self.start = np.asarray(start, dtype=float)
        self.via = np.asarray(via, dtype=float)
        self.end = np.asarray(end, dtype=float)
        self.centre, self.radius, self.normal = circumcircle(self.start, self.via, self.end)
        self.e1 = (self.start - self.centre) / self.radius
        self.e2 = np.cross(self.normal, self.e1)
        d = self.end - self.centre
        # a, b, c counter-clockwise about n = (b - a) x (c - a): the sweep start -> via -> end
        self.angle = float(np.arctan2(d @ self.e2, d @ self.e1)) % (2.0 * np.pi)
        self.arc_length = self.radius * self.angle

    def _cs(self, r):
        th = self.angle * _as_r(r)
        return np.cos(th)[:, None], np.sin(th)[:, None]

    def position(self, r) -> np.ndarray:
        c, s = self._cs(r)
        return self.centre + self.radius * (c * self.e1 + s * self.e2)

    def d1(self, r) -> np.ndarray:
        c, s = self._cs(r)
        return self.radius * self.angle * (-s * self.e1 + c * self.e2)

    def d2(self, r) -> np.ndarray:
        c, s = self._cs(r)
        return -self.radius * self.angle**2 * (c * self.e1 + s * self.e2)

    def project(self, X) -> np.ndarray:
        d = np.atleast_2d(np.asarray(X, dtype=float)) - self.centre
        th = np.arctan2(d @ self.e2, d @ self.e1)
        lo = 0.5 * self.angle - np.pi  # representative angle nearest to the arc's middle
        th = lo + np.mod(th - lo, 2.0 * np.pi)
        return th / self.angle

    def summary(self) -> dict:
        return {"type": "arc", "start_m": self.start.tolist(), "via_m": self.via.tolist(),
                "end_m": self.end.tolist(), "length_m": float(self.arc_length),
                "centre_m": self.centre.tolist(), "radius_m": self.radius,
                "normal": self.normal.tolist(), "angle_deg": float(np.degrees(self.angle))}


class SplineGeometry(PathGeometry):
    """C2 cubic spline through via points, parametrised by arc length (module docstring)."""

    kind = "spline"

    def __init__(self, points) -> None:
        P = np.asarray(points, dtype=float)
        if P.ndim != 2 or P.shape[0] < 3 or P.shape[1] != 3:
            raise ValueError("spline: expected at least 3 points of 3 coordinates")
        chord = np.linalg.norm(np.diff(P, axis=0), axis=1)
        if np.any(chord <= 1e-12 * max(float(np.max(chord)), 1e-300)):
            i = int(np.argmin(chord))
            raise ValueError(f"spline: points {i} and {i + 1} coincide")
        self.points = P
        self._memo: dict[bytes, np.ndarray] = {}
        self.u = np.concatenate([[0.0], np.cumsum(chord)])
        self.cs = CubicSpline(self.u, P, bc_type="natural")
        self.d1s = self.cs.derivative(1)
        self.d2s = self.cs.derivative(2)
        # arc length at the knots: GL quadrature on sub-intervals of every piece
        s_piece = np.array([self._integral(np.array([a]), np.array([b]), _GL_SPLIT)[0]
                            for a, b in zip(self.u[:-1], self.u[1:], strict=True)])
        self.s_knots = np.concatenate([[0.0], np.cumsum(s_piece)])
        self.arc_length = float(self.s_knots[-1])
        self.r_knots = self.s_knots / self.arc_length
        # a dense table of s(u) for the first guess of the inversion
        uu = np.concatenate([np.linspace(a, b, 64, endpoint=False)
                             for a, b in zip(self.u[:-1], self.u[1:], strict=True)]
                            + [self.u[-1:]])
        self._u_tab = uu
        self._s_tab = self._s_of_u(uu)
        self._t0 = self._speed_dir(np.array([0.0]))[0]
        self._t1 = self._speed_dir(self.u[-1:])[0]

    def _speed(self, u: np.ndarray) -> np.ndarray:
        return np.linalg.norm(self.d1s(u), axis=-1)

    def _speed_dir(self, u: np.ndarray) -> np.ndarray:
        d = self.d1s(u)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def _integral(self, a: np.ndarray, b: np.ndarray, split: int) -> np.ndarray:
        """``int_a^b |P'(w)| dw`` (m,) by Gauss-Legendre on ``split`` sub-intervals."""
        edges = a[:, None] + (b - a)[:, None] * np.linspace(0.0, 1.0, split + 1)[None]
        lo, hi = edges[:, :-1], edges[:, 1:]
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        w = mid[..., None] + half[..., None] * _GL_X  # (m, split, nodes)
        f = self._speed(w.reshape(-1)).reshape(w.shape)
        return np.sum(half * np.sum(f * _GL_W, axis=-1), axis=-1)

    def _s_of_u(self, u: np.ndarray) -> np.ndarray:
        """Arc length ``s(u)`` for ``0 <= u <= u_k`` (m,)."""
        i = np.clip(np.searchsorted(self.u, u, side="right") - 1, 0, len(self.u) - 2)
        return self.s_knots[i] + self._integral(self.u[i], u, 2)

    def _u_of_s(self, s: np.ndarray) -> np.ndarray:
        """Inverse of s(u) on ``[0, L]`` by Newton's method from the table (to rounding)."""
        u = np.interp(s, self._s_tab, self._u_tab)
        for _ in range(12):
            du = (self._s_of_u(u) - s) / self._speed(u)
            u = np.clip(u - du, 0.0, self.u[-1])
            if np.all(np.abs(du) <= 1e-14 * self.u[-1]):  # quadratic: the next step ~1e-28
                break
        return u

    def _split(self, r):
        r = _as_r(r)
        key = r.tobytes()
        hit = self._memo.get(key)
        if hit is None:  # the IK asks for the same r many times (Newton, differences)
            u = self._u_of_s(np.clip(r, 0.0, 1.0) * self.arc_length)
            if len(self._memo) > 256:
                self._memo.clear()
            hit = self._memo[key] = u
        return r, hit, r < 0.0, r > 1.0

    def position(self, r) -> np.ndarray:
        r, u, below, above = self._split(r)
        p = self.cs(u)
        L = self.arc_length
        p[below] = self.points[0] + (r[below] * L)[:, None] * self._t0
        p[above] = self.points[-1] + ((r[above] - 1.0) * L)[:, None] * self._t1
        return p

    def d1(self, r) -> np.ndarray:
        r, u, below, above = self._split(r)
        d = self.arc_length * self._speed_dir(u)
        d[below] = self.arc_length * self._t0
        d[above] = self.arc_length * self._t1
        return d

    def d2(self, r) -> np.ndarray:
        r, u, below, above = self._split(r)
        d1, d2 = self.d1s(u), self.d2s(u)
        sp = np.linalg.norm(d1, axis=1, keepdims=True)
        t = d1 / sp
        out = self.arc_length**2 * (d2 - t * np.sum(t * d2, axis=1, keepdims=True)) / sp**2
        out[below | above] = 0.0
        return out

    def project(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        rs = np.linspace(0.0, 1.0, 64 * (len(self.points) - 1) + 1)
        ps = self.position(rs)
        out = np.empty(X.shape[0])
        L = self.arc_length
        for k, x in enumerate(X):
            cand = []
            r_lo = float((x - self.points[0]) @ self._t0) / L
            if r_lo < 0.0:
                cand.append(r_lo)
            r_hi = 1.0 + float((x - self.points[-1]) @ self._t1) / L
            if r_hi > 1.0:
                cand.append(r_hi)
            r = float(rs[np.argmin(np.linalg.norm(ps - x, axis=1))])
            for _ in range(30):  # Newton on g(r) = (p - x) . p' = 0
                rr = np.array([r])
                e = self.position(rr)[0] - x
                d1, d2 = self.d1(rr)[0], self.d2(rr)[0]
                g, dg = float(e @ d1), float(d1 @ d1 + e @ d2)
                step = g / dg if dg > 0.0 else 0.0
                r = float(np.clip(r - step, 0.0, 1.0))
                if abs(step) <= 1e-15:
                    break
            cand.append(r)
            dist = [float(np.linalg.norm(self.position(np.array([c]))[0] - x)) for c in cand]
            out[k] = cand[int(np.argmin(dist))]
        return out

    def summary(self) -> dict:
        return {"type": "spline", "points_m": self.points.tolist(),
                "length_m": float(self.arc_length),
                "via_r": [float(v) for v in self.r_knots]}


# ---- orientation --------------------------------------------------------------------------


def _blend(tau: np.ndarray, smooth: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sigma, sigma', sigma'' of the keyframe blend (module docstring)."""
    if not smooth:
        return tau, np.ones_like(tau), np.zeros_like(tau)
    t2 = tau * tau
    return (t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2), 30.0 * t2 * (1.0 - tau) ** 2,
            60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau))


class SlerpOrientation:
    """Hand orientation ``R*(r)`` interpolated between keyframes (module docstring).

    Parameters
    ----------
    rotations : array (k, 3, 3)
        Keyframe rotations ``R_i`` (base frame), ``k >= 1``.
    r_knots : array (k,)
        Increasing path parameters of the keyframes (``[0, 1]`` for the two ends; one keyframe:
        any value, the orientation is held).
    blend : {'linear', 'smooth'}
        Constant angular rate between keyframes (slerp), or quintic (rate and acceleration
        zero at every keyframe).
    """

    def __init__(self, rotations, r_knots, blend: str = "linear") -> None:
        Rk = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
        rk = np.asarray(r_knots, dtype=float).reshape(-1)
        if Rk.shape[0] != rk.size or rk.size < 1:
            raise ValueError("slerp: one r per keyframe rotation")
        if rk.size > 1 and np.any(np.diff(rk) <= 0.0):
            raise ValueError("slerp: keyframe r values must increase")
        if blend not in ("linear", "smooth"):
            raise ValueError(f"slerp: blend is linear or smooth, got {blend!r}")
        self.R = Rk
        self.r_knots = rk
        self.smooth = blend == "smooth"
        self.blend = blend
        self.varying = rk.size > 1
        self.v = rotation_log(Rk[1:] @ np.swapaxes(Rk[:-1], 1, 2)) if self.varying else \
            np.zeros((0, 3))

    def _piece(self, r) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r = _as_r(r)
        k = self.r_knots
        i = np.clip(np.searchsorted(k, r, side="right") - 1, 0, k.size - 2)
        dr = k[i + 1] - k[i]
        tau = (r - k[i]) / dr
        # outside the keyframes: linear continues the end geodesics at their rate (C-infinity),
        # smooth holds the end orientations (its rate and acceleration are zero there: C2)
        return i, dr, (np.clip(tau, 0.0, 1.0) if self.smooth else tau)

    def rotation(self, r) -> np.ndarray:
        """``R*(r) (m, 3, 3)``."""
        r = _as_r(r)
        if not self.varying:
            return np.broadcast_to(self.R[0], (r.size, 3, 3)).copy()
        i, _, tau = self._piece(r)
        sig = _blend(tau, self.smooth)[0]
        return Rotation.from_rotvec(sig[:, None] * self.v[i]).as_matrix() @ self.R[i]

    def omega(self, r) -> np.ndarray:
        """Angular velocity per unit r, base frame: ``dR*/dr = [omega] R*`` (m, 3) [rad]."""
        r = _as_r(r)
        if not self.varying:
            return np.zeros((r.size, 3))
        i, dr, tau = self._piece(r)
        return (_blend(tau, self.smooth)[1] / dr)[:, None] * self.v[i]

    def domega(self, r) -> np.ndarray:
        """``d omega / dr (m, 3)`` [rad] (piecewise; zero with ``blend: linear``)."""
        r = _as_r(r)
        if not self.varying:
            return np.zeros((r.size, 3))
        i, dr, tau = self._piece(r)
        return (_blend(tau, self.smooth)[2] / dr**2)[:, None] * self.v[i]

"""Forward position of lee's spherical RRPS mechanism in closed form: every assembly mode (Eq. 10).

:func:`forward_position_batch` and :func:`forward_position`: the three leg equations
``b_i . ([R] r_i) = c_i`` (lee Eq. (10), sign corrected as in
:mod:`mechkin.solvers.closed_form.lee_spherical`) reduced to a trigonometric polynomial of
degree 4 in one angle, sampled, its roots polished to real assembly modes and merged. Split out
of ``lee_spherical.py`` (issue 23: modules that fit in a head).

Design
------
Part of the closed-form room :mod:`mechkin.solvers.closed_form`; numpy and
:mod:`mechkin.solvers.closed_form.lee_geometry` only.

References
----------
lee_spherical_3dof_parallel Eqs. (9), (10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.solvers.closed_form.lee_geometry import (
    ForwardPositionResult,
    LeeGeometry,
    euler_xyz_from_matrix,
)

# --------------------------------------------------------------------------- forward position

_N_SAMPLES = 16  # >= 2 * 4 + 1 samples determine a trigonometric polynomial of degree 4 exactly
_ROOT_BAND = 1e-3  # | |z| - 1 | below which a root is polished as a real candidate
_ACCEPT = 1e-9  # max |b_i . p_i - c_i| after polishing for a real assembly mode
_SAME = 1e-7  # Frobenius distance under which two polished rotations are one mode


def _frame(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Right-handed orthonormal frame (columns) from the pair (u, v); (..., 3) -> (..., 3, 3)."""
    e1 = u / np.linalg.norm(u, axis=-1, keepdims=True)
    e3 = np.cross(u, v)
    e3 = e3 / np.linalg.norm(e3, axis=-1, keepdims=True)
    return np.stack([e1, np.cross(e3, e1), e3], axis=-1)


def _perp_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


@dataclass(frozen=True)
class _Plan:
    """Leg roles of the elimination: circle of leg j is swept, leg k solved, leg m closes."""

    j: int
    k: int
    m: int
    a: float  # r_m = a r_j + b r_k
    b: float
    d_jk: float  # r_j . r_k


def _plans(geom: LeeGeometry) -> list[_Plan]:
    top = geom._cache["top"]
    plans = []
    for j in range(3):
        k, m = (j + 1) % 3, (j + 2) % 3
        M = top[[j, k], :2].T
        if abs(np.linalg.det(M)) < 1e-9 * geom.r**2:
            continue
        ab = np.linalg.solve(M, top[m, :2])
        if abs(ab[1]) < 1e-9:  # r_m parallel to r_j: leg m would not involve p_k
            continue
        plans.append(_Plan(j, k, m, float(ab[0]), float(ab[1]), float(top[j] @ top[k])))
    return plans


def _linear_rows(
    pj: np.ndarray,
    ok: np.ndarray,
    cm: np.ndarray,
    pl: _Plan,
    bm: np.ndarray,
    e1k: np.ndarray,
    e2k: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """For fixed ``p_j`` legs k and m are linear in ``(x, y)``, ``p_k = o_k + x e1_k + y e2_k``.

    Row 1: ``p_j . p_k = r_j . r_k``; row 2: ``b_m . (a p_j + b p_k) = c_m``. Returns
    ``a11, a12, f1, a21, a22, f2`` of ``[[a11, a12], [a21, a22]] (x, y) = (f1, f2)``.
    """
    a11 = pj @ e1k
    a12 = pj @ e2k
    f1 = pl.d_jk - np.sum(pj * ok, axis=-1)
    a21 = np.full_like(a11, pl.b * (bm @ e1k))
    a22 = np.full_like(a11, pl.b * (bm @ e2k))
    f2 = cm - pl.a * (pj @ bm) - pl.b * (ok @ bm)
    return a11, a12, f1, a21, a22, f2


def _candidates(
    geom: LeeGeometry, lengths: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Starting rotations from the real roots of the univariate polynomial, for m problems.

    Returns ``R0 (n, 3, 3)``, ``owner (n,)`` (problem index of each start), ``n_real (m,)``
    (roots on the unit circle per problem) and ``degenerate (m,)``.
    """
    b, top = geom._cache["b"], geom._cache["top"]
    m_prob = lengths.shape[0]
    bn = np.linalg.norm(b, axis=-1)
    n = b / bn[:, None]
    c = 0.5 * (lengths**2 - bn**2 - geom.r**2)  # corrected lee Eq. (10)
    h = c / bn  # signed distance of leg i's circle plane from P
    rho2 = geom.r**2 - h**2
    reachable = np.all(rho2 >= -1e-12 * geom.r**2, axis=-1)
    rho = np.sqrt(np.clip(rho2, 0.0, None))
    plans = _plans(geom)
    score = np.stack([rho[:, p.j] * rho[:, p.k] for p in plans], axis=-1)
    choice = np.argmax(score, axis=-1)  # sweep the pair of largest circles: best conditioned
    basis = [_perp_basis(n[i]) for i in range(3)]
    theta = 2.0 * np.pi * np.arange(_N_SAMPLES) / _N_SAMPLES

    R_out, owner_out = [], []
    n_real = np.zeros(m_prob, dtype=np.int64)
    degenerate = np.zeros(m_prob, dtype=bool)
    for ip, pl in enumerate(plans):
        sel = np.flatnonzero((choice == ip) & reachable)
        if sel.size == 0:
            continue
        j, k, m = pl.j, pl.k, pl.m
        (e1j, e2j), (e1k, e2k) = basis[j], basis[k]
        oj, ok = h[sel, j, None] * n[j], h[sel, k, None] * n[k]  # circle centres (S, 3)
        rj, rk, cm = rho[sel, j], rho[sel, k], c[sel, m]

        # F(theta_j) = Nx^2 + Ny^2 - rho_k^2 D^2 (Cramer on the 2x2 rows, then x^2 + y^2 =
        # rho_k^2) is a trigonometric polynomial of degree 4: 16 samples give it exactly.
        pj = oj[:, None, :] + rj[:, None, None] * (
            np.cos(theta)[:, None] * e1j + np.sin(theta)[:, None] * e2j
        )
        a11, a12, f1, a21, a22, f2 = _linear_rows(
            pj, ok[:, None, :], cm[:, None], pl, b[m], e1k, e2k
        )
        D = a11 * a22 - a12 * a21
        Nx = f1 * a22 - a12 * f2
        Ny = a11 * f2 - f1 * a21
        F = Nx * Nx + Ny * Ny - (rk * rk)[:, None] * D * D
        X = np.fft.fft(F, axis=-1) / _N_SAMPLES
        coef = np.concatenate([X[:, 4:0:-1], X[:, :1], X[:, -1:-5:-1]], axis=-1)  # f_4 .. f_-4
        scale = np.max(np.abs(coef), axis=-1)
        degen = scale <= 1e-14 * np.maximum(np.max(np.abs(F), axis=-1), 1e-300)
        degen |= scale == 0.0
        lead_ok = np.abs(coef[:, 0]) > 1e-10 * scale
        degenerate[sel[degen]] = True

        # Roots of z^4 F = sum_k f_k z^(k+4), z = exp(i theta): companion eigenvalues.
        roots = np.full((sel.size, 8), np.nan + 0j)
        reg = lead_ok & ~degen
        if reg.any():
            C = np.zeros((int(reg.sum()), 8, 8), dtype=complex)
            C[:, 0, :] = -coef[reg, 1:] / coef[reg, :1]
            C[:, np.arange(1, 8), np.arange(7)] = 1.0
            roots[reg] = np.linalg.eigvals(C)
        for s in np.flatnonzero(~lead_ok & ~degen):
            rts = np.roots(np.where(np.abs(coef[s]) > 1e-13 * scale[s], coef[s], 0.0))
            roots[s, : rts.size] = rts
        on_circle = np.abs(np.abs(roots) - 1.0) < _ROOT_BAND
        n_real[sel] = on_circle.sum(axis=-1)
        th_roots = np.where(on_circle, np.angle(roots), np.nan)
        if degen.any():  # F == 0: every theta_j solves it; start from a ring of samples
            th_roots[degen] = np.linspace(0.0, 2 * np.pi, 9)[:-1]

        s_idx, r_idx = np.nonzero(np.isfinite(th_roots))
        if s_idx.size == 0:
            continue
        th = th_roots[s_idx, r_idx]
        pj = oj[s_idx] + rj[s_idx, None] * (np.cos(th)[:, None] * e1j + np.sin(th)[:, None] * e2j)
        a11, a12, f1, a21, a22, f2 = _linear_rows(pj, ok[s_idx], cm[s_idx], pl, b[m], e1k, e2k)
        D = a11 * a22 - a12 * a21
        rel_D = np.abs(D) / np.maximum(np.hypot(a11, a12) * np.hypot(a21, a22), 1e-300)
        regular = rel_D >= 1e-6
        safe_D = np.where(regular, D, 1.0)
        xy_cramer = np.stack([f1 * a22 - a12 * f2, a11 * f2 - f1 * a21], -1) / safe_D[:, None]
        starts = [(regular, xy_cramer)]
        # Nearly parallel rows: p_k is where one row's line meets circle k (both points).
        rk_s = rk[s_idx]
        for A1, A2, F0 in ((a11, a12, f1), (a21, a22, f2)):
            nrm = np.hypot(A1, A2)
            good = ~regular & (nrm > 1e-12)
            u = np.stack([A1, A2], -1) / np.where(good, nrm, 1.0)[:, None]
            t0 = F0 / np.where(good, nrm, 1.0)
            half = np.sqrt(np.clip(rk_s**2 - t0**2, 0.0, None))
            perp = np.stack([-u[:, 1], u[:, 0]], -1)
            for sgn in (1.0, -1.0):
                starts.append((good, t0[:, None] * u + sgn * half[:, None] * perp))
        for keep, xy in starts:
            if not keep.any():
                continue
            pk = ok[s_idx[keep]] + xy[keep, :1] * e1k + xy[keep, 1:] * e2k
            Rp = _frame(pj[keep], pk)
            Rr = _frame(top[j], top[k])
            R_out.append(Rp @ Rr.T)  # the rotation taking (r_j, r_k) to (p_j, p_k)
            owner_out.append(sel[s_idx[keep]])
    if R_out:
        return np.concatenate(R_out), np.concatenate(owner_out), n_real, degenerate
    return np.zeros((0, 3, 3)), np.zeros(0, dtype=np.int64), n_real, degenerate


def _polish(
    geom: LeeGeometry, R: np.ndarray, c: np.ndarray, *, max_iter: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Newton on ``b_i . (exp([delta]) R r_i) = c_i`` for stacked starts; returns R, residual."""
    b, top = geom._cache["b"], geom._cache["top"]
    R = R.copy()
    eye = np.eye(3)
    active = np.ones(R.shape[0], dtype=bool)
    for _ in range(max_iter):
        if not active.any():
            break
        Ra = R[active]
        p = np.einsum("njk,ik->nij", Ra, top)
        f = np.einsum("nij,ij->ni", p, b) - c[active]
        J = np.cross(p, np.broadcast_to(b, p.shape))  # d f_i / d delta = (p_i x b_i)^T
        JT = np.swapaxes(J, -1, -2)
        H = JT @ J
        mu = 1e-15 * np.trace(H, axis1=-2, axis2=-1)[:, None, None] + 1e-300
        delta = -np.linalg.solve(H + mu * eye, (JT @ f[..., None]))[..., 0]
        ang = np.linalg.norm(delta, axis=-1)
        axis = np.where(ang[:, None] > 0, delta / np.where(ang > 0, ang, 1.0)[:, None], eye[2])
        R[active] = _rodrigues(axis, ang) @ Ra
        # Quadratic convergence: after a step of 1e-12 the error is at round-off level.
        active[np.flatnonzero(active)[(ang < 1e-12) | (ang > 10.0)]] = False
    # Re-orthonormalize and evaluate the final residual.
    U, _, Vt = np.linalg.svd(R)
    R = U @ Vt
    p = np.einsum("njk,ik->nij", R, top)
    res = np.max(np.abs(np.einsum("nij,ij->ni", p, b) - c), axis=-1)
    return R, res


def _rodrigues(axis: np.ndarray, ang: np.ndarray) -> np.ndarray:
    K = np.zeros(axis.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -axis[..., 2], axis[..., 1]
    K[..., 1, 0], K[..., 1, 2] = axis[..., 2], -axis[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -axis[..., 1], axis[..., 0]
    s, c = np.sin(ang)[..., None, None], np.cos(ang)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def forward_position_batch(geom: LeeGeometry, lengths: np.ndarray) -> list[ForwardPositionResult]:
    r"""Every real assembly mode for each of m sets of leg lengths (complete, lee §2.3 redone).

    Method. With ``p_i = [R] r_i``, the legs are ``b_i . p_i = c_i`` (corrected Eq. 10) and
    ``|p_i| = r``, so each ``p_i`` lies on a circle ``C_i``. Because the ``r_i`` are coplanar,
    ``r_m = a r_j + b r_k`` and the rotation is fixed by the pair ``(p_j, p_k)`` with
    ``p_j . p_k = r_j . r_k``. Sweep ``p_j`` round ``C_j`` by its angle ``theta``; for fixed
    ``p_j`` the two remaining conditions (``p_j . p_k = r_j . r_k`` and
    ``b_m . (a p_j + b p_k) = c_m``) are *linear* in the in-plane coordinates ``(x, y)`` of
    ``p_k``, and ``p_k`` on ``C_k`` means ``x^2 + y^2 = rho_k^2``. Eliminating ``(x, y)`` by
    Cramer's rule gives

    .. math:: F(\theta) = N_x^2 + N_y^2 - \rho_k^2 D^2 = 0,

    a trigonometric polynomial of degree 4, i.e. a degree-8 polynomial in
    ``z = exp(i theta)``: eight complex solutions, matching the Bezout bound of three quadrics
    in the Euler parameters (the forward problem has at most 8 assembly modes). Its
    coefficients are obtained exactly from 16 samples by an FFT and its roots as eigenvalues
    of the companion matrix; roots on the unit circle are the real solutions. No tangent
    half-angle substitution is used, so no solution can hide at ``theta = pi``; every real
    solution makes ``F = 0`` (also where ``D = 0``, where the rows are parallel and both
    intersection points of a row with ``C_k`` are tried). Each root is then polished by
    Newton's method on the three leg equations in rotation space and duplicates are merged.

    Why not lee Eqs. (11)-(16): they write the three legs as ``[B] ([R] r^(t)) = A`` with a
    *single* vector ``r^(t)``, but each leg carries its own ``r_i`` (the rows of Eq. 10 involve
    three different vectors ``[R] r_i``), so ``v = [B]^{-1} A`` of Eq. (13) is none of them and
    in general not even of length ``r``. And even a correct vector pair ``u -> v`` fixes only
    two of the three rotational freedoms: every ``Rot(v, phi) Rot(k, theta)`` maps ``u`` to
    ``v``, so Eqs. (14)-(16) pick one rotation out of a one-parameter family. The paper's
    formula therefore returns a wrong orientation, and at most one of the up to eight
    assembly modes. (Eq. 10/12 also carries a sign error, corrected above.)

    Parameters
    ----------
    geom : LeeGeometry
    lengths : array, shape (m, 3)
        Leg lengths ``l_i``.

    Returns
    -------
    list of ForwardPositionResult, length m
        Empty ``mu`` (shape (0, 3)) when the lengths admit no real assembly.
    """
    lengths = np.asarray(lengths, dtype=np.float64).reshape(-1, 3)
    m_prob = lengths.shape[0]
    R0, owner, n_real, degenerate = _candidates(geom, lengths)
    b, top = geom._cache["b"], geom._cache["top"]
    c = 0.5 * (lengths**2 - np.sum(b * b, -1) - geom.r**2)
    R, res_c = _polish(geom, R0, c[owner])
    scale = max(geom.R, geom.r, float(np.linalg.norm(geom.center))) ** 2
    ok = res_c < _ACCEPT * scale
    R, owner = R[ok], owner[ok]
    order = np.argsort(owner, kind="stable")
    R, owner = R[order], owner[order]
    bounds = np.searchsorted(owner, np.arange(m_prob + 1))
    out = []
    for i in range(m_prob):
        Ri = R[bounds[i] : bounds[i + 1]]
        keep: list[int] = []
        for a in range(Ri.shape[0]):
            if all(np.linalg.norm(Ri[a] - Ri[q]) > _SAME for q in keep):
                keep.append(a)
        Ri = Ri[keep]
        angle = np.arccos(np.clip(0.5 * (np.trace(Ri, axis1=-2, axis2=-1) - 1.0), -1.0, 1.0))
        Ri = Ri[np.argsort(angle, kind="stable")]
        p = np.einsum("njk,ik->nij", Ri, top)
        res = np.max(np.abs(np.linalg.norm(p + b, axis=-1) - lengths[i]), axis=-1)
        out.append(
            ForwardPositionResult(
                mu=euler_xyz_from_matrix(Ri),
                R=Ri,
                residual=res,
                n_candidates=int(n_real[i]),
                degenerate=bool(degenerate[i]),
            )
        )
    return out


def forward_position(geom: LeeGeometry, lengths: np.ndarray) -> ForwardPositionResult:
    """Every real assembly mode for one set of leg lengths ``(3,)``.

    See :func:`forward_position_batch` for the method and why lee Eqs. (11)-(16) are not used.
    """
    lengths = np.asarray(lengths, dtype=np.float64)
    if lengths.shape != (3,):
        raise ValueError(f"lengths: expected shape (3,), got {lengths.shape}")
    return forward_position_batch(geom, lengths[None, :])[0]

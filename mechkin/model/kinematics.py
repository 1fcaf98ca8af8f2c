r"""Batched forward kinematics, Jacobians and the loop-closure residual (kim1995 §2, Eq. (4)).

Twists and geometric Jacobians are ordered (omega, v) (Lynch & Park), expressed in the base
frame, with v the velocity of the frame's origin. Residuals are ordered like kim1995 Eq. (8):
position first, then the vector part of the Euler parameters.

Two FK routes. :func:`forward_kinematics` returns every link (the tree, one batched product per
depth; from ``LARGE_BATCH`` configurations on, block by block through the all-links path plan).
:func:`frame_poses` evaluates only the joints on the paths from the base to the requested
frames: a :class:`_PathPlan` per mechanism and frame set (cached on the mechanism like the other
caches here) with the constants folded (``C = B_parent A_child``); the plans and their routes
are in :mod:`mechkin.model.fk_plan`. Routes: the compiled kernel of :mod:`mechkin.model.fk_jit`
for single configurations once :mod:`mechkin.model.fk_accel` has loaded it (rent or buy: only
when the numpy time of the process would exceed numba's load cost), for any batch size with
``MECHKIN_JIT=1`` (``=0``: never); else one configuration in plain Python floats
(a straight-line function generated per plan, the constants' exact zeros and ones folded), a
few as 4x4 products, many block by block in a column-major layout (``PLAN_BLOCK``
configurations, one wide (4 x 4) @ (4 x 3b) product per constant, below OpenBLAS's threading
threshold), keeping only the poses still needed. All routes agree to round-off
(tests/model/test_fast_fk.py, tests/model/test_fk_routes.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model import fk_accel
from mechkin.model.couplings import append_coupling_rows
from mechkin.model.fk_plan import (  # noqa: F401 - re-exported: the plan routes' names
    _F64,
    _ZC,
    _ZD,
    _ZK,
    _ZS,
    PLAN_BLOCK,
    PLAN_LARGE_BATCH,
    _one_function,
    _path_plan,
    _PathPlan,
    _plan_compiled,
    _plan_large,
    _plan_one,
    _plan_one_fast,
    _plan_small,
)
from mechkin.model.mechanism import Mechanism
from mechkin.spatial.rotations import quat_from_matrix, skew


@dataclass(frozen=True)
class Kinematics:
    """Poses of a batch of configurations.

    q (m, n); T_links (m, nl, 4, 4): base -> link frames. Joint axes (unit z in the base frame)
    and points on them are computed on demand by :meth:`axes`.
    """

    q: np.ndarray
    T_links: np.ndarray
    mech: Mechanism

    def frames(self, mech: Mechanism, idx: np.ndarray | list[int] | None = None) -> np.ndarray:
        """Poses of frames ``idx`` (all if None) in the base frame: (m, k, 4, 4)."""
        fi = np.arange(len(mech.frame_names)) if idx is None else np.asarray(idx)
        return self.T_links[:, mech.frame_link[fi]] @ mech.frame_offset[fi]

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint axes z (m, n, 3) and points o (m, n, 3) on them, in the base frame."""
        cache = self.__dict__.get("_axes")
        if cache is None:
            mech = self.mech
            # link-major (the layout forward_kinematics builds): one contiguous gather
            Tp = np.moveaxis(self.T_links, 1, 0)[mech.joint_parent_link]  # (n, m, 4, 4)
            Rp = Tp[..., :3, :3]
            az = mech.A[:, :3, 2]
            d = np.where(mech.s == 1, self.q, 0.0).T  # (n, m)
            ao = mech.A[:, None, :3, 3] + az[:, None, :] * d[..., None]  # (n, m, 3)
            z = np.moveaxis((Rp @ az[:, None, :, None])[..., 0], 0, 1)
            o = np.moveaxis((Rp @ ao[..., None])[..., 0] + Tp[..., :3, 3], 0, 1)
            cache = (z, o)
            object.__setattr__(self, "_axes", cache)
        return cache

    @property
    def W(self) -> np.ndarray:
        """Joint axis frames (m, n, 4, 4): T_base_parent @ A_i @ Z(q_i)."""
        mech = self.mech
        Tp = self.T_links[:, mech.joint_parent_link]
        return Tp @ (_local(mech, self.q, mech.A, mech.A @ _ZC, mech.A @ _ZS, mech.A @ _ZD))


# Z(q) factors and the path plans: mechkin.model.fk_plan


def _local(mech: Mechanism, qs: np.ndarray, P0, Pc, Ps, Pd) -> np.ndarray:
    """c P_c + s P_s + d P_d + P_0 for every joint: (m, n, 4, 4)."""
    return np.moveaxis(_local_T(mech, np.ascontiguousarray(qs.T), P0, Pc, Ps, Pd), 0, 1)


def _local_T(mech: Mechanism, qT: np.ndarray, P0, Pc, Ps, Pd) -> np.ndarray:
    """Joint-major local transforms (n, m, 4, 4) from joint-major values qT (n, m)."""
    rev = mech.s == 0
    L = np.empty(qT.shape + (4, 4))
    if rev.all():  # no masking copies for all-revolute chains (the common case)
        np.multiply(np.cos(qT)[..., None, None], Pc[:, None], out=L)
        L += np.sin(qT)[..., None, None] * Ps[:, None]
        L += P0[:, None]
        return L
    if rev.any():
        qr = qT[rev]
        L[rev] = np.cos(qr)[..., None, None] * Pc[rev, None]
        L[rev] += np.sin(qr)[..., None, None] * Ps[rev, None]
        L[rev] += P0[rev, None]
    if (~rev).any():
        L[~rev] = qT[~rev][..., None, None] * Pd[~rev, None]
        L[~rev] += P0[~rev, None]
    return L
def _local_factors(mech: Mechanism) -> tuple[np.ndarray, ...]:
    """Constant matrices with A Z(q) B = c Pc + s Ps + d Pd + P0 (cached on the mechanism)."""
    cache = mech.__dict__.get("_local_factors")
    if cache is None:
        A, B = mech.A, mech.B
        rev = (mech.s == 0)[:, None, None]
        P0 = np.where(rev, A @ _ZK @ B, A @ B)
        Pc = np.where(rev, A @ _ZC @ B, 0.0)
        Ps = np.where(rev, A @ _ZS @ B, 0.0)
        Pd = np.where(rev, 0.0, A @ _ZD @ B)
        cache = (P0, Pc, Ps, Pd)
        object.__setattr__(mech, "_local_factors", cache)
    return cache


def forward_kinematics(mech: Mechanism, qs: np.ndarray) -> Kinematics:
    """Tree forward kinematics of every link for many configurations in one call.

    Parameters
    ----------
    qs : array, shape (m, n)
        Joint values [rad | m].

    Notes
    -----
    Each joint's transform ``A Z(q) B`` is ``c P_c + s P_s + d P_d + P_0`` with constant
    matrices (kim1995 Eq. (2): the joint index s_i picks rotation or translation), and joints of
    one depth of the tree are composed together (one batched product per depth), so a 36-joint
    Stewart platform costs 7 batched products, a 6R arm 6. Below ``LARGE_BATCH``
    configurations the compiled path plan of every link (:mod:`mechkin.model.fk_jit`) does
    it once :mod:`mechkin.model.fk_accel` has loaded it (one Stewart configuration: a few us
    instead of about 0.2 ms); from ``LARGE_BATCH`` on, the numpy path plan block by block.
    """
    qs = np.asarray(qs, dtype=np.float64)
    if qs.ndim != 2 or qs.shape[1] != mech.n:
        raise ValueError(f"qs: expected shape (m, {mech.n}), got {qs.shape}")
    m = qs.shape[0]
    if _links_are_frames(mech):
        kern = fk_accel.kernel_for_job(mech.n, m) if m < LARGE_BATCH else None
        if kern is not None:  # the compiled path plan of every link body frame
            plan = _path_plan(mech, np.arange(mech.n_links), ("links",))
            return Kinematics(q=qs, T_links=_plan_compiled(kern, plan, qs), mech=mech)
        if m >= LARGE_BATCH:
            # the link body frames through the block-wise path plan (link-major storage)
            plan = _path_plan(mech, np.arange(mech.n_links), ("links",))
            return Kinematics(q=qs, T_links=_plan_large(plan, qs, link_major=True), mech=mech)
    T = np.empty((mech.n_links, m, 4, 4))  # link-major while composing, contiguous per link
    T[0] = np.eye(4)
    if m >= LARGE_BATCH:
        _fk_large_batch(mech, qs, T)
        return Kinematics(q=qs, T_links=np.moveaxis(T, 0, 1), mech=mech)
    L = _local_T(mech, np.ascontiguousarray(qs.T), *_local_factors(mech))
    for lvl in mech.levels:
        if len(lvl) == 1:
            j = lvl[0]
            np.matmul(T[mech.joint_parent_link[j]], L[j], out=T[mech.joint_child_link[j]])
        else:
            T[mech.joint_child_link[lvl]] = T[mech.joint_parent_link[lvl]] @ L[lvl]
    T = np.moveaxis(T, 0, 1)
    return Kinematics(q=qs, T_links=T, mech=mech)


LARGE_BATCH = 256


def _links_are_frames(mech: Mechanism) -> bool:
    """Whether frames 0..nl-1 are the link body frames (identity offsets), as built (cached
    on the mechanism)."""
    hit = mech.__dict__.get("_links_are_frames")
    if hit is None:
        nl = mech.n_links
        hit = (len(mech.frame_names) >= nl
               and bool(np.array_equal(mech.frame_link[:nl], np.arange(nl)))
               and bool(np.array_equal(mech.frame_offset[:nl],
                                       np.broadcast_to(np.eye(4), (nl, 4, 4)))))
        object.__setattr__(mech, "_links_are_frames", hit)
    return hit


def _a_as_rz_tz(mech: Mechanism) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each joint, whether A = Rz(theta0) Tz(d0) (as in standard D-H), and theta0, d0."""
    cache = mech.__dict__.get("_a_rz_tz")
    if cache is None:
        A = mech.A
        theta0 = np.arctan2(A[:, 1, 0], A[:, 0, 0])
        c, s = np.cos(theta0), np.sin(theta0)
        R = np.zeros((mech.n, 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
        simple = (np.abs(A[:, :3, :3] - R).max(axis=(1, 2)) < 1e-15) & (
            np.abs(A[:, :2, 3]).max(axis=1) < 1e-15)
        cache = (theta0, A[:, 2, 3].copy(), simple)
        object.__setattr__(mech, "_a_rz_tz", cache)
    return cache


def _fk_large_batch(mech: Mechanism, qs: np.ndarray, T: np.ndarray) -> None:
    """Joint by joint for large batches: T_parent @ A and (.) @ B are each one GEMM over the
    whole batch ((m*4, 4) @ (4, 4)), and Z(q) only mixes two columns (or shifts one)."""
    m = qs.shape[0]
    rev = mech.s == 0
    theta0, d0, simple = _a_as_rz_tz(mech)
    phi = np.where(rev, qs, 0.0) + theta0  # rotation about z after T_parent (simple A)
    c = np.cos(phi)
    s = np.sin(phi)
    for j in np.concatenate(mech.levels):
        if simple[j]:
            # A = Rz(theta0) Tz(d0) (standard D-H): no GEMM, two columns mix and one shifts
            Tp = T[mech.joint_parent_link[j]]
            X = np.empty((m, 4, 4))
            cj, sj = c[:, j, None], s[:, j, None]
            X[:, :, 0] = Tp[:, :, 0] * cj + Tp[:, :, 1] * sj
            X[:, :, 1] = Tp[:, :, 1] * cj - Tp[:, :, 0] * sj
            X[:, :, 2] = Tp[:, :, 2]
            shift = d0[j] + (qs[:, j, None] if not rev[j] else 0.0)
            X[:, :, 3] = Tp[:, :, 3] + Tp[:, :, 2] * shift
            np.matmul(X.reshape(m * 4, 4), mech.B[j],
                      out=T[mech.joint_child_link[j]].reshape(m * 4, 4))
            continue
        X = (T[mech.joint_parent_link[j]].reshape(m * 4, 4) @ mech.A[j]).reshape(m, 4, 4)
        if rev[j]:
            x0 = X[:, :, 0].copy()
            x1 = X[:, :, 1]
            cj, sj = np.cos(qs[:, j, None]), np.sin(qs[:, j, None])
            X[:, :, 0] = x0 * cj + x1 * sj
            X[:, :, 1] = x1 * cj - x0 * sj
        else:
            X[:, :, 3] += X[:, :, 2] * qs[:, j, None]
        np.matmul(X.reshape(m * 4, 4), mech.B[j], out=T[mech.joint_child_link[j]].reshape(m * 4, 4))


def frame_poses(mech: Mechanism, qs: np.ndarray, idx: list[int] | np.ndarray | None = None):
    """Poses (m, k, 4, 4) of frames ``idx`` (all when None) for configurations qs (m, n).

    Only the joints on the paths from the base to the requested frames are evaluated (a plan
    per mechanism and frame set, cached on the mechanism, see :func:`_path_plan`); the result
    equals ``forward_kinematics(mech, qs).frames(mech, idx)`` to round-off.

    Routes: the compiled kernel (:mod:`mechkin.model.fk_jit`) once
    :mod:`mechkin.model.fk_accel` has loaded it (rent or buy; ``MECHKIN_JIT=1`` always,
    ``MECHKIN_JIT=0`` never), else plain Python floats (one configuration), 4x4 products (a
    few) or column-major blocks (many). The hot path of one configuration is a cached plan
    lookup, one output allocation and the kernel call.
    """
    kern = fk_accel.ENTRY
    if kern is not None and type(idx) is list and type(qs) is np.ndarray and qs.dtype is _F64:
        # the hot path (compiled, a list of frames, a float64 array): plan lookup, the
        # kernel's own argument types checked here, allocation, call without numba's dispatch
        plans = mech.__dict__.get("_fk_plans")
        plan = None if plans is None else plans.get(tuple(idx))
        shape = qs.shape
        if (plan is not None and len(shape) == 2 and shape[1] == plan.n
                and (shape[0] == 1 or fk_accel.EVERYWHERE)):
            fl = qs.flags
            if fl.c_contiguous and fl.writeable and fl.aligned:
                out = np.empty(plan.shape1 if shape[0] == 1 else (shape[0], plan.k, 4, 4))
                kern(qs, plan.jit, out)
                return out
    plans = mech.__dict__.get("_fk_plans")
    try:  # the cache key: the frame indices as given (a list or an integer array)
        key = tuple(idx) if type(idx) is list else (
            None if idx is None else tuple(np.asarray(idx).tolist()))
        plan = None if plans is None else plans.get(key)
    except TypeError:  # unhashable (nested) indices: the tree FK decides
        return forward_kinematics(mech, qs).frames(mech, idx)
    qs = np.asarray(qs, dtype=np.float64)
    if qs.ndim != 2 or qs.shape[1] != mech.n:
        raise ValueError(f"qs: expected shape (m, {mech.n}), got {qs.shape}")
    if plan is None:
        fi = np.arange(len(mech.frame_names)) if idx is None else np.asarray(idx)
        if fi.ndim != 1 or (fi.size and fi.dtype.kind not in "iu"):
            return forward_kinematics(mech, qs).frames(mech, idx)
        plan = _path_plan(mech, fi.astype(int), key)
        if key is None:  # all frames: found under None next time
            mech.__dict__["_fk_plans"][None] = plan
    m = qs.shape[0]
    if not plan.frames_py:
        return np.zeros((m, 0, 4, 4))
    kern = fk_accel.kernel_for_job(len(plan.steps), m)
    if kern is not None:
        return _plan_compiled(kern, plan, qs)
    if m == 1:
        return _plan_one_fast(plan, qs[0])
    if m >= PLAN_LARGE_BATCH:
        return _plan_large(plan, qs)
    return _plan_small(plan, qs)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (faster than np.cross on small stacks)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _point_twists(mech: Mechanism, kin: Kinematics, p: np.ndarray):
    """Per joint, velocity of points p (m, k, 3) and angular velocity: (m, k, n, 3) each."""
    z, o = kin.axes()
    rev = (mech.s == 0)[:, None]
    v = np.where(rev, _cross(z[:, None], p[:, :, None, :] - o[:, None]), z[:, None])
    w = np.where(rev, z, 0.0)[:, None]
    return v, w


def frame_jacobian(mech: Mechanism, kin: Kinematics, f: int) -> np.ndarray:
    """Geometric Jacobian (m, 6, n) of frame ``f``: rows (omega, v) in the base frame."""
    p = kin.frames(mech, [f])[:, :, :3, 3]
    v, w = _point_twists(mech, kin, p)
    mask = mech.link_ancestors[mech.frame_link[f]][None, :, None]
    J = np.concatenate([np.broadcast_to(w[:, 0], v[:, 0].shape) * mask, v[:, 0] * mask], axis=-1)
    return np.swapaxes(J, 1, 2)


def relative_residual(T_a: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """Residual of frame b relative to frame a (kim1995 Eq. (7)-(8)): (..., 6).

    ``x = (R_a^T (p_b - p_a), e_ab)`` with ``e_ab`` the vector part of the Euler parameters of
    ``R_a^T R_b`` (e0 >= 0).
    """
    R_a = T_a[..., :3, :3]
    dp = T_b[..., :3, 3] - T_a[..., :3, 3]
    p = np.einsum("...ji,...j->...i", R_a, dp)
    e = quat_from_matrix(np.swapaxes(R_a, -1, -2) @ T_b[..., :3, :3])
    return np.concatenate([p, e[..., 1:]], axis=-1)


def _support(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of sigma (k, n), the joints with sigma != 0, padded: index (k, s), sign (k, s)."""
    nz = [np.flatnonzero(row) for row in sigma]
    width = max((len(x) for x in nz), default=0)
    idx = np.full((len(nz), width), sigma.shape[1], dtype=int)  # padding -> a dummy column n
    sgn = np.zeros((len(nz), width))
    for r, cols in enumerate(nz):
        idx[r, : len(cols)] = cols
        sgn[r, : len(cols)] = sigma[r, cols]
    return idx, sgn


def _support_cached(mech: Mechanism, fa: np.ndarray | None, fb: np.ndarray):
    """The loop supports of (fa, fb) frame pairs, computed once per mechanism and pair list."""
    cache = mech.__dict__.setdefault("_supports", {})
    key = (None if fa is None else tuple(fa.tolist()), tuple(fb.tolist()))
    hit = cache.get(key)
    if hit is None:
        sigma = mech.link_ancestors[mech.frame_link[fb]].astype(np.float64)  # (k, n)
        if fa is not None:
            sigma = sigma - mech.link_ancestors[mech.frame_link[fa]]
        idx, sgn = _support(sigma)
        hit = (idx, sgn, np.minimum(idx, mech.n - 1))
        if len(cache) < 256:
            cache[key] = hit
    return hit


def relative_jacobians(
    mech: Mechanism,
    kin: Kinematics,
    fa: np.ndarray | None,
    fb: np.ndarray,
    T_a_fixed: np.ndarray | None = None,
    *,
    rotation: str = "euler",
) -> tuple[np.ndarray, np.ndarray]:
    r"""Residuals x (m, k, 6) of frames fb (k,) relative to frames fa (k,) and dx/dq (m, k, 6, n).

    ``rotation="euler"`` (default): the orientation part is the vector part of the Euler
    parameters (kim1995 Eq. (8)) with its exact Jacobian. ``rotation="log"``: the rotation
    vector (angle times axis) of R_a^T R_b, with the angular-velocity Jacobian R_a^T sum sigma_j
    omega_j (exact at zero rotation; the Gauss-Newton model used by Levenberg-Marquardt).

    ``fa = None`` means fixed frames ``T_a_fixed`` (k, 4, 4) or (m, k, 4, 4) in the base frame
    (precision points, kim1995 Eq. (7)). With sigma_j = [j before b] - [j before a] in the tree,

    .. math:: \dot p = R_a^T \sum_j \sigma_j v_j(p_b)\dot q_j,\quad
              \dot e = \tfrac12 (e_0 I - [e]_\times) R_a^T \sum_j \sigma_j \omega_j \dot q_j

    (for a joint before both frames, v_j(p_b) - v_j(p_a) - omega_j x (p_b - p_a) = 0). Only the
    joints with sigma_j != 0 (the two branches of each loop) are evaluated.
    """
    fb = np.asarray(fb)
    m = kin.q.shape[0]
    k = len(fb)
    T_b = kin.frames(mech, fb)
    if fa is None:
        T_a = np.asarray(T_a_fixed, dtype=np.float64)
        if T_a.shape != (m, k, 4, 4):
            T_a = np.broadcast_to(T_a, (m, k, 4, 4))
    else:
        fa = np.asarray(fa)
        T_a = kin.frames(mech, fa)
    idx, sgn, idx_c = _support_cached(mech, fa, fb)  # (k, s)
    R_a = T_a[..., :3, :3]
    p_b = T_b[..., :3, 3]
    z, o = kin.axes()
    full = k == 1 and idx.shape[1] == mech.n and bool(np.all(sgn == 1.0)) and bool(
        np.all(idx[0] == np.arange(mech.n)))  # a serial chain up to b: no gather, no scatter
    if full:
        zs, os_ = z[:, None], o[:, None]
    else:
        zs, os_ = z[:, idx_c], o[:, idx_c]  # (m, k, s, 3)
    rev = (mech.s[idx_c] == 0)[None, :, :, None]
    if full:
        v = _cross(zs, p_b[:, :, None, :] - os_)
        if not rev.all():
            v = np.where(rev, v, zs)
        w = zs if rev.all() else np.where(rev, zs, 0.0)
    else:
        sg = sgn[None, :, :, None]
        v = np.where(rev, _cross(zs, p_b[:, :, None, :] - os_), zs) * sg
        w = np.where(rev, zs, 0.0) * sg
    Jp = v @ R_a  # rows v^T R_a = (R_a^T v)^T: (m, k, s, 3)
    Jw = w @ R_a
    e = quat_from_matrix(np.swapaxes(R_a, -1, -2) @ T_b[..., :3, :3])  # (m, k, 4)
    e0, ev = e[..., 0], e[..., 1:]
    x = np.empty((m, k, 6))
    x[..., :3] = (np.swapaxes(R_a, -1, -2) @ (p_b - T_a[..., :3, 3])[..., None])[..., 0]
    if rotation == "log":
        x[..., 3:] = rotation_vector(e)
        Je = Jw
    else:
        E = 0.5 * (e0[..., None, None] * np.eye(3) - skew(ev))
        Je = Jw @ np.swapaxes(E, -1, -2)  # (E Jw^T)^T
        x[..., 3:] = ev
    if full:
        J = np.empty((m, k, 6, mech.n))
        J[:, :, :3] = np.swapaxes(Jp, -1, -2)
        J[:, :, 3:] = np.swapaxes(Je, -1, -2)
        return x, J
    Jt = np.zeros((m, k, mech.n + 1, 6))
    Jt[:, np.arange(k)[:, None], idx, :3] = Jp
    Jt[:, np.arange(k)[:, None], idx, 3:] = Je
    Jt = Jt[:, :, : mech.n]
    return x, np.swapaxes(Jt, -1, -2)


def rotation_vector(e: np.ndarray) -> np.ndarray:
    """Rotation vector (angle * axis) from Euler parameters (..., 4) with e0 >= 0: (..., 3)."""
    ev = e[..., 1:]
    s = np.linalg.norm(ev, axis=-1)
    ang = 2.0 * np.arctan2(s, e[..., 0])
    scale = np.where(s > 1e-12, ang / np.where(s > 1e-12, s, 1.0), 2.0)
    return ev * scale[..., None]


def relative_jacobian(
    mech: Mechanism, kin: Kinematics, fa: int | None, fb: int, T_a_fixed: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Residual x (m, 6) of frame fb relative to fa (or a fixed frame) and dx/dq (m, 6, n)."""
    T_fixed = None if T_a_fixed is None else np.asarray(T_a_fixed)[..., None, :, :]
    x, J = relative_jacobians(mech, kin, None if fa is None else np.array([fa]), np.array([fb]),
                              T_fixed)
    return x[:, 0], J[:, 0]


def _cut_arrays(mech: Mechanism) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    cache = mech.__dict__.get("_cut_arrays")
    if cache is None:
        cache = (np.array([c.a for c in mech.cuts], dtype=int),
                 np.array([c.b for c in mech.cuts], dtype=int),
                 np.stack([c.mask for c in mech.cuts]) if mech.cuts else np.zeros((0, 6), bool))
        object.__setattr__(mech, "_cut_arrays", cache)
    return cache


def closure_residual(mech: Mechanism, kin: Kinematics) -> np.ndarray:
    """phi_R (m, n_eq): the loop-closure residual of every cut, masked (kim1995 Eq. (4))."""
    m = kin.q.shape[0]
    if not mech.cuts:
        phi = np.zeros((m, 0))
    else:
        fa, fb, mask = _cut_arrays(mech)
        x = relative_residual(kin.frames(mech, fa), kin.frames(mech, fb))  # (m, nc, 6)
        phi = x[:, mask]
    if mech.couplings:  # joint couplings: rows after the cuts' (mechkin.model.couplings)
        phi = append_coupling_rows(mech, kin.q, phi)
    return phi


def closure_jacobian(mech: Mechanism, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """phi_R (m, n_eq) and d(phi_R)/dq (m, n_eq, n), analytic (kim1995 Eq. (4))."""
    m = kin.q.shape[0]
    if not mech.cuts:
        phi, J = np.zeros((m, 0)), np.zeros((m, 0, mech.n))
    else:
        fa, fb, mask = _cut_arrays(mech)
        x, Jx = relative_jacobians(mech, kin, fa, fb)
        phi, J = x[:, mask], Jx[:, mask]
    if mech.couplings:  # joint couplings: rows after the cuts' (mechkin.model.couplings)
        phi, J = append_coupling_rows(mech, kin.q, phi, J)
    return phi, J

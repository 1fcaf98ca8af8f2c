r"""Singularities of complex chains, measured and named (kim1995 §5.1, Eq. (4) and (10)).

Design
------
Two matrices decide whether a closed chain moves well at a configuration:

- ``Phi_w = d phi_R / d q_w`` (kim1995 Eq. (4) differentiated in the dependent joints), which
  the loop closure inverts. When it loses column rank the dependent joints are no longer
  determined by the independent ones: a **constraint singularity** (the passive chain locks,
  or two assembly modes meet and the chain can branch, e.g. the direct-drive arm's
  parallelogram folding flat into an anti-parallelogram).
- ``J_r = dx_E / dq_v = J_E (L_v + L_w S)`` (kim1995 Eq. (10)), the end-effector Jacobian
  through the loop closure. When it loses rank (``min(6, n_v)`` singular values) the end
  effector loses a direction of motion, or the independent joints gain a self-motion that does
  not move it: an **inverse-kinematic singularity** (e.g. the PUMA 560 with q5 = 0, its wrist
  axes 4 and 6 aligned).

Both are measured by the relative smallest singular value ``ratio = sigma_min / sigma_max``
(1 / condition number; for a matrix with a single column, e.g. the J_r of a 1-DOF linkage,
``min(1, sigma)``: its one singular value against the unit scale, since the ratio of a single
column is always 1), computed by SVD on **nondimensionalised** matrices: every length is
divided by a characteristic length ``L`` (rows of positions and velocities divided by L,
columns of prismatic joints multiplied by L), so revolute and prismatic columns and rotation
and translation rows compare as numbers. ``L`` defaults to :func:`characteristic_length`, the
largest distance between two joint axis points at the home configuration (the mechanism's
size). Thresholds (relative, dimensionless):

- ``ratio < tol_singular`` (default :data:`TOL_SINGULAR` = 1e-6): singular;
- ``ratio < tol_near`` (default :data:`TOL_NEAR` = 1e-2): near singular (a warning: joint
  rates grow like 1/ratio).

The unscaled condition number of ``Phi_w`` (what the Newton-Raphson of
:func:`mechkin.model.closure.solve_closure` sees, and ``ClosureResult.cond``) is reported as
``cond_closure``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from mechkin.model.kinematics import (
    Kinematics,
    _cut_arrays,
    closure_jacobian,
    forward_kinematics,
)
from mechkin.model.mechanism import Mechanism
from mechkin.model.reduced import _frame_indices, _svd_pinv, reduced_jacobian, scatter_rows

TOL_SINGULAR = 1e-6
TOL_NEAR = 1e-2
LEVELS = ("regular", "near", "singular")


class SingularityKind(enum.Enum):
    """Which matrix is rank deficient (``ratio < tol_singular``)."""

    REGULAR = "regular"
    CONSTRAINT = "constraint singularity"
    INVERSE_KINEMATIC = "inverse-kinematic singularity"
    BOTH = "constraint and inverse-kinematic singularity"
    UNDEFINED = "undefined"  # the configuration is not finite (e.g. a failed closure step)


_SINGULAR_KINDS = (SingularityKind.CONSTRAINT, SingularityKind.INVERSE_KINEMATIC,
                   SingularityKind.BOTH)


@dataclass(frozen=True)
class SingularityReport:
    """Per configuration (m,): condition numbers and the classification.

    Attributes
    ----------
    cond_closure : (m,), property
        Unscaled ``sigma_1 / sigma_{n_w}`` of ``Phi_w`` (= ``ClosureResult.cond`` at the
        solution); 1 without dependent joints, inf when rank deficient.
    cond_constraint, cond_reduced : (m,)
        Condition numbers of the nondimensionalised ``Phi_w`` and ``J_r`` (``cond_reduced`` nan
        without an end-effector frame).
    ratio_constraint, ratio_reduced : (m,)
        Their inverses ``sigma_min / sigma_max`` (0 at a singularity, 1 isotropic).
    constraint_level, inverse_level : (m,) str
        ``"regular"``, ``"near"`` or ``"singular"`` for each matrix (``"undefined"`` for a
        configuration that is not finite; its measures are nan).
    kind : (m,) SingularityKind
    label : (m,) str
        ``kind.value`` when singular, else e.g. ``"near constraint singularity"``, or
        ``"regular"``; one string per configuration (for a CSV column).
    length_scale : float
        L [m]. tol_singular, tol_near : the thresholds used.
    end_effector : str or None
        The frame of ``J_r``.
    """

    cond_constraint: np.ndarray
    cond_reduced: np.ndarray
    constraint_level: np.ndarray
    inverse_level: np.ndarray
    kind: np.ndarray
    label: np.ndarray
    length_scale: float
    tol_singular: float
    tol_near: float
    end_effector: str | None
    phi_w: np.ndarray | None = field(default=None, repr=False)  # unscaled (m, n_eq, n_w)

    @cached_property
    def cond_closure(self) -> np.ndarray:
        """Unscaled cond of d(phi)/d(q_w) (m,), computed on first access (one SVD)."""
        m = len(self.kind)
        if self.phi_w is None or self.phi_w.shape[2] == 0:
            return np.ones(m)
        if self.phi_w.shape[1] == 0:
            return np.full(m, np.inf)
        out = np.full(m, np.nan)
        ok = np.isfinite(self.phi_w).all(axis=(1, 2))
        if ok.any():
            s = np.linalg.svd(self.phi_w[ok], compute_uv=False)
            out[ok] = _cond_cols(s, self.phi_w.shape[2])
        return out

    @property
    def ratio_constraint(self) -> np.ndarray:
        return _inv(self.cond_constraint)

    @property
    def ratio_reduced(self) -> np.ndarray:
        return _inv(self.cond_reduced)

    @property
    def singular(self) -> np.ndarray:
        """(m,) bool: any singularity (constraint or inverse-kinematic)."""
        return np.array([k in _SINGULAR_KINDS for k in self.kind], dtype=bool)

    @property
    def near(self) -> np.ndarray:
        """(m,) bool: regular but within the warning threshold of a singularity."""
        return ~self.singular & ((self.constraint_level == "near")
                                 | (self.inverse_level == "near"))


def _inv(c: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return np.where(np.isnan(c), np.nan, 1.0 / c)


def characteristic_length(mech: Mechanism) -> float:
    """The mechanism's size [m]: the largest distance between two joint axis points at home.

    Joint axis points are the origins of the joint frames ``T_parent A_i`` (kim1995 Eq. (2)) at
    the home configuration (undefined home values taken as 0). Falls back to the largest
    distance of a frame origin from the base, then to 1 m, for degenerate mechanisms.
    """
    cached = mech.__dict__.get("_characteristic_length")
    if cached is not None:
        return cached
    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    kin = forward_kinematics(mech, q0)
    o = kin.axes()[1][0]
    L = float(np.max(np.linalg.norm(o[:, None] - o[None], axis=-1), initial=0.0))
    if not L > 1e-9:
        L = float(np.max(np.linalg.norm(kin.frames(mech)[0, :, :3, 3], axis=-1), initial=0.0))
    if not L > 1e-9:
        L = 1.0
    object.__setattr__(mech, "_characteristic_length", L)
    return L


def _cond_cols(s: np.ndarray, ncols: int) -> np.ndarray:
    """sigma_1 / sigma_ncols from singular values s (m, k); inf when k < ncols or rank lost."""
    m = s.shape[0]
    if ncols == 0:
        return np.ones(m)
    if s.shape[1] < ncols:
        return np.full(m, np.inf)
    smin, smax = s[:, ncols - 1], s[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(smin > 0, smax / np.where(smin > 0, smin, 1.0), np.inf)


def _cond_scaled(s: np.ndarray, ncols: int) -> np.ndarray:
    """Condition of a nondimensionalised matrix from its singular values s (m, k).

    With two or more columns ``sigma_1 / sigma_ncols``. With one column the ratio of a vector's
    singular values is 1 by definition, so its only singular value is measured against the
    unit scale of the nondimensionalisation instead: ``max(1, 1 / sigma)`` (a 1-DOF linkage at a
    dead centre, where the column vanishes, is singular; ``ratio = min(1, sigma)``).
    """
    if ncols != 1 or s.shape[1] < 1:
        return _cond_cols(s, ncols)
    with np.errstate(divide="ignore"):
        return np.where(s[:, 0] > 0, np.maximum(1.0, 1.0 / np.where(s[:, 0] > 0, s[:, 0], 1.0)),
                        np.inf)


def _row_is_position(mech: Mechanism) -> np.ndarray:
    _, _, mask = _cut_arrays(mech)
    kinds = np.broadcast_to(np.array([1, 1, 1, 0, 0, 0], bool), mask.shape)
    if not mech.couplings:
        return kinds[mask]
    from mechkin.model.couplings import coupling_position_rows

    return np.concatenate([kinds[mask], coupling_position_rows(mech)])


def constraint_scaling(mech: Mechanism, length_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Row (n_eq,) and column (n_w,) factors of the nondimensionalised ``Phi_w``.

    ``row * Phi_w * col``: position rows of the cut residuals divided by L, columns of
    prismatic dependent joints multiplied by L (module docstring).
    """
    row = (np.where(_row_is_position(mech), 1.0 / length_scale, 1.0) if mech.is_closed
           else np.ones(0))
    col = np.where(mech.s[mech.dependent] == 1, length_scale, 1.0)
    return row, col


def reduced_scaling(mech: Mechanism, length_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Row (6,) and column (n_v,) factors of the nondimensionalised ``J_r``: v rows / L,
    prismatic independent columns * L."""
    row = np.array([1.0, 1.0, 1.0] + [1.0 / length_scale] * 3)
    return row, np.where(mech.s[mech.independent] == 1, length_scale, 1.0)


def resolve_length_scale(mech: Mechanism, length_scale: float | None) -> float:
    """``length_scale`` checked (> 0), or :func:`characteristic_length` when None."""
    L = characteristic_length(mech) if length_scale is None else float(length_scale)
    if not L > 0.0:
        raise ValueError(f"length_scale must be > 0, got {L}")
    return L


def _level(ratio: np.ndarray, tol_singular: float, tol_near: float) -> np.ndarray:
    out = np.full(ratio.shape, "regular", dtype=object)
    out[ratio < tol_near] = "near"
    out[ratio < tol_singular] = "singular"
    out[np.isnan(ratio)] = "regular"
    return out


def classify(
    mech: Mechanism,
    q: np.ndarray,
    *,
    end_effector: int | str | None = None,
    length_scale: float | None = None,
    tol_singular: float | None = None,
    tol_near: float | None = None,
    kin: Kinematics | None = None,
    Phi: np.ndarray | None = None,
    S: np.ndarray | None = None,
    s_constraint: np.ndarray | None = None,
) -> SingularityReport:
    r"""Condition numbers of ``Phi_w`` and ``J_r`` and the singularity class of each configuration.

    Parameters
    ----------
    q : (m, n)
        Assembled configurations (the closure solved).
    end_effector : frame name or index
        Frame of the reduced Jacobian ``J_r`` (kim1995 Eq. (10)); default
        ``mech.end_effector``; without one only constraint singularities are classified.
    length_scale : float, optional
        L [m] of the nondimensionalisation (module docstring); default
        :func:`characteristic_length`.
    tol_singular, tol_near : float, optional
        Thresholds on ``sigma_min / sigma_max`` (defaults :data:`TOL_SINGULAR`,
        :data:`TOL_NEAR`).
    kin, Phi, S, s_constraint
        Already computed kinematics, closure Jacobian ``dphi/dq`` (m, n_eq, n), sensitivity
        ``S`` and singular values of the nondimensionalised ``Phi_w`` (reused by
        :func:`mechkin.model.differential.motion_derivatives`).
    """

    tol_singular = TOL_SINGULAR if tol_singular is None else float(tol_singular)
    tol_near = TOL_NEAR if tol_near is None else float(tol_near)
    if not 0.0 < tol_singular <= tol_near < 1.0:
        raise ValueError(f"thresholds: need 0 < tol_singular ({tol_singular}) <= tol_near "
                         f"({tol_near}) < 1")
    L = resolve_length_scale(mech, length_scale)
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    m = q.shape[0]
    ok = np.isfinite(q).all(axis=1)
    if not ok.all():  # failed closure steps: nan measures, "undefined" class

        sub = classify(mech, q[ok], end_effector=end_effector, length_scale=L,
                       tol_singular=tol_singular, tol_near=tol_near,
                       S=None if S is None else S[ok],
                       s_constraint=None if s_constraint is None else s_constraint[ok])
        return scatter_rows(sub, ok)
    kin = forward_kinematics(mech, q) if kin is None else kin
    iv, iw = mech.independent, mech.dependent
    if Phi is None:
        _, Phi = closure_jacobian(mech, kin)
    Phi_w = Phi[:, :, iw]
    if len(iw):
        if s_constraint is None:
            row, col = constraint_scaling(mech, L)
            Pw = Phi_w * row[None, :, None] * col[None, None, :]
            s_constraint = (np.linalg.svd(Pw, compute_uv=False) if Pw.shape[1]
                            else np.zeros((m, 0)))
        cond_constraint = _cond_scaled(s_constraint, len(iw))
    else:
        cond_constraint = np.ones(m)
    f = (mech.end_effector if end_effector is None
         else int(_frame_indices(mech, [end_effector])[0]))
    if f is None or len(iv) == 0:
        cond_reduced = np.full(m, np.nan)
        ee_name = None if f is None else mech.frame_names[f]
    else:
        if S is None and len(iw):
            S = -_svd_pinv(Phi_w)[0] @ Phi[:, :, iv]
        Jr = reduced_jacobian(mech, q, f, kin=kin, S=S)
        row, col = reduced_scaling(mech, L)
        Jr = Jr * row[None, :, None] * col[None, None, :]
        s_r = np.linalg.svd(Jr, compute_uv=False)
        cond_reduced = _cond_scaled(s_r, min(6, len(iv)))
        ee_name = mech.frame_names[f]
    lc = _level(_inv(cond_constraint), tol_singular, tol_near)
    li = _level(_inv(cond_reduced), tol_singular, tol_near)
    kind = np.empty(m, dtype=object)
    label = np.empty(m, dtype=object)
    for k in range(m):
        c_s, i_s = lc[k] == "singular", li[k] == "singular"
        kind[k] = (SingularityKind.BOTH if c_s and i_s else SingularityKind.CONSTRAINT if c_s
                   else SingularityKind.INVERSE_KINEMATIC if i_s else SingularityKind.REGULAR)
        parts = [kind[k].value] if kind[k] is not SingularityKind.REGULAR else []
        if lc[k] == "near":
            parts.append("near constraint singularity")
        if li[k] == "near":
            parts.append("near inverse-kinematic singularity")
        label[k] = "; ".join(parts) if parts else "regular"
    return SingularityReport(
        cond_constraint=cond_constraint, cond_reduced=cond_reduced,
        constraint_level=lc, inverse_level=li, kind=kind, label=label, length_scale=L,
        tol_singular=tol_singular, tol_near=tol_near, end_effector=ee_name, phi_w=Phi_w)


CROSSED = "constraint singularity crossed"


def constraint_crossings(mech: Mechanism, q: np.ndarray, ok: np.ndarray,
                         report: SingularityReport) -> np.ndarray:
    r"""(m,) bool: a motion q (m, n) crossed a constraint singularity just before step k.

    Between two consecutive assembled, non-singular steps i < k (``ok``, and no singular level
    in ``report``) the nondimensionalised ``Phi_w`` changes orientation,
    :math:`\det(\Phi_{w,i}^T \Phi_{w,k}) < 0` (for a square ``Phi_w`` the sign of
    :math:`\det\Phi_w` flips): a singular value passed through zero between them, e.g. a
    four-bar at a Grashof change point (all links in line, two assembly modes crossing) or a
    parallelogram folding flat, stepped over between samples. Steps with a singular sample
    between them are not flagged again (that sample already is). Rows with no dependent joint
    never cross.

    References
    ----------
    Allgower and Georg (2003) §8.1: a simple bifurcation point is detected by the sign change
    of the determinant along the solution curve.
    """
    m = q.shape[0]
    out = np.zeros(m, dtype=bool)
    iw = mech.dependent
    if len(iw) == 0 or not mech.is_closed:
        return out
    bad = np.asarray(report.constraint_level == "singular", dtype=bool)
    keep = np.flatnonzero(np.asarray(ok, bool) & np.isfinite(q).all(axis=1) & ~bad)
    if keep.size < 2:
        return out
    _, Phi = closure_jacobian(mech, forward_kinematics(mech, q[keep]))
    row, col = constraint_scaling(mech, report.length_scale)
    if row.size != Phi.shape[1]:
        row = np.ones(Phi.shape[1])
    A = Phi[:, :, iw] * row[None, :, None] * col[None, None, :]
    with np.errstate(all="ignore"):
        d = np.linalg.det(np.swapaxes(A[:-1], 1, 2) @ A[1:])
    flip = d < 0
    gap = np.array([bad[i + 1:k].any() for i, k in zip(keep[:-1], keep[1:], strict=True)],
                   dtype=bool) if flip.any() else np.zeros(len(d), bool)
    out[keep[1:][flip & ~gap]] = True
    return out


def crossings_along(mech: Mechanism, q: np.ndarray, length_scale: float | None = None
                    ) -> np.ndarray:
    r"""(m,) bool: a sampled path q (m, n) of assembled configurations crossed a constraint
    singularity just before sample k, without a singularity report: as
    :func:`constraint_crossings` with the singular samples those whose nondimensionalised
    ``Phi_w`` has sigma_min / sigma_max below 1e-3 (the continuation's ``RATIO_SINGULAR``;
    such samples are skipped, so a crossing exactly on a sample is flagged at the next
    regular one). Rows that are not finite are skipped."""
    m = q.shape[0]
    out = np.zeros(m, dtype=bool)
    iw = mech.dependent
    if len(iw) == 0 or not mech.is_closed or m < 2:
        return out
    fin = np.flatnonzero(np.isfinite(q).all(axis=1))
    if fin.size < 2:
        return out
    L = resolve_length_scale(mech, length_scale)
    _, Phi = closure_jacobian(mech, forward_kinematics(mech, q[fin]))
    row, col = constraint_scaling(mech, L)
    if row.size != Phi.shape[1]:
        row = np.ones(Phi.shape[1])
    A = Phi[:, :, iw] * row[None, :, None] * col[None, None, :]
    s = np.linalg.svd(A, compute_uv=False)
    with np.errstate(all="ignore"):
        regular = s[:, -1] >= 1e-3 * s[:, 0]
    keep = fin[regular]
    A = A[regular]
    if keep.size < 2:
        return out
    with np.errstate(all="ignore"):
        d = np.linalg.det(np.swapaxes(A[:-1], 1, 2) @ A[1:])
    out[keep[1:][d < 0]] = True
    return out


def mark_crossings(report: SingularityReport, crossed: np.ndarray) -> SingularityReport:
    """The report with the steps ``crossed`` (m,) at the constraint singular level, kind
    ``CONSTRAINT`` (``BOTH`` with an inverse-kinematic singularity) and label
    :data:`CROSSED` (:func:`constraint_crossings`)."""
    if not np.any(crossed):
        return report
    from dataclasses import replace

    lc = report.constraint_level.copy()
    kind = report.kind.copy()
    label = report.label.copy()
    for k in np.flatnonzero(crossed):
        lc[k] = "singular"
        both = report.inverse_level[k] == "singular"
        kind[k] = SingularityKind.BOTH if both else SingularityKind.CONSTRAINT
        label[k] = CROSSED + ("; inverse-kinematic singularity" if both else "")
    return replace(report, constraint_level=lc, kind=kind, label=label)


def mechanism_singularity_at_home(mech: Mechanism) -> dict[str, Any]:
    """Singularity measures at the home configuration, as JSON-ready values (``mechkin info``).

    The dependent joints are closed from their home values first (:func:`solve_closure`); if
    that fails the home values are used as they are and ``closure_converged`` is false.
    ``constraint`` is None without dependent joints, ``end_effector`` None without an
    end-effector frame; infinite condition numbers are written as None (JSON has no inf).
    """
    from mechkin.model.closure import ClosureStatus, solve_closure

    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    converged = True
    if mech.is_closed and len(mech.dependent):
        res = solve_closure(mech, q0[:, mech.independent], q0[:, mech.dependent])
        converged = res.status[0] is ClosureStatus.CONVERGED
        if converged:
            q0 = res.q
    rep = classify(mech, q0)

    def num(x: float) -> float | None:
        return None if not np.isfinite(x) else float(x)

    return {
        "closure_converged": bool(converged),
        "class": str(rep.label[0]),
        "kind": rep.kind[0].value,
        "length_scale_m": rep.length_scale,
        "tol_singular": rep.tol_singular,
        "tol_near": rep.tol_near,
        "constraint": None if not len(mech.dependent) else {
            "cond": num(rep.cond_constraint[0]),
            "cond_unscaled": num(rep.cond_closure[0]),
            "ratio": float(rep.ratio_constraint[0]),
            "level": str(rep.constraint_level[0])},
        "end_effector": None if rep.end_effector is None else {
            "frame": rep.end_effector,
            "cond": num(rep.cond_reduced[0]),
            "ratio": None if np.isnan(rep.ratio_reduced[0]) else float(rep.ratio_reduced[0]),
            "level": str(rep.inverse_level[0])},
    }

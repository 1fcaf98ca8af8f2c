r"""The fk run's rates and singularity classes as whole-motion array work (open chains), and the
per-step labels, counts and statuses of any fk run without per-step Python.

Design
------
:func:`mechkin.model.differential.motion_derivatives` is already batched, but for an open chain
(no cut, no dependent joint) most of it is empty work, and its classification
(:func:`mechkin.model.singularity.classify`) names each step in a Python loop.
:func:`open_chain_derivatives` returns the same :class:`MotionDerivatives`, bit for bit, for an
open chain from the run's own :class:`Kinematics` (no second forward kinematics): with
``q_w`` empty, kim1995 Eq. (3)-(4) differentiated give ``qd = qd_v``, ``qdd = qdd_v``,
``S`` (m, 0, n_v) and ``gamma`` (m, 0); the link twists and accelerations are
:func:`mechkin.model.differential.link_motion` with ``qdd`` (kim1995 §2, the derivative of the
Eq. (2) chain), the frame twists :func:`frame_motion`, and the reduced Jacobian of kim1995
Eq. (10) is the end-effector Jacobian's independent columns, nondimensionalised and measured by
one batched SVD (``numpy.linalg.svd`` of the (m, 6, n_v) stack, the call ``classify`` makes).
The classes come from the two levels by a table over the 16 combinations
(:func:`classify_levels`), the rule of ``classify`` evaluated once per combination instead of
once per step. tests/tasks/test_fk_batch.py checks every field against ``motion_derivatives``
(exactly, and the rates to 1e-12 on random motions of the bundled open chains).

Imports: model (kinematics, differential, reduced, singularity).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from mechkin.model.differential import (
    LinkMotion,
    MotionDerivatives,
    _ancestors,
    frame_motion,
    joint_twists,
    link_motion,
)
from mechkin.model.kinematics import Kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.model.reduced import reduced_jacobian
from mechkin.model.singularity import (
    TOL_NEAR,
    TOL_SINGULAR,
    SingularityKind,
    SingularityReport,
    _cond_scaled,
    _inv,
    _level,
    reduced_scaling,
    resolve_length_scale,
)

_LEVELS = ("regular", "near", "singular")


def _label_table() -> tuple[np.ndarray, np.ndarray]:
    """Kind and label of each (constraint level, inverse level) pair, indexed 3 * c + i
    (levels in :data:`_LEVELS` order): the rule of ``classify``, evaluated once per pair."""
    kinds = np.empty(9, dtype=object)
    labels = np.empty(9, dtype=object)
    for c, lc in enumerate(_LEVELS):
        for i, li in enumerate(_LEVELS):
            c_s, i_s = lc == "singular", li == "singular"
            kind = (SingularityKind.BOTH if c_s and i_s else SingularityKind.CONSTRAINT if c_s
                    else SingularityKind.INVERSE_KINEMATIC if i_s else SingularityKind.REGULAR)
            parts = [kind.value] if kind is not SingularityKind.REGULAR else []
            if lc == "near":
                parts.append("near constraint singularity")
            if li == "near":
                parts.append("near inverse-kinematic singularity")
            kinds[3 * c + i] = kind
            labels[3 * c + i] = "; ".join(parts) if parts else "regular"
    return kinds, labels


_KINDS, _LABELS = _label_table()


def _level_code(level: np.ndarray) -> np.ndarray:
    """0, 1, 2 for the levels regular, near, singular of an object array (m,)."""
    code = np.zeros(len(level), dtype=np.intp)
    code[level == "near"] = 1
    code[level == "singular"] = 2
    return code


def classify_levels(lc: np.ndarray, li: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinds (m,) and labels (m,) (object arrays) from the constraint and inverse-kinematic
    levels, as :func:`mechkin.model.singularity.classify` names them."""
    k = 3 * _level_code(lc) + _level_code(li)
    return _KINDS[k], _LABELS[k]


def is_open_chain(mech: Mechanism) -> bool:
    """No cut and no dependent joint: every step is its own closed-form configuration."""
    return mech.n_cuts == 0 and len(mech.dependent) == 0


def open_chain_derivatives(mech: Mechanism, kin: Kinematics, qd_v: np.ndarray,
                           qdd_v: np.ndarray, frames: np.ndarray | list[int],
                           length_scale: float | None = None,
                           tol_singular: float | None = None,
                           tol_near: float | None = None) -> MotionDerivatives:
    r"""``motion_derivatives(mech, kin.q, qd_v, qdd_v, frames)`` of an open chain, from ``kin``.

    .. math:: \dot q = \dot q_v,\qquad \ddot q = \ddot q_v,\qquad
              J_r = J_E L_v\ \text{(kim1995 Eq. (10) with no } q_w\text{)}

    Parameters
    ----------
    mech : Mechanism
        An open chain (:func:`is_open_chain`).
    kin : Kinematics
        The forward kinematics of the m configurations (all finite).
    qd_v, qdd_v : (m, n_v)
        Rates and accelerations of the (independent) joints [rad | m, /s, /s^2].
    frames : (k,) int
        Frames whose twists and accelerations are returned.

    Returns
    -------
    MotionDerivatives
        Equal, field by field, to :func:`mechkin.model.differential.motion_derivatives`.
    """
    if not is_open_chain(mech):
        raise ValueError(f"{mech.name}: not an open chain (cuts or dependent joints)")
    q = kin.q
    m = q.shape[0]
    iv = mech.independent
    idx = np.asarray(frames, dtype=int)
    qd_v = np.broadcast_to(np.asarray(qd_v, dtype=np.float64), (m, len(iv)))
    qdd_v = np.broadcast_to(np.asarray(qdd_v, dtype=np.float64), (m, len(iv)))
    L = resolve_length_scale(mech, length_scale)
    if m <= RATE_CHUNK:
        return _open_chunk(mech, kin, qd_v, qdd_v, idx, L, tol_singular, tol_near)
    axes = kin.__dict__.get("_axes")
    parts = []
    for i in range(0, m, RATE_CHUNK):
        j = min(i + RATE_CHUNK, m)
        k = Kinematics(q=q[i:j], T_links=kin.T_links[i:j], mech=mech)
        if axes is not None:
            object.__setattr__(k, "_axes", (axes[0][i:j], axes[1][i:j]))
        parts.append(_open_chunk(mech, k, qd_v[i:j], qdd_v[i:j], idx, L, tol_singular,
                                 tol_near))
    return _concat(parts)


#: Samples per chunk of :func:`open_chain_derivatives` (the intermediates, (chunk, links, 6)
#: and (chunk, joints, 4, 4) arrays, stay in cache). Every operation is per sample (elementwise
#: products, one small matrix product or SVD per sample), so the numbers do not depend on it.
RATE_CHUNK = 8192


def _concat(parts: list[MotionDerivatives]) -> MotionDerivatives:
    """One MotionDerivatives of consecutive chunks (sample axis first)."""
    import dataclasses

    def cat(objs, name):
        return np.concatenate([getattr(o, name) for o in objs])

    first, sings = parts[0], [p.singularity for p in parts]
    sing = dataclasses.replace(
        sings[0], **{f: cat(sings, f) for f in ("cond_constraint", "cond_reduced",
                                                 "constraint_level", "inverse_level", "kind",
                                                 "label", "phi_w")})
    return dataclasses.replace(
        first, **{f: cat(parts, f) for f in ("q", "qd", "qdd", "S", "gamma",
                                             "closure_rate_residual", "closure_accel_residual",
                                             "twists", "accelerations", "positions")},
        singularity=sing)


def _open_chunk(mech: Mechanism, kin: Kinematics, qd_v: np.ndarray, qdd_v: np.ndarray,
                idx: np.ndarray, L: float, tol_singular: float | None,
                tol_near: float | None) -> MotionDerivatives:
    """:func:`open_chain_derivatives` of one chunk."""
    q = kin.q
    m = q.shape[0]
    iv = mech.independent
    empty_w = np.zeros((m, 0))
    qd = mech.assemble(qd_v, empty_w)
    qdd = mech.assemble(qdd_v, empty_w)
    xi = joint_twists(mech, kin)
    lm0 = link_motion(mech, kin, qd, xi=xi)  # qdd = 0: velocity-product accelerations
    lm = LinkMotion(lm0.V, lm0.A + _ancestors(mech) @ (xi * qdd[..., None]))
    tw, acc = frame_motion(mech, kin, lm, idx)
    tol_singular = TOL_SINGULAR if tol_singular is None else float(tol_singular)
    tol_near = TOL_NEAR if tol_near is None else float(tol_near)
    cond_constraint = np.ones(m)
    f = mech.end_effector
    if f is None or len(iv) == 0:
        cond_reduced = np.full(m, np.nan)
        ee_name = None if f is None else mech.frame_names[f]
    else:
        Jr = reduced_jacobian(mech, q, f, kin=kin)
        row, col = reduced_scaling(mech, L)
        s_r = np.linalg.svd(Jr * row[None, :, None] * col[None, None, :], compute_uv=False)
        cond_reduced = _cond_scaled(s_r, min(6, len(iv)))
        ee_name = mech.frame_names[f]
    lc = _level(_inv(cond_constraint), tol_singular, tol_near)
    li = _level(_inv(cond_reduced), tol_singular, tol_near)
    kind, label = classify_levels(lc, li)
    report = SingularityReport(
        cond_constraint=cond_constraint, cond_reduced=cond_reduced, constraint_level=lc,
        inverse_level=li, kind=kind, label=label, length_scale=L, tol_singular=tol_singular,
        tol_near=tol_near, end_effector=ee_name, phi_w=np.zeros((m, 0, 0)))
    return MotionDerivatives(
        q=q, qd=qd, qdd=qdd, S=np.zeros((m, 0, len(iv))), gamma=np.zeros((m, 0)),
        closure_rate_residual=np.zeros(m), closure_accel_residual=np.zeros(m), frames=idx,
        frame_names=tuple(mech.frame_names[i] for i in idx), twists=tw, accelerations=acc,
        positions=kin.frames(mech, idx)[:, :, :3, 3], singularity=report)


def singular_masks(sing: SingularityReport) -> tuple[np.ndarray, np.ndarray]:
    """(m,) bool ``singular`` and ``near`` of a report, from its levels (the report's own
    properties test each step's kind in Python)."""
    c, i = np.asarray(sing.constraint_level), np.asarray(sing.inverse_level)
    singular = (c == "singular") | (i == "singular")
    near = ~singular & ((c == "near") | (i == "near"))
    return singular, near


def label_counts(labels: Any) -> dict[str, int]:
    """Steps per label, in the order of first appearance."""
    return dict(Counter(map(str, labels)))


def status_values(status: np.ndarray, members: Any) -> tuple[np.ndarray, dict[Any, np.ndarray]]:
    """Status strings (m,) (object array) of an array of enum members, and a bool mask per
    member: one comparison per member instead of one attribute lookup per step."""
    status = np.asarray(status, dtype=object)
    out = np.empty(len(status), dtype=object)
    masks = {}
    for mm in members:
        hit = status == mm
        out[hit] = mm.value
        masks[mm] = hit
    left = np.flatnonzero(np.equal(out, None))
    for k in left.tolist():  # not a member (never in practice): its value as before
        out[k] = status[k].value
    return out, masks

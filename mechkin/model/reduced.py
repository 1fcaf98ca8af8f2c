"""The reduced end-effector Jacobian through the loop closure (kim1995 Eq. (10)) and the small
linear-algebra helpers that the differential kinematics and the singularity measures share.

Imports: model.kinematics, model.mechanism (below both :mod:`mechkin.model.differential` and
:mod:`mechkin.model.singularity`).
"""

from __future__ import annotations

import numpy as np

from mechkin.model.kinematics import (
    Kinematics,
    closure_jacobian,
    forward_kinematics,
    frame_jacobian,
)
from mechkin.model.mechanism import Mechanism

RCOND = 1e-12  # singular values below RCOND * sigma_max are dropped by the pseudo-inverse


def _svd_pinv(J: np.ndarray, rcond: float = RCOND) -> tuple[np.ndarray, np.ndarray]:
    """Pseudo-inverse (m, c, r) of a stack J (m, r, c) and its singular values (m, min(r, c))."""
    m, r, c = J.shape
    if m == 0 or r == 0 or c == 0:
        return np.zeros((m, c, r)), np.zeros((m, min(r, c)))
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    keep = s > rcond * np.maximum(s[:, :1], 1e-300)
    sinv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    return np.swapaxes(Vt, 1, 2) @ (sinv[:, :, None] * np.swapaxes(U, 1, 2)), s


def _frame_indices(mech: Mechanism, frames) -> np.ndarray:
    if frames is None:
        return np.arange(len(mech.frame_names))
    if isinstance(frames, (str, int, np.integer)):
        frames = [frames]
    out = []
    for f in frames:
        if isinstance(f, str):
            out.append(mech.frame_index(f))
        else:
            fi = int(f)
            if not 0 <= fi < len(mech.frame_names):
                raise KeyError(f"frame index {fi} out of range (0..{len(mech.frame_names) - 1})")
            out.append(fi)
    return np.asarray(out, dtype=int)


def scatter_rows(rec, ok: np.ndarray, **keep):
    """A record (dataclass) of the rows ``ok`` (m,) spread back to m rows: float arrays nan,
    object arrays (labels) "undefined" (enum members: their ``UNDEFINED``); fields in ``keep``
    replaced as given. Arrays that do not have the sample axis first (e.g. frame indices) and
    scalars are kept."""
    import dataclasses

    m, n_ok = len(ok), int(ok.sum())
    out = {}
    for f in dataclasses.fields(rec):
        if not f.init:
            continue
        v = getattr(rec, f.name)
        if f.name in keep:
            out[f.name] = keep[f.name]
        elif dataclasses.is_dataclass(v):
            out[f.name] = scatter_rows(v, ok)
        elif isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n_ok and f.name != "frames":
            if v.dtype == object:
                fill = next((type(x).UNDEFINED for x in v if hasattr(type(x), "UNDEFINED")),
                            "undefined")
                full = np.full(m, fill, dtype=object)
            else:
                full = np.full((m,) + v.shape[1:], np.nan)
            full[ok] = v
            out[f.name] = full
        else:
            out[f.name] = v
    return type(rec)(**out)


def reduced_jacobian(mech: Mechanism, q: np.ndarray, frame: int | str | None = None, *,
                     kin: Kinematics | None = None, S: np.ndarray | None = None) -> np.ndarray:
    r"""End-effector Jacobian through the loop closure, ``J_r = dx_E/dq_v`` (m, 6, n_v).

    .. math:: J_r = J_E L_v + J_E L_w S,\qquad S = -\Phi_w^+\Phi_v

    (kim1995 Eq. (10)), rows ``(omega, v)`` of the frame's origin in the base frame, so
    ``twist_E = J_r qd_v``. ``frame`` defaults to ``mech.end_effector``.
    """
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    kin = forward_kinematics(mech, q) if kin is None else kin
    f = mech.end_effector if frame is None else _frame_indices(mech, [frame])[0]
    if f is None:
        raise ValueError(f"{mech.name}: no end effector frame; pass frame=")
    J = frame_jacobian(mech, kin, int(f))
    Jr = J[:, :, mech.independent]
    if len(mech.dependent):
        if S is None:
            _, Phi = closure_jacobian(mech, kin)
            S = -_svd_pinv(Phi[:, :, mech.dependent])[0] @ Phi[:, :, mech.independent]
        Jr = Jr + J[:, :, mech.dependent] @ S
    return Jr

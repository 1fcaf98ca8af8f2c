"""Closed forms chosen by the mechanism's structure, not by its name.

A mechanism file may declare ``closed_form: stewart | direct_drive | lee_spherical``
(:class:`mechkin.config.schema.MechanismSpec`). :func:`check_closed_form` reads the closed
form's parameters from the model's geometry at home (Stewart: base and platform points of every
leg, any 6-6 or 3-6 platform; direct-drive: d1 and the link lengths; lee: radii, angles, centre
and stroke) and raises :class:`ClosedFormMismatch` (a ModelError) naming the joint, frame or
dimension that does not fit. :func:`recognise_closed_form` checks the declared form, or, with
none declared, returns the first form that fits (or None). :func:`closed_form_ik` and
:func:`closed_form_solutions` solve poses with it, through the leg decomposition
(:mod:`mechkin.solvers.ik.analytic.legs`) of which these closed forms are cases.

DESIGN: the Mechanism object does not carry the declaration (mechkin.model builds it from the
spec); :func:`declared_closed_form` reads it from ``mech.closed_form`` when the model provides
that attribute, else from the mechanism's source file. The geometry is read once per Mechanism
and cached on it (like the kinematics' constant factors).

References
----------
kim1995_complex_chain_ik §6.1 appendix (direct drive), §6.2 (Stewart); lee_spherical_3dof_parallel
Eqs. (2)-(9).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.closed_form.stewart import (
    ClosedFormMismatch,
    StewartGeometry,
    assembled_home,
    concurrent_point,
    size_of,
    stewart_geometry,
)

CLOSED_FORM_KINDS = ("stewart", "direct_drive", "lee_spherical")

__all__ = [
    "CLOSED_FORM_KINDS",
    "ClosedFormMismatch",
    "LeeModelGeometry",
    "check_closed_form",
    "closed_form_ik",
    "closed_form_solutions",
    "declared_closed_form",
    "recognise_closed_form",
]


@dataclass(frozen=True)
class LeeModelGeometry:
    """lee's mechanism read from a model: the paper's parameters and the legs' model geometry
    (for the joint values: ``legs.joint_values(T)``)."""

    geometry: Any  # mechkin.solvers.closed_form.lee_spherical.LeeGeometry
    legs: StewartGeometry


def declared_closed_form(mech: Mechanism) -> str | None:
    """The ``closed_form:`` of the mechanism's file (None if absent or no file)."""
    if hasattr(mech, "closed_form"):
        return getattr(mech, "closed_form")  # noqa: B009 - set by a model that carries it
    cache = mech.__dict__.get("_declared_closed_form", ())
    if cache == ():
        cache = None
        if mech.source is not None:
            from mechkin.config.mechanism_file import read_mechanism_spec

            spec, _ = read_mechanism_spec(mech.source)
            cache = getattr(spec, "closed_form", None)
        object.__setattr__(mech, "_declared_closed_form", cache)
    return cache


def _lee_geometry(mech: Mechanism) -> LeeModelGeometry:
    """lee §2.1: three U-P-S legs from base points on a circle about z0 (z = 0) to top points on
    a circle about the plate origin, the plate carried by concurrent revolutes at its origin."""
    from mechkin.solvers.closed_form.lee_spherical import LeeGeometry

    name = mech.name
    legs = stewart_geometry(mech, n_legs=3, platform_on_leg=False)
    kin = assembled_home(mech)
    tol = 1e-7 * size_of(mech, kin)
    e_link = int(mech.frame_link[mech.end_effector])
    carrier = []
    link = e_link
    while mech.link_parent_joint[link] >= 0:
        j = int(mech.link_parent_joint[link])
        carrier.insert(0, j)
        link = int(mech.joint_parent_link[j])
    for j in carrier:
        if mech.s[j] != 0 or j in mech.independent:
            raise ClosedFormMismatch(f"{name}: joint {mech.joint_names[j]} carries the plate and "
                                     "is not a passive revolute (lee: a passive RRR chain)")
    if len(carrier) != 3:
        raise ClosedFormMismatch(f"{name}: the plate hangs on {len(carrier)} joints, lee's "
                                 "passive chain has 3 concurrent revolutes")
    z, o = (x[0] for x in kin.axes())
    P = concurrent_point(mech, carrier, z, o, tol, "plate chain")
    T_E = kin.frames(mech, [mech.end_effector])[0, 0]
    if np.linalg.norm(T_E[:3, 3] - P) > tol:
        raise ClosedFormMismatch(f"{name}: frame {mech.frame_names[mech.end_effector]} is "
                                 f"{np.linalg.norm(T_E[:3, 3] - P):.3g} m from the plate "
                                 "chain's centre (lee: {E} at the centre P)")
    a = legs.a
    if np.abs(a[:, 2]).max() > tol:
        raise ClosedFormMismatch(f"{name}: base joint centres not in the plane z = 0 of the "
                                 f"base (z = {np.round(a[:, 2], 6).tolist()})")
    Rs = np.linalg.norm(a[:, :2], axis=1)
    rs = np.linalg.norm(legs.b, axis=1)
    if np.ptp(Rs) > tol or np.ptp(rs) > tol or np.abs(legs.b[:, 2]).max() > tol:
        raise ClosedFormMismatch(f"{name}: base radii {np.round(Rs, 6).tolist()} and top radii "
                                 f"{np.round(rs, 6).tolist()} (top z "
                                 f"{np.round(legs.b[:, 2], 6).tolist()}): lee needs equal radii "
                                 "and a flat top")
    if np.abs(legs.sigma - 1).max() > 0 or np.abs(legs.c).max() > tol:
        raise ClosedFormMismatch(f"{name}: the leg joints are not the leg lengths (offsets "
                                 f"{np.round(legs.c, 6).tolist()} m)")
    iv = mech.independent
    lo, hi = mech.lower[iv], mech.upper[iv]
    geom = LeeGeometry(r=float(rs.mean()), R=float(Rs.mean()),
                       base_angles=tuple(float(v) for v in np.arctan2(a[:, 1], a[:, 0])),
                       top_angles=tuple(float(v) for v in np.arctan2(legs.b[:, 1],
                                                                      legs.b[:, 0])),
                       center=tuple(float(v) for v in P),
                       l_min=float(np.max(lo)) if np.all(np.isfinite(lo)) else 0.0,
                       l_max=float(np.min(hi)) if np.all(np.isfinite(hi)) else 1e300)
    return LeeModelGeometry(geometry=geom, legs=legs)


def check_closed_form(mech: Mechanism, kind: str) -> Any:
    """Parameters of closed form ``kind`` read from ``mech``'s geometry.

    Returns
    -------
    StewartGeometry | DirectDriveGeometry | LeeModelGeometry

    Raises
    ------
    ClosedFormMismatch
        (a ModelError) naming the joint, frame or dimension that does not fit, or an unknown
        ``kind``.
    """
    if kind not in CLOSED_FORM_KINDS:
        raise ClosedFormMismatch(f"{mech.name}: unknown closed form {kind!r} (known: "
                                 f"{', '.join(CLOSED_FORM_KINDS)})")
    cache = mech.__dict__.setdefault("_closed_form_geometry", {})
    if kind not in cache:
        try:
            if kind == "stewart":
                cache[kind] = stewart_geometry(mech, n_legs=6)
            elif kind == "direct_drive":
                from mechkin.solvers.closed_form.direct_drive import direct_drive_geometry

                cache[kind] = direct_drive_geometry(mech)
            else:
                cache[kind] = _lee_geometry(mech)
        except ClosedFormMismatch as exc:
            cache[kind] = exc
    got = cache[kind]
    if isinstance(got, ClosedFormMismatch):
        raise ClosedFormMismatch(f"closed_form {kind}: {got}")
    return got


def recognise_closed_form(mech: Mechanism) -> str | None:
    """The closed form that solves ``mech``: the declared one (checked: ClosedFormMismatch if
    it does not fit), else the first of :data:`CLOSED_FORM_KINDS` that fits, else None."""
    declared = declared_closed_form(mech)
    if declared is not None:
        check_closed_form(mech, declared)
        return declared
    for kind in CLOSED_FORM_KINDS:
        try:
            check_closed_form(mech, kind)
        except ClosedFormMismatch:
            continue
        return kind
    return None


def _by_legs(mech: Mechanism, T: np.ndarray, tol: float) -> list[np.ndarray] | None:
    """Every solution (k_i, n_v) of the independent joints per pose T (m, 4, 4) by the leg
    decomposition (:func:`mechkin.solvers.ik.analytic.legs.legs_all`: every combination of the
    legs' branches within the limits, each leg's end within ``tol``), distinct values (1e-9,
    revolute joints modulo 2 pi) nearest home first; None when a leg does not decompose."""
    from mechkin.solvers.ik.all_solutions import first_of_clusters
    from mechkin.solvers.ik.analytic.legs import legs_all, legs_for

    legs = legs_for(mech)
    if legs is None:
        return None
    iv = mech.independent
    ref = np.where(np.isfinite(mech.home), mech.home, 0.0)
    out = []
    for Ti in T:
        qv = legs_all(mech, legs, Ti, ref, tol)[:, iv]
        out.append(qv[first_of_clusters(mech, iv, qv, 1e-9)] if len(qv) else qv)
    return out


def _formula_solutions(mech: Mechanism, T: np.ndarray, kind: str, tol: float
                       ) -> list[np.ndarray]:
    """The hand-written formulas (kim1995's appendix, the leg lengths |p + R b_i - a_i|), for a
    mechanism that fits ``kind`` but whose legs do not decompose (e.g. S-P-S legs: a free spin
    of each leg about itself)."""
    g = check_closed_form(mech, kind)
    if kind == "direct_drive":
        from mechkin.solvers.closed_form.direct_drive import direct_drive_solutions

        return direct_drive_solutions(T, tol=tol, **g.params)
    legs = g if kind == "stewart" else g.legs
    q = legs.joint_values(T)
    if kind == "lee_spherical":
        off = np.linalg.norm(T[:, :3, 3] - np.asarray(g.geometry.center), axis=1) > tol
        return [np.zeros((0, q.shape[1])) if bad else qk[None] for qk, bad in zip(q, off,
                                                                                 strict=True)]
    return [qk[None] for qk in q]


def closed_form_solutions(mech: Mechanism, T_0_E: np.ndarray,
                          kind: str | None = None, tol: float = 1e-6) -> list[np.ndarray]:
    """Every closed-form solution (k_i, n_v) of the independent joints, per pose (m, 4, 4),
    within the joint limits (passive joints included).

    The closed forms are cases of the leg decomposition of
    :mod:`mechkin.solvers.ik.analytic.legs`: ``kind`` (declared or recognised) is checked
    against the geometry (:func:`check_closed_form`), then the legs solve the pose (Stewart:
    six U-P-S legs, the leg lengths; lee: the central spherical joint and three U-P-S legs,
    none where {E} is not at the centre; direct drive: the crank, rod and forearm on the
    turning shoulder, then the upper arm). A mechanism that fits ``kind`` but whose legs do
    not decompose keeps the hand-written formulas.
    """
    T = np.asarray(T_0_E, dtype=np.float64).reshape(-1, 4, 4)
    kind = kind or recognise_closed_form(mech)
    if kind is None:
        raise ClosedFormMismatch(f"{mech.name}: no closed form fits this mechanism (known: "
                                 f"{', '.join(CLOSED_FORM_KINDS)})")
    check_closed_form(mech, kind)
    sols = _by_legs(mech, T, tol)
    return sols if sols is not None else _formula_solutions(mech, T, kind, tol)


def closed_form_ik(mech: Mechanism, T_0_E: np.ndarray, kind: str | None = None,
                   tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Independent joints (m, n_v) for poses (m, 4, 4) and a flag (m,) that a solution exists.

    The first solution of :func:`closed_form_solutions` (the one nearest home); where none
    exists, the hand-written formula's value (direct drive: the least-residual branch of
    kim1995's appendix; Stewart and lee: the leg lengths) with the flag False.
    """
    T = np.asarray(T_0_E, dtype=np.float64).reshape(-1, 4, 4)
    kind = kind or recognise_closed_form(mech)
    sols = closed_form_solutions(mech, T, kind, tol)
    ok = np.array([len(s) > 0 for s in sols])
    g = check_closed_form(mech, kind)  # type: ignore[arg-type]
    if ok.all():
        q_fallback = np.zeros((len(T), len(mech.independent)))
    elif kind == "direct_drive":
        from mechkin.solvers.closed_form.direct_drive import direct_drive_ik

        q_fallback, _ = direct_drive_ik(T, tol=tol, **g.params)
    else:
        q_fallback = (g if kind == "stewart" else g.legs).joint_values(T)
    q = np.array([s[0] if len(s) else qf for s, qf in zip(sols, q_fallback, strict=True)])
    return q.reshape(len(T), -1), ok

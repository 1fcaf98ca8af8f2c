r"""Closed-form inverse kinematics of a Stewart platform: leg lengths from the pose.

.. math:: l_i = \| p + R\, b_i - a_i \|

with a_i the base attachment points (base frame) and b_i the platform attachment points in the
end-effector frame {E} (kim1995 §6.2, Table 4; for the 3-6 platform of kim1995 the b_i repeat in
pairs). The actuated joint of leg i is prismatic along the line a_i b_i; its value is
``q_i = sigma_i l_i - c_i`` (``sigma_i = +-1`` the direction of the joint axis along a_i -> b_i,
``c_i`` the constant offset of its zero; kim1995: sigma = 1, c = 0).

DESIGN: :func:`stewart_geometry` reads every parameter from the mechanism itself, at its
assembled home configuration, so any 6-6 or 3-6 platform (or another number of legs) written in
the mechanism format is solved without naming it: each leg is a chain
base -> revolutes with concurrent axes (a_i) -> the prismatic leg -> revolutes with concurrent
axes (b_i) -> the platform (the end effector's link) or a cut link whose cut puts the joint
centre on a platform frame. Every departure from that structure raises
:class:`ClosedFormMismatch` naming the joint, link or frame and the dimension that differs.

References
----------
kim1995_complex_chain_ik §6.2, Tables 4-6 ("analytical solution", after Masory et al. 1992).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.errors import ModelError
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.spatial.transforms import invert

GEOM_TOL = 1e-7
"""Relative tolerance [-] (times the mechanism's size) of concurrency and collinearity checks."""


class ClosedFormMismatch(ModelError, ValueError):
    """A declared (or tried) closed form does not match the mechanism's geometry."""


@dataclass(frozen=True)
class StewartGeometry:
    """Legs of a Stewart-type mechanism, read from the model at home.

    legs : names of the prismatic (independent) leg joints, in the order of ``mech.independent``
    a : (k, 3) base points a_i in the base frame [m]
    b : (k, 3) platform points b_i in {E} [m]
    sigma : (k,) +-1, direction of the leg joint's axis along a_i -> b_i
    c : (k,) offset [m]: the joint value is ``sigma l - c``
    """

    legs: tuple[str, ...]
    a: np.ndarray
    b: np.ndarray
    sigma: np.ndarray
    c: np.ndarray

    def joint_values(self, T_0_E: np.ndarray) -> np.ndarray:
        """Leg joint values (m, k) for platform poses T_0_E (m, 4, 4)."""
        return self.sigma * leg_lengths(T_0_E, self.a, self.b) - self.c


def leg_lengths(T_0_E: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leg lengths (m, k) for platform poses T_0_E (m, 4, 4), base points a (k, 3) in {0} and
    platform points b (k, 3) in {E}."""
    T = np.asarray(T_0_E, dtype=np.float64).reshape(-1, 4, 4)
    B = np.einsum("mij,kj->mki", T[:, :3, :3], np.asarray(b, float)) + T[:, None, :3, 3]
    return np.linalg.norm(B - np.asarray(a, float)[None], axis=-1)


def assembled_home(mech: Mechanism):
    """Kinematics of the assembled home configuration (loop closure from home)."""
    res = solve_closure(mech, mech.home[mech.independent][None], mech.home[mech.dependent][None])
    if not res.ok[0]:
        raise ClosedFormMismatch(f"{mech.name}: the home configuration does not assemble (loop "
                                 "closure failed), so its geometry cannot be read")
    return forward_kinematics(mech, res.q)


def size_of(mech: Mechanism, kin) -> float:
    """A length scale of the mechanism [m]: the largest joint-axis point distance at home."""
    _, o = kin.axes()
    return max(float(np.abs(o[0]).max()), float(np.abs(kin.T_links[0, :, :3, 3]).max()), 1.0)


def concurrent_point(mech: Mechanism, joints: list[int], z: np.ndarray, o: np.ndarray,
                     tol: float, what: str) -> np.ndarray:
    """The common point of the axes of ``joints`` (least squares); ClosedFormMismatch naming
    the first joint whose axis misses it by more than ``tol``."""
    M = np.zeros((3, 3))
    r = np.zeros(3)
    for j in joints:
        P = np.eye(3) - np.outer(z[j], z[j])
        M += P
        r += P @ o[j]
    if len(joints) == 1:
        return o[joints[0]].copy()
    x = np.linalg.lstsq(M, r, rcond=None)[0]
    if np.linalg.matrix_rank(M, tol=1e-9) < 3:  # parallel axes: no single point
        names = ", ".join(mech.joint_names[j] for j in joints)
        raise ClosedFormMismatch(f"{mech.name}: {what}: the axes of {names} are parallel, not "
                                 "concurrent (expected a universal or spherical joint)")
    for j in joints:
        dist = float(np.linalg.norm((np.eye(3) - np.outer(z[j], z[j])) @ (x - o[j])))
        if dist > tol:
            raise ClosedFormMismatch(
                f"{mech.name}: {what}: joint {mech.joint_names[j]}'s axis misses the common "
                f"point of the other axes by {dist:.3g} m (expected concurrent axes)")
    return x


def _base_link(mech: Mechanism) -> int:
    return int(np.flatnonzero(mech.link_parent_joint < 0)[0])


def _path_from_base(mech: Mechanism, link: int) -> list[int]:
    """Joints from the base to ``link`` (base side first)."""
    path = []
    while mech.link_parent_joint[link] >= 0:
        j = int(mech.link_parent_joint[link])
        path.insert(0, j)
        link = int(mech.joint_parent_link[j])
    return path


def stewart_geometry(mech: Mechanism, n_legs: int | None = None, *,
                     platform_on_leg: bool = True) -> StewartGeometry:
    """Base points, platform points, directions and offsets of every leg, read at home.

    Parameters
    ----------
    mech : Mechanism
        Its independent joints are the legs (all prismatic); see the module docstring.
    n_legs : int, optional
        Required number of legs (6 for a Stewart platform); any number if None.
    platform_on_leg : bool
        The platform must hang on one of the legs (True: a Stewart platform); False allows
        another chain to carry it (lee's constrained platform).

    Raises
    ------
    ClosedFormMismatch
        Naming the joint, link or frame that does not fit (a ModelError and a ValueError).
    """
    name = mech.name
    if mech.end_effector is None:
        raise ClosedFormMismatch(f"{name}: no end_effector frame (the platform frame {{E}})")
    iv = [int(j) for j in mech.independent]
    if n_legs is not None and len(iv) != n_legs:
        raise ClosedFormMismatch(f"{name}: {len(iv)} independent joints, expected {n_legs} "
                                 "prismatic legs")
    for j in iv:
        if mech.s[j] != 1:
            raise ClosedFormMismatch(f"{name}: joint {mech.joint_names[j]} is not a prismatic "
                                     "leg (every independent joint must be a prismatic leg)")
    kin = assembled_home(mech)
    tol = GEOM_TOL * size_of(mech, kin)
    z, o = (x[0] for x in kin.axes())
    q = kin.q[0]
    e_link = int(mech.frame_link[mech.end_effector])
    T_E = kin.frames(mech, [mech.end_effector])[0, 0]
    T_E_0 = invert(T_E)
    base = _base_link(mech)
    # the platform must hang on one of the legs, not on another chain to the base
    carrier = _path_from_base(mech, e_link)
    if platform_on_leg and not any(j in carrier for j in iv):
        names = ", ".join(mech.joint_names[j] for j in carrier) or "nothing"
        raise ClosedFormMismatch(f"{name}: the platform link {mech.link_names[e_link]} hangs on "
                                 f"{names}, not on a leg: not a Stewart platform")
    cut_partner: dict[int, tuple[int, int, object]] = {}  # link -> (own frame, other frame, cut)
    for c in mech.cuts:
        for f_own, f_other in ((c.b, c.a), (c.a, c.b)):
            cut_partner.setdefault(int(mech.frame_link[f_own]), (f_own, f_other, c))
    a_pts, b_pts, sig, off = [], [], [], []
    for j in iv:
        jn = mech.joint_names[j]
        before = _path_from_base(mech, int(mech.joint_parent_link[j]))
        if not before or int(mech.joint_parent_link[before[0]]) != base:
            raise ClosedFormMismatch(f"{name}: leg {jn}: no joint between the base and the leg")
        for k in before:
            if mech.s[k] != 0 or k in iv:
                raise ClosedFormMismatch(f"{name}: leg {jn}: joint {mech.joint_names[k]} between "
                                         "the base and the leg is not a passive revolute")
        A = concurrent_point(mech, before, z, o, tol, f"leg {jn} base joint")
        after: list[int] = []
        link = int(mech.joint_child_link[j])
        while link != e_link:
            kids = np.flatnonzero(mech.joint_parent_link == link)
            if kids.size == 0:
                break
            if kids.size > 1:
                raise ClosedFormMismatch(f"{name}: leg {jn} branches at link "
                                         f"{mech.link_names[link]} (joints "
                                         f"{', '.join(mech.joint_names[k] for k in kids)})")
            k = int(kids[0])
            if mech.s[k] != 0:
                raise ClosedFormMismatch(f"{name}: leg {jn}: joint {mech.joint_names[k]} after "
                                         "the leg is not a revolute")
            after.append(k)
            link = int(mech.joint_child_link[k])
        if not after:
            raise ClosedFormMismatch(f"{name}: leg {jn}: no joint between the leg and the "
                                     "platform")
        B = concurrent_point(mech, after, z, o, tol, f"leg {jn} platform joint")
        if link != e_link:
            if link not in cut_partner:
                raise ClosedFormMismatch(f"{name}: leg {jn} ends at link "
                                         f"{mech.link_names[link]}, which is neither the "
                                         "platform nor closed by a cut")
            f_own, f_other, cut = cut_partner[link]
            if int(mech.frame_link[f_other]) != e_link:
                raise ClosedFormMismatch(
                    f"{name}: cut {cut.name}: frame {mech.frame_names[f_other]} is on link "
                    f"{mech.link_names[int(mech.frame_link[f_other])]}, not on the platform "
                    f"{mech.link_names[e_link]}")
            if not bool(np.all(cut.mask[:3])):
                raise ClosedFormMismatch(f"{name}: cut {cut.name} does not constrain all three "
                                         "positions (mask x, y, z)")
            p_own = kin.frames(mech, [f_own])[0, 0, :3, 3]
            dist = float(np.linalg.norm(p_own - B))
            if dist > tol:
                raise ClosedFormMismatch(
                    f"{name}: cut {cut.name}: frame {mech.frame_names[f_own]} is {dist:.3g} m "
                    f"from the centre of leg {jn}'s platform joint (expected on it)")
        # the leg's axis must run through both joint centres
        o_j = o[j] - z[j] * q[j]  # the joint's zero point on its axis
        for P, what in ((A, "base"), (B, "platform")):
            dist = float(np.linalg.norm(np.cross(z[j], P - o_j)))
            if dist > tol:
                raise ClosedFormMismatch(f"{name}: leg {jn}: the prismatic axis misses the "
                                         f"{what} joint centre by {dist:.3g} m")
        s = float(z[j] @ (B - A))
        if abs(s) < tol:
            raise ClosedFormMismatch(f"{name}: leg {jn}: zero length at home")
        a_pts.append(A)
        b_pts.append(T_E_0[:3, :3] @ B + T_E_0[:3, 3])
        sig.append(np.sign(s))
        off.append(np.sign(s) * abs(s) - q[j])
    geom = StewartGeometry(legs=tuple(mech.joint_names[j] for j in iv), a=np.array(a_pts),
                           b=np.array(b_pts), sigma=np.array(sig), c=np.array(off))
    _verify(mech, geom, tol)
    return geom


def _verify(mech: Mechanism, geom: StewartGeometry, tol: float) -> None:
    """The leg formula reproduces the model at home and at two perturbed assemblies."""
    iv, dep = mech.independent, mech.dependent
    rng = np.random.default_rng(0)
    qv = mech.home[iv] + np.concatenate([np.zeros((1, len(iv))),
                                         rng.uniform(-1e-2, 1e-2, (2, len(iv)))]) * max(
        1.0, float(np.abs(geom.a).max()))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[dep], (len(qv), len(dep))))
    ok = res.ok
    T = forward_kinematics(mech, res.q[ok]).frames(mech, [mech.end_effector])[:, 0]
    err = np.abs(geom.joint_values(T) - qv[ok])
    if err.size and err.max() > 1e3 * tol:
        k = int(np.unravel_index(np.argmax(err), err.shape)[1])
        raise ClosedFormMismatch(f"{mech.name}: leg {geom.legs[k]}: the leg-length formula is "
                                 f"off by {err.max():.3g} m from the model's loop closure")


def stewart_attachments(mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """Base points a (k, 3) [base frame] and platform points b (k, 3) [{E} frame] of the legs
    (see :func:`stewart_geometry`; raises :class:`ClosedFormMismatch`, a ValueError)."""
    g = stewart_geometry(mech)
    return g.a, g.b


def stewart_ik(mech: Mechanism, T_0_E: np.ndarray,
               geom: StewartGeometry | None = None) -> np.ndarray:
    """Leg joint values (m, k) of a Stewart-type mechanism for platform poses (m, 4, 4)."""
    g = geom if geom is not None else stewart_geometry(mech)
    return g.joint_values(T_0_E)

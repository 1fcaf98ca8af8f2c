r"""Closed-form inverse kinematics of the kim1995 3-DOF direct-drive arm (kim1995 appendix).

With {E} given as ``T_0_E = [[n, s, a, p], [0, 0, 0, 1]]`` the motor angles are (kim1995
appendix, read with the corrections of PAPER_NOTES: d1 = 0.4, a3 = 0.25, a4 = 0.4, dE = -0.65
and the lower signs, ``q1 = atan2(-s_x, s_y)``)

.. math::
    q_{v1} = \mathrm{atan2}(\pm s_x, \mp s_y)\ (s_y \ne 0),\quad \pm\pi/2\ (s_y = 0) \\
    q_{v2} = \mathrm{atan2}(a_z, c_1 a_x + s_1 a_y) - \pi \\
    q_{v3} = \pi/2 - q_{v2} - \mathrm{atan2}(\pm s_3, c_3),\quad
    c_3 = (\alpha^2 + \beta^2 - a_3^2 - a_4^2) / (2 a_3 a_4),\quad s_3 = \pm\sqrt{1 - c_3^2}

with :math:`\alpha = c_1 p_x + s_1 p_y + d_E (c_1 a_x + s_1 a_y)` and
:math:`\beta = p_z - d_1 + d_E a_z`. Every branch (both signs of q1, both signs of s3, the
s_y = 0 case) is evaluated; :func:`direct_drive_ik` keeps the ones whose forward kinematics
reproduce the pose.

The arm's forward kinematics (PAPER_NOTES): ``u(t) = cos t r(q1) + sin t z0``;
``E = (0, 0, d1) + (a3 + dE) u(q2) + a4 u(pi/2 - q3)``... written with the link lengths
``l1 = a3``, ``l4 = -dE``, ``l2 = a4``: ``E = S + (l1 - l4) u(q2) + l2 u(pi/2 - q3)``,
``a = -u(q2)``, ``s = (-sin q1, cos q1, 0)``, ``n = s x a``.

References
----------
kim1995_complex_chain_ik, appendix 1; Tables 2-3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

D1 = 0.4
A3 = 0.25
A4 = 0.4
DE = -0.65


@dataclass(frozen=True)
class DirectDriveSolutions:
    """All branches for a batch of poses.

    q : (m, k, 3) motor angles q_v1..q_v3 [rad] of the k = 4 branches, ordered (lower q1 sign,
        lower signs in q3), (lower, upper), (upper, lower), (upper, upper); NaN-free
        (unreachable poses get c3 clipped to [-1, 1]). "Lower signs in q3" means
        ``atan2(-s3, c3)`` with ``s3 = -sqrt(1 - c3^2)``, i.e. ``atan2(+sqrt(1 - c3^2), c3)``.
    residual : (m, k) pose residual of each branch by forward kinematics (position [m] +
        orientation [-], max-abs over the matrix entries).
    valid : (m, k) bool, residual below ``tol``.
    """

    q: np.ndarray
    residual: np.ndarray
    valid: np.ndarray


def direct_drive_fk(q: np.ndarray, *, d1: float = D1, a3: float = A3, a4: float = A4,
                    dE: float = DE) -> np.ndarray:
    """T_0_E (m, 4, 4) of the direct-drive arm from motor angles q (m, 3) (PAPER_NOTES)."""
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2]
    r = np.stack([np.cos(q1), np.sin(q1), np.zeros_like(q1)], axis=-1)
    z0 = np.array([0.0, 0.0, 1.0])

    def u(t: np.ndarray) -> np.ndarray:
        return np.cos(t)[:, None] * r + np.sin(t)[:, None] * z0

    p = d1 * z0 + (a3 + dE) * u(q2) + a4 * u(np.pi / 2 - q3)
    a = -u(q2)
    s = np.stack([-np.sin(q1), np.cos(q1), np.zeros_like(q1)], axis=-1)
    n = np.cross(s, a)
    T = np.zeros((q.shape[0], 4, 4))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2], T[:, :3, 3] = n, s, a, p
    T[:, 3, 3] = 1.0
    return T


def _wrap(t: np.ndarray) -> np.ndarray:
    return (t + np.pi) % (2.0 * np.pi) - np.pi


def direct_drive_branches(T_0_E: np.ndarray, *, d1: float = D1, a3: float = A3, a4: float = A4,
                          dE: float = DE, tol: float = 1e-6) -> DirectDriveSolutions:
    """Every branch of the kim1995 appendix formulas for poses T_0_E (m, 4, 4)."""
    T = np.asarray(T_0_E, dtype=np.float64).reshape(-1, 4, 4)
    m = T.shape[0]
    sx, sy = T[:, 0, 1], T[:, 1, 1]
    ax, ay, az = T[:, 0, 2], T[:, 1, 2], T[:, 2, 2]
    px, py, pz = T[:, 0, 3], T[:, 1, 3], T[:, 2, 3]
    sols = []
    for sgn1 in (-1.0, 1.0):  # lower sign first: atan2(-s_x, s_y)
        q1 = np.where(np.abs(sy) > 1e-12, np.arctan2(sgn1 * sx, -sgn1 * sy),
                      np.where(sgn1 * sx >= 0, 1.0, -1.0) * np.pi / 2)
        c1, s1 = np.cos(q1), np.sin(q1)
        q2 = _wrap(np.arctan2(az, c1 * ax + s1 * ay) - np.pi)
        alpha = (c1 * px + s1 * py) + dE * (c1 * ax + s1 * ay)
        beta = pz - d1 + dE * az
        c3 = np.clip((alpha**2 + beta**2 - a3**2 - a4**2) / (2.0 * a3 * a4), -1.0, 1.0)
        for sgn3 in (1.0, -1.0):  # the product of the two lower signs first
            s3 = sgn3 * np.sqrt(1.0 - c3**2)
            q3 = _wrap(np.pi / 2 - q2 - np.arctan2(s3, c3))
            sols.append(np.stack([_wrap(q1), q2, q3], axis=-1))
    q = np.stack(sols, axis=1)  # (m, 4, 3)
    Tq = direct_drive_fk(q.reshape(-1, 3), d1=d1, a3=a3, a4=a4, dE=dE).reshape(m, 4, 4, 4)
    res = np.abs(Tq - T[:, None]).reshape(m, 4, -1).max(axis=-1)
    return DirectDriveSolutions(q=q, residual=res, valid=res < tol)


def direct_drive_ik(T_0_E: np.ndarray, **kwargs: float) -> tuple[np.ndarray, np.ndarray]:
    """Motor angles (m, 3) [rad] reproducing T_0_E (m, 4, 4) and a flag (m,) that one exists.

    The first valid branch in the order of :class:`DirectDriveSolutions` is returned (the
    paper's lower signs first); where none is valid, the branch with the smallest residual.
    """
    sol = direct_drive_branches(T_0_E, **kwargs)
    pick = np.where(sol.valid.any(axis=1), np.argmax(sol.valid, axis=1),
                    np.argmin(sol.residual, axis=1))
    m = sol.q.shape[0]
    return sol.q[np.arange(m), pick], sol.valid.any(axis=1)


def direct_drive_solutions(T_0_E: np.ndarray, *, d1: float = D1, a3: float = A3, a4: float = A4,
                           dE: float = DE, tol: float = 1e-6) -> list[np.ndarray]:
    """Every distinct solution of the appendix formulas, per pose.

    All four branches of :func:`direct_drive_branches` are evaluated (both signs of q1, both
    of s3); the ones whose forward kinematics reproduce T_0_E within ``tol`` are kept, and
    coinciding ones (c3 = +-1, the arm stretched or folded) are merged.

    Returns
    -------
    list of (k_i, 3) arrays [rad], one per pose, in the branch order of
    :class:`DirectDriveSolutions`; k_i = 0 where the pose is not reachable.
    """
    sol = direct_drive_branches(T_0_E, d1=d1, a3=a3, a4=a4, dE=dE, tol=tol)
    out = []
    for q, ok in zip(sol.q, sol.valid, strict=True):
        keep: list[np.ndarray] = []
        for qk in q[ok]:
            if not any(np.abs(_wrap(qk - p)).max() < 1e-9 for p in keep):
                keep.append(qk)
        out.append(np.array(keep).reshape(-1, 3))
    return out


@dataclass(frozen=True)
class DirectDriveGeometry:
    """Parameters of the appendix formulas read from a mechanism (kim1995 names, m).

    d1 : height of the shoulder axis on z0; a3 : crank (l1); a4 : upper arm (l2);
    dE : signed tool offset along the approach (-l4); ``joints``: the three motors.
    """

    d1: float
    a3: float
    a4: float
    dE: float
    joints: tuple[str, str, str]

    @property
    def params(self) -> dict[str, float]:
        return {"d1": self.d1, "a3": self.a3, "a4": self.a4, "dE": self.dE}


def _line_distance(o1, z1, o2, z2) -> float:
    n = np.cross(z1, z2)
    if np.linalg.norm(n) < 1e-12:  # parallel lines
        return float(np.linalg.norm(np.cross(z1, o2 - o1)))
    return float(abs((o2 - o1) @ n) / np.linalg.norm(n))


def direct_drive_geometry(mech) -> DirectDriveGeometry:
    """Read d1, a3, a4, dE from a mechanism of the kim1995 direct-drive arm's structure.

    Structure checked (at the assembled home configuration): three independent revolute
    motors; the first about the base z axis through the base origin; the second and third
    coaxial on a horizontal shoulder axis that meets z0 (at height d1); a3 and a4 are the
    distances from that axis to the next joint on the second and third motor's links (the
    crank's and the upper arm's far pins), dE follows from the end-effector position at home.
    Then the closed-form FK with these parameters must reproduce the model's end-effector pose
    at home and at four perturbed assemblies.

    Raises
    ------
    ClosedFormMismatch
        Naming the joint, frame or dimension that differs.
    """
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.solvers.closed_form.stewart import ClosedFormMismatch, assembled_home, size_of

    name = mech.name
    if mech.end_effector is None:
        raise ClosedFormMismatch(f"{name}: no end_effector frame")
    iv = [int(j) for j in mech.independent]
    if len(iv) != 3:
        raise ClosedFormMismatch(f"{name}: {len(iv)} independent joints, the direct-drive arm "
                                 "has 3 motors")
    jn = tuple(mech.joint_names[j] for j in iv)
    for j in iv:
        if mech.s[j] != 0:
            raise ClosedFormMismatch(f"{name}: motor {mech.joint_names[j]} is not revolute")
    kin = assembled_home(mech)
    tol = 1e-7 * size_of(mech, kin)
    z, o = (x[0] for x in kin.axes())
    j1, j2, j3 = iv
    ez = np.array([0.0, 0.0, 1.0])
    if np.linalg.norm(np.cross(z[j1], ez)) > 1e-9:
        raise ClosedFormMismatch(f"{name}: motor {jn[0]}: axis {np.round(z[j1], 6).tolist()} is "
                                 "not the base z axis")
    if np.linalg.norm(o[j1][:2]) > tol:
        raise ClosedFormMismatch(f"{name}: motor {jn[0]}: its axis is "
                                 f"{np.linalg.norm(o[j1][:2]):.3g} m off the base origin")
    if abs(z[j2] @ ez) > 1e-9:
        raise ClosedFormMismatch(f"{name}: motor {jn[1]}: the shoulder axis is not horizontal "
                                 f"(z component {z[j2] @ ez:.3g})")
    if np.linalg.norm(np.cross(z[j2], z[j3])) > 1e-9 or _line_distance(
            o[j2], z[j2], o[j3], z[j3]) > tol:
        raise ClosedFormMismatch(f"{name}: motors {jn[1]} and {jn[2]} are not coaxial")
    dist = _line_distance(o[j1], z[j1], o[j2], z[j2])
    if dist > tol:
        raise ClosedFormMismatch(f"{name}: motor {jn[1]}: the shoulder axis misses the base z "
                                 f"axis by {dist:.3g} m")
    d1 = float(o[j2][2])

    def arm(j: int, label: str) -> float:
        kids = np.flatnonzero(mech.joint_parent_link == mech.joint_child_link[j])
        if kids.size != 1:
            raise ClosedFormMismatch(f"{name}: motor {mech.joint_names[j]}: its link carries "
                                     f"{kids.size} joints, the {label} has one far pin")
        k = int(kids[0])
        if mech.s[k] != 0 or np.linalg.norm(np.cross(z[k], z[j])) > 1e-9:
            raise ClosedFormMismatch(f"{name}: joint {mech.joint_names[k]} (the {label}'s far "
                                     f"pin) is not a revolute parallel to {mech.joint_names[j]}")
        return _line_distance(o[j], z[j], o[k], z[k])

    a3, a4 = arm(j2, "crank"), arm(j3, "upper arm")
    qh = kin.q[0, iv]
    c1, s1 = np.cos(qh[0]), np.sin(qh[0])
    r = np.array([c1, s1, 0.0])

    def u(t: float) -> np.ndarray:
        return np.cos(t) * r + np.sin(t) * ez

    p = kin.frames(mech, [mech.end_effector])[0, 0, :3, 3]
    k = float((p - d1 * ez - a4 * u(np.pi / 2 - qh[2])) @ u(qh[1]))
    geom = DirectDriveGeometry(d1=d1, a3=a3, a4=a4, dE=k - a3, joints=jn)
    # verify: closed-form FK with these parameters = the model, at home and perturbed
    rng = np.random.default_rng(0)
    qv = qh + np.concatenate([np.zeros((1, 3)), rng.uniform(-0.1, 0.1, (4, 3))])
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (len(qv), len(mech.dependent))))
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    Tc = direct_drive_fk(qv, **geom.params)
    fr = mech.frame_names[mech.end_effector]
    for i in np.flatnonzero(res.ok):
        dp = float(np.linalg.norm(T[i, :3, 3] - Tc[i, :3, 3]))
        if dp > 1e3 * tol:
            raise ClosedFormMismatch(
                f"{name}: frame {fr}: position differs from the direct-drive closed form by "
                f"{dp:.3g} m at motors {np.round(qv[i], 4).tolist()} rad (link lengths read: "
                f"d1 {d1:.6g}, a3 {a3:.6g}, a4 {a4:.6g}, dE {geom.dE:.6g} m)")
        for col, label in ((0, "x axis (normal n)"), (1, "y axis (sliding s = shoulder axis)"),
                           (2, "z axis (approach a = -u(q2))")):
            de = float(np.linalg.norm(T[i, :3, col] - Tc[i, :3, col]))
            if de > 1e-6:
                raise ClosedFormMismatch(
                    f"{name}: frame {fr}: its {label} differs from the direct-drive closed "
                    f"form by {de:.3g} at motors {np.round(qv[i], 4).tolist()} rad")
    return geom

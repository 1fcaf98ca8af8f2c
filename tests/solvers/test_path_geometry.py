"""Hand path geometry (line, arc, arc-length spline) and slerp orientation: arc-length
parametrisation, derivatives against finite differences, projection, continuity, scipy
cross-checks; the path IK along curves on the PUMA 560 and a planar 3R (FK after IK, dq/dr and
d2q/dr2 against differences of q(r), the task-space curvature term)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, Slerp

from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics, frame_jacobian
from mechkin.solvers.track.path_geometry import (
    ArcGeometry,
    LineGeometry,
    SlerpOrientation,
    SplineGeometry,
    circumcircle,
)
from mechkin.solvers.track.path_ik import COMPONENTS, HandLineIK, HandPathIK
from mechkin.spatial.rotations import matrix_from_rpy, rotation_log

ROOT = Path(__file__).resolve().parents[2]
DEG = np.pi / 180.0
H = 1e-5
R_IN = np.linspace(0.013, 0.987, 37)
P0 = np.array([0.80574977, -0.15005, 0.86743])  # PUMA 560 tool at q0 (scenarios/*track*)
Q0 = np.array([0, 30, -120, 0, -40, 0]) * DEG
SPLINE_PTS = P0 + np.array([[0, 0, 0], [0.03, 0.1, 0.03], [-0.01, 0.2, 0.05], [0.02, 0.3, 0.0]])


def _geometries():
    return {
        "line": LineGeometry(P0, P0 + [0.1, 0.3, -0.2]),
        "arc": ArcGeometry([1.0, 0.2, 0.3], [0.4, 0.9, 0.5], [-0.3, 0.1, 0.2]),
        "arc_big": ArcGeometry([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]),  # 270 deg
        "spline": SplineGeometry(SPLINE_PTS),
        "spline_wavy": SplineGeometry([[0, 0, 0], [0.3, 0.2, 0], [0.5, -0.1, 0.2],
                                       [0.9, 0.1, 0.1], [1.2, 0.0, -0.1]]),
    }


GEOMS = _geometries()


@pytest.mark.parametrize("name", list(GEOMS))
def test_arc_length_parametrisation(name: str) -> None:
    """|p'(r)| = L everywhere (also beyond the ends), and L is the length of the curve: the
    sum of the chords of a fine sampling (an independent estimate, error O(h^2))."""
    g = GEOMS[name]
    r = np.linspace(-0.1, 1.1, 241)
    assert_allclose(np.linalg.norm(g.d1(r), axis=1), g.arc_length, rtol=1e-12)
    rs = np.linspace(0.0, 1.0, 200001)
    chords = np.sum(np.linalg.norm(np.diff(g.position(rs), axis=0), axis=1))
    assert chords == pytest.approx(g.arc_length, rel=1e-9)
    # r is the normalised arc length: the chords up to r = 0.3 are 0.3 L
    rs = np.linspace(0.0, 0.3, 60001)
    part = np.sum(np.linalg.norm(np.diff(g.position(rs), axis=0), axis=1))
    assert part == pytest.approx(0.3 * g.arc_length, rel=1e-8)


@pytest.mark.parametrize("name", list(GEOMS))
def test_derivatives_match_finite_differences(name: str) -> None:
    g = GEOMS[name]
    r = np.concatenate([R_IN, [-0.05, 1.05]])
    fd1 = (g.position(r + H) - g.position(r - H)) / (2 * H)
    fd2 = (g.d1(r + H) - g.d1(r - H)) / (2 * H)
    L = g.arc_length
    assert_allclose(g.d1(r), fd1, atol=1e-8 * L)
    assert_allclose(g.d2(r), fd2, atol=1e-6 * max(L * L, np.max(np.abs(g.d2(r)))))
    # p' is orthogonal to p'' (constant speed)
    assert_allclose(np.sum(g.d1(r) * g.d2(r), axis=1), 0.0, atol=1e-9 * L**3)


@pytest.mark.parametrize("name", ["spline", "spline_wavy"])
def test_spline_is_c2_and_interpolates_its_points(name: str) -> None:
    """Through every point at its arc-length r; p' and p'' continuous across the knots and at
    the ends (natural end conditions: zero curvature, the tangent continuation)."""
    g = GEOMS[name]
    assert_allclose(g.position(g.r_knots), g.points, atol=1e-13)
    e = 1e-9
    for rk in g.r_knots:
        a, b = np.array([rk - e]), np.array([rk + e])
        assert_allclose(g.d1(a), g.d1(b), atol=1e-6 * g.arc_length)
        assert_allclose(g.d2(a), g.d2(b), atol=1e-5 * g.arc_length**2)
    assert_allclose(g.d2(np.array([0.0, 1.0])), 0.0, atol=1e-9)
    # the arc length against scipy's quadrature of |P'(u)| of an independent natural spline
    P = np.asarray(g.points)
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    d = CubicSpline(u, P, bc_type="natural").derivative()
    L = sum(quad(lambda x: np.linalg.norm(d(x)), a, b, epsabs=1e-14, epsrel=1e-13)[0]
            for a, b in zip(u[:-1], u[1:], strict=True))
    assert g.arc_length == pytest.approx(L, rel=1e-12)


def test_arc_geometry_against_its_definition() -> None:
    a, b, c = np.array([1.0, 0.2, 0.3]), np.array([0.4, 0.9, 0.5]), np.array([-0.3, 0.1, 0.2])
    centre, rho, n = circumcircle(a, b, c)
    for p in (a, b, c):
        assert np.linalg.norm(p - centre) == pytest.approx(rho, rel=1e-13)
    g = GEOMS["arc"]
    assert_allclose(g.position(np.array([0.0, 1.0])), [a, c], atol=1e-13)
    rv = g.project(b[None])[0]
    assert 0.0 < rv < 1.0  # the arc passes through via between start and end
    assert_allclose(g.position(np.array([rv]))[0], b, atol=1e-13)
    # the swept angle from the three points: 2 pi minus the angle subtended away from via
    ang = lambda x, y: np.arccos(np.clip((x - centre) @ (y - centre) / rho**2, -1, 1))  # noqa
    assert g.angle == pytest.approx(ang(a, b) + ang(b, c), rel=1e-12)
    assert g.arc_length == pytest.approx(rho * g.angle, rel=1e-14)
    assert GEOMS["arc_big"].angle == pytest.approx(1.5 * np.pi, rel=1e-14)
    with pytest.raises(ValueError, match="collinear"):
        ArcGeometry([0, 0, 0], [1, 1, 1], [2, 2, 2])


@pytest.mark.parametrize("name", list(GEOMS))
def test_project_inverts_position(name: str) -> None:
    g = GEOMS[name]
    # beyond the ends up to 0.2; a 270 deg arc's continuations meet 45 deg (r = 1/6) past them
    e = 0.15 if name == "arc_big" else 0.2
    r = np.linspace(-e, 1.0 + e, 29)
    assert_allclose(g.project(g.position(r)), r, atol=1e-10)


def test_conveyor_phase_on_a_curve() -> None:
    """A part on the arc 0.05 m of arc behind the start at 0.1 m/s along the tangent:
    r0 = -0.05 / L, r' = 0.1 / L; a part off the path or a belt across it is refused."""
    g = GEOMS["arc"]
    L = g.arc_length
    r0 = -0.05 / L
    x = g.position(np.array([r0]))[0]
    t = g.tangent(np.array([r0]))[0]
    got = g.conveyor_phase(x, 0.1 * t)
    assert got[0] == pytest.approx(r0, abs=1e-12) and got[1] == pytest.approx(0.1 / L, rel=1e-12)
    with pytest.raises(ConfigError, match="off the hand's arc"):
        g.conveyor_phase(x + 1e-3 * g.normal, 0.1 * t)
    with pytest.raises(ConfigError, match="not along the hand's arc"):
        g.conveyor_phase(x, 0.1 * t + [0.0, 0.0, 0.01])
    with pytest.raises(ConfigError, match="away from the path's end"):
        g.conveyor_phase(x, -0.1 * t)


# ---- orientation ----------------------------------------------------------------------------

ROTS = Rotation.random(4, random_state=7).as_matrix()
KNOTS = np.array([0.0, 0.3, 0.55, 1.0])


def test_linear_slerp_equals_scipy_slerp() -> None:
    o = SlerpOrientation(ROTS, KNOTS, "linear")
    r = np.linspace(0.0, 1.0, 101)
    ref = Slerp(KNOTS, Rotation.from_matrix(ROTS))(r).as_matrix()
    assert_allclose(o.rotation(r), ref, atol=1e-13)
    assert_allclose(o.rotation(KNOTS), ROTS, atol=1e-13)


@pytest.mark.parametrize("blend", ["linear", "smooth"])
def test_slerp_omega_matches_finite_differences_of_the_rotation(blend: str) -> None:
    """omega(r) from log(R(r + h) R(r - h)^T) / 2h (base frame), omega' from differences of
    omega; inside the pieces and beyond the end keyframes."""
    o = SlerpOrientation(ROTS, KNOTS, blend)
    r = np.concatenate([np.linspace(0.01, 0.29, 8), np.linspace(0.31, 0.54, 6),
                        np.linspace(0.56, 0.99, 9), [-0.05, 1.05]])
    Rp, Rm = o.rotation(r + H), o.rotation(r - H)
    fd = rotation_log(Rp @ np.swapaxes(Rm, 1, 2)) / (2 * H)
    # truncation h^2 omega'' / 6: ~1e-7 for the quintic (sigma''' = 60 on pieces of 0.25)
    assert_allclose(o.omega(r), fd, atol=1e-8 if blend == "linear" else 1e-6)
    fd2 = (o.omega(r + H) - o.omega(r - H)) / (2 * H)
    assert_allclose(o.domega(r), fd2, atol=1e-5)
    if blend == "smooth":  # at rest at every keyframe: omega continuous across them
        assert_allclose(o.omega(KNOTS), 0.0, atol=1e-12)
    else:
        assert_allclose(o.domega(r), 0.0, atol=0.0)


# ---- path IK along curves -------------------------------------------------------------------


def _fk(mech, q):
    return forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]


@cache
def _puma():
    return load_mechanism(ROOT / "mechanisms" / "puma560.yaml")


def _puma_orientations():
    R0 = _fk(_puma(), Q0[None])[0, :3, :3]
    R1 = matrix_from_rpy(np.array([-170.0, 35.0, -150.0]) * DEG)
    return R0, R1


@cache
def puma_path(kind: str, orient: str) -> HandPathIK:
    mech = _puma()
    if kind == "arc":  # the vertical half circle of scenarios/puma560_track_arc.yaml
        g = ArcGeometry(P0, P0 + [0.0, 0.1, 0.1], P0 + [0.0, 0.2, 0.0])
    else:
        g = SplineGeometry(SPLINE_PTS)
    R0, R1 = _puma_orientations()
    o = None if orient == "fixed" else SlerpOrientation(np.stack([R0, R1]), [0.0, 1.0], orient)
    return HandPathIK(mech, mech.end_effector, g, Q0, 1e-12, mask=COMPONENTS, tol_rot=1e-12,
                      orientation=o)


CASES = [("arc", "fixed"), ("arc", "linear"), ("spline", "fixed"), ("spline", "linear"),
         ("spline", "smooth")]


@pytest.mark.parametrize(("kind", "orient"), CASES)
def test_puma_pose_held_along_a_curve(kind: str, orient: str) -> None:
    """FK of q(r): the hand on p(r) to 1e-6 m and at R*(r) to 1e-6 rad (measured ~1e-15)."""
    ik = puma_path(kind, orient)
    assert ik.rank == 6 and ik.redundancy == 0
    r = np.linspace(0.0, 1.0, 81)
    q = ik.q(r)
    T = _fk(ik.mech, q)
    assert np.max(np.linalg.norm(T[:, :3, 3] - ik.geometry.position(r), axis=1)) <= 1e-9
    R0, R1 = _puma_orientations()
    if orient == "fixed":
        target = np.broadcast_to(R0, (r.size, 3, 3))
    else:
        target = SlerpOrientation(np.stack([R0, R1]), [0.0, 1.0], orient).rotation(r)
    ang = np.linalg.norm(rotation_log(T[:, :3, :3] @ np.swapaxes(target, 1, 2)), axis=1)
    assert np.max(ang) <= 1e-9
    err = ik.pose_errors(q, r)
    assert err["max_position_error_m"] <= 1e-6 and err["max_orientation_error_rad"] <= 1e-6
    if orient != "fixed":  # the tool really turns: 28.5 deg between the two orientations
        assert err["max_rotation_from_start_rad"] == pytest.approx(
            np.linalg.norm(rotation_log((R1 @ R0.T)[None])), rel=1e-9)


@pytest.mark.parametrize(("kind", "orient"), CASES)
def test_puma_dq_ddq_match_differences_of_q(kind: str, orient: str) -> None:
    """dq/dr and d2q/dr2 against central differences of the solved q(r) (steps 2e-3 and 1e-3,
    Richardson-extrapolated; Newton's 1e-12 tolerance is the noise); and in task space,
    J f' = [omega*; p'] and the
    curvature term J f'' + Jdot f' = [omega*'; p''] (Jdot f' by differences along r)."""
    ik = puma_path(kind, orient)
    r = np.linspace(0.02, 0.98, 13)

    def diffs(h):
        qm, q0, qp = ik.q(r - h), ik.q(r), ik.q(r + h)
        return (qp - qm) / (2 * h), (qp - 2 * q0 + qm) / h**2

    (a1, a2), (b1, b2) = diffs(2e-3), diffs(1e-3)
    fd1, fd2 = (4 * b1 - a1) / 3, (4 * b2 - a2) / 3  # Richardson: truncation O(h^4)
    q0 = ik.q(r)
    d1, d2 = ik.dq(r), ik.ddq(r)
    scale1, scale2 = np.max(np.abs(d1)), np.max(np.abs(d2))
    assert_allclose(d1, fd1, atol=1e-8 * scale1)
    assert_allclose(d2, fd2, atol=1e-5 * max(scale2, 1.0))
    mech = ik.mech
    J = frame_jacobian(mech, forward_kinematics(mech, q0), mech.end_effector)
    o = ik.orientation
    w = np.zeros((r.size, 3)) if o is None else o.omega(r)
    dw = np.zeros((r.size, 3)) if o is None else o.domega(r)
    twist = np.einsum("mij,mj->mi", J, d1)
    assert_allclose(twist[:, 3:], ik.geometry.d1(r), atol=1e-9)
    assert_allclose(twist[:, :3], w, atol=1e-9)
    Jp = frame_jacobian(mech, forward_kinematics(mech, ik.q(r + 1e-5)), mech.end_effector)
    Jm = frame_jacobian(mech, forward_kinematics(mech, ik.q(r - 1e-5)), mech.end_effector)
    acc = np.einsum("mij,mj->mi", J, d2) + np.einsum("mij,mj->mi", (Jp - Jm) / 2e-5, d1)
    assert_allclose(acc[:, 3:], ik.geometry.d2(r), atol=1e-5 * max(1.0, scale2))
    assert_allclose(acc[:, :3], dw, atol=1e-5 * max(1.0, scale2))


def test_line_geometry_is_the_original_line_ik() -> None:
    """HandPathIK on a LineGeometry is HandLineIK: the same table and derivatives, bit for bit."""
    mech = _puma()
    g = LineGeometry(P0, P0 + [0.0, 0.4, 0.0])
    a = HandLineIK(mech, mech.end_effector, g.p0, g.p1, Q0, 1e-12, mask=COMPONENTS)
    b = HandPathIK(mech, mech.end_effector, g, Q0, 1e-12, mask=COMPONENTS)
    r = np.linspace(0.0, 1.0, 11)
    assert np.array_equal(a.tab, b.tab)
    assert np.array_equal(a.ddq(r), b.ddq(r)) and np.array_equal(a.hand(r), b.hand(r))


def test_planar_3r_on_an_arc_in_its_plane() -> None:
    """A redundant planar 3R on an arc (position task x, y): solves, the hand on the arc, f'
    tangent (J_v f' = p'), posture term N (q_s - q) = 0."""
    mech = load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
    p0 = _fk(mech, mech.home[None])[0, :3, 3]
    g = ArcGeometry(p0, p0 + [-0.15, 0.1, 0.0], p0 + [-0.35, 0.0, 0.0])
    ik = HandPathIK(mech, mech.end_effector, g, mech.home, 1e-12)
    assert ik.redundancy == 1 and ik.rank == 2
    r = np.linspace(0.0, 1.0, 21)
    q = ik.q(r)
    assert_allclose(_fk(mech, q)[:, :3, 3], g.position(r), atol=1e-12)
    N = ik._null(q)
    assert np.max(np.abs(np.einsum("mij,mj->mi", N, ik.q_ref - q))) <= 1e-9
    rr = np.linspace(0.05, 0.95, 7)
    J = frame_jacobian(mech, forward_kinematics(mech, ik.q(rr)), mech.end_effector)
    assert_allclose(np.einsum("mij,mj->mi", J[:, 3:], ik.dq(rr)), g.d1(rr), atol=1e-8)
    h = 1e-3
    fd2 = (ik.q(rr + h) - 2 * ik.q(rr) + ik.q(rr - h)) / h**2
    assert_allclose(ik.ddq(rr), fd2, atol=1e-4 * max(1.0, np.max(np.abs(fd2))))


def _check_partial(ik: HandPathIK, comps: list[int]) -> None:
    """FK: the hand on the path, the masked rotation components of log(R R*^T) zero; dq, ddq
    against Richardson differences of q(r)."""
    r = np.linspace(0.0, 1.0, 41)
    q = ik.q(r)
    T = _fk(ik.mech, q)
    pos = [i for i in range(3) if COMPONENTS[i] in ik.mask]
    assert np.max(np.abs((T[:, :3, 3] - ik.geometry.position(r))[:, pos])) <= 1e-9
    phi = rotation_log(T[:, :3, :3] @ np.swapaxes(ik.orientation.rotation(r), 1, 2))
    assert np.max(np.abs(phi[:, comps])) <= 1e-9
    rr = np.linspace(0.03, 0.97, 9)

    def diffs(h):
        qm, q0, qp = ik.q(rr - h), ik.q(rr), ik.q(rr + h)
        return (qp - qm) / (2 * h), (qp - 2 * q0 + qm) / h**2

    (a1, a2), (b1, b2) = diffs(2e-3), diffs(1e-3)
    d1, d2 = ik.dq(rr), ik.ddq(rr)
    assert_allclose(d1, (4 * b1 - a1) / 3, atol=1e-7 * max(1.0, np.max(np.abs(d1))))
    assert_allclose(d2, (4 * b2 - a2) / 3, atol=1e-4 * max(1.0, np.max(np.abs(d2))))


def test_slerp_on_some_rotation_rows_of_a_redundant_arm() -> None:
    """PUMA 560, mask [x, y, z, rz] (redundancy 2) with the orientation slerped: only the z
    component of the orientation error is held; the null-space projector then turns with r
    (the D_r term), which dq/dr must include to match the differences of q(r)."""
    mech = _puma()
    R0, R1 = _puma_orientations()
    ik = HandPathIK(mech, mech.end_effector, SplineGeometry(SPLINE_PTS), Q0, 1e-12,
                    mask=("x", "y", "z", "rz"), tol_rot=1e-12,
                    orientation=SlerpOrientation(np.stack([R0, R1]), [0.0, 1.0]))
    assert ik.redundancy == 2 and ik._partial_varying
    _check_partial(ik, [2])


def test_planar_3r_turns_its_hand_by_slerp_about_z() -> None:
    """Planar 3R on an arc with the hand's yaw interpolated from 0 to 40 deg: mask [x, y, rz]
    (not redundant); the hand's angle q1 + q2 + q3 follows 40 r deg."""
    mech = load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
    p0 = _fk(mech, mech.home[None])[0, :3, 3]
    g = ArcGeometry(p0, p0 + [-0.15, 0.1, 0.0], p0 + [-0.35, 0.0, 0.0])
    rot = matrix_from_rpy(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 40.0]]) * DEG)
    ik = HandPathIK(mech, mech.end_effector, g, mech.home, 1e-12, mask=("x", "y", "rz"),
                    tol_rot=1e-12, orientation=SlerpOrientation(rot, [0.0, 1.0]))
    assert ik.redundancy == 0
    _check_partial(ik, [2])
    r = np.linspace(0.0, 1.0, 11)
    yaw = np.sum(ik.q(r), axis=1)
    assert_allclose(np.angle(np.exp(1j * (yaw - 40 * DEG * r))), 0.0, atol=1e-9)

"""The bundled mechanism files (mechanisms/*.yaml): they load, their Jacobians match finite
differences, and each paper mechanism reproduces an independent description of its kinematics.

Reference values are typed in with their sources; nothing is read from outside the repository.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import ClosureStatus, solve_closure
from mechkin.model.kinematics import (
    closure_jacobian,
    closure_residual,
    forward_kinematics,
    frame_jacobian,
    frame_poses,
)
from mechkin.spatial.rotations import quat_from_matrix

MECH_DIR = Path(__file__).resolve().parents[2] / "mechanisms"
FILES = sorted(MECH_DIR.glob("*.yaml"))
IDS = [p.stem for p in FILES]
H = 1e-6  # central-difference step [rad | m]


def _rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _T(R: np.ndarray | None = None, p=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    T[:3, 3] = p
    return T


def _random_configs(mech, m: int, seed: int) -> np.ndarray:
    """m configurations, uniform within the limits; home +- 1 where a joint has none."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(mech.lower), mech.lower, mech.home - 1.0)
    hi = np.where(np.isfinite(mech.upper), mech.upper, mech.home + 1.0)
    return lo + (hi - lo) * rng.random((m, mech.n))


def _perturbed(q: np.ndarray) -> np.ndarray:
    """(2n, n): q + h e_k for every k, then q - h e_k."""
    n = q.size
    E = H * np.eye(n)
    return np.concatenate([q + E, q - E])


def _skew_vec(S: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


# ---- every bundled file ----------------------------------------------------------------------


def test_bundled_files_present():
    names = {p.name for p in FILES}
    for required in ("panda.yaml", "park_scara2.yaml", "lee_spherical_rrps.yaml",
                     "hwang2023_biped.yaml"):
        assert required in names


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_loads(path):
    mech = load_mechanism(path)
    assert mech.n > 0
    assert np.all(mech.lower <= mech.home) and np.all(mech.home <= mech.upper)
    assert mech.end_effector is not None
    # dof = n - rank of the constraint Jacobian at home, and one independent joint per dof
    kin = forward_kinematics(mech, mech.home[None])
    _, J = closure_jacobian(mech, kin)
    rank = np.linalg.matrix_rank(J[0], tol=1e-9) if mech.cuts else 0
    assert len(mech.independent) == mech.n - rank


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_home_closes(path):
    """home is near an assembled configuration: Newton from home closes the loops."""
    mech = load_mechanism(path)
    if not mech.cuts:
        pytest.skip("open chain")
    q0 = mech.home[None]
    res = solve_closure(mech, q0[:, mech.independent], q0[:, mech.dependent])
    assert res.status[0] is ClosureStatus.CONVERGED
    kin = forward_kinematics(mech, res.q)
    assert np.abs(closure_residual(mech, kin)).max() < 1e-10


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_end_effector_jacobian_matches_finite_differences(path):
    mech = load_mechanism(path)
    f = mech.end_effector
    for q in _random_configs(mech, 4, seed=20240611):
        qs = np.concatenate([q[None], _perturbed(q)])
        kin = forward_kinematics(mech, qs)
        J = frame_jacobian(mech, kin, f)[0]  # (6, n): (omega, v)
        T = kin.frames(mech, [f])[:, 0]
        n = mech.n
        Tp, Tm = T[1 : n + 1], T[n + 1 :]
        J_fd = np.empty((6, n))
        R0 = T[0, :3, :3]
        for k in range(n):
            dR = (Tp[k, :3, :3] - Tm[k, :3, :3]) / (2 * H)
            J_fd[:3, k] = _skew_vec(dR @ R0.T)
            J_fd[3:, k] = (Tp[k, :3, 3] - Tm[k, :3, 3]) / (2 * H)
        np.testing.assert_allclose(J, J_fd, atol=1e-7)


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_closure_jacobian_matches_finite_differences(path):
    mech = load_mechanism(path)
    if not mech.cuts:
        pytest.skip("open chain")
    qs = np.concatenate([mech.home[None], _random_configs(mech, 12, seed=7)])
    checked = 0
    for q in qs:
        kin0 = forward_kinematics(mech, q[None])
        # the residual uses e0 >= 0; keep away from the sign flip at e0 = 0 (half turns)
        Ta = kin0.frames(mech, [c.a for c in mech.cuts])[0]
        Tb = kin0.frames(mech, [c.b for c in mech.cuts])[0]
        e0 = quat_from_matrix(np.swapaxes(Ta[:, :3, :3], -1, -2) @ Tb[:, :3, :3])[:, 0]
        if e0.min() < 0.05:
            continue
        phi, J = closure_jacobian(mech, kin0)
        np.testing.assert_allclose(phi[0], closure_residual(mech, kin0)[0], atol=1e-15)
        P = closure_residual(mech, forward_kinematics(mech, _perturbed(q)))
        J_fd = ((P[: mech.n] - P[mech.n :]) / (2 * H)).T
        np.testing.assert_allclose(J[0], J_fd, atol=1e-7)
        checked += 1
        if checked == 4:
            break
    assert checked >= 3


# ---- Franka Emika Panda --------------------------------------------------------------------

# Franka's published modified D-H table (frankaemika.github.io/docs/control_parameters.html):
# rows (a_{i-1}, d_i, alpha_{i-1}) for joints 1..7, then the flange (a, d, alpha) = (0, 0.107, 0).
PANDA_MDH = [
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.316, np.pi / 2),
    (0.0825, 0.0, np.pi / 2),
    (-0.0825, 0.384, -np.pi / 2),
    (0.0, 0.0, np.pi / 2),
    (0.088, 0.0, np.pi / 2),
]
PANDA_FLANGE_D = 0.107


def _panda_flange(q: np.ndarray) -> np.ndarray:
    """Hand-written product of Craig transforms Rx(alpha) Tx(a) Rz(theta) Tz(d)."""
    T = np.eye(4)
    for (a, d, alpha), th in zip(PANDA_MDH, q, strict=True):
        T = T @ _T(_rx(alpha)) @ _T(None, (a, 0, 0)) @ _T(_rz(th)) @ _T(None, (0, 0, d))
    return T @ _T(None, (0, 0, PANDA_FLANGE_D))


@pytest.fixture(scope="module")
def panda():
    return load_mechanism(MECH_DIR / "panda.yaml")


def test_panda_fk_matches_documented_dh_product(panda):
    qs = np.concatenate([np.zeros((1, 7)), panda.home[None], _random_configs(panda, 20, seed=3)])
    T = frame_poses(panda, qs, [panda.frame_index("flange")])[:, 0]
    for q, Tq in zip(qs, T, strict=True):
        np.testing.assert_allclose(Tq, _panda_flange(q), atol=1e-9)


def test_panda_zero_pose(panda):
    # qz: the arm points up, the flange 0.088 m forward and 0.333 + 0.316 + 0.384 - 0.107 m up,
    # flange z pointing down
    T = frame_poses(panda, np.zeros((1, 7)), [panda.frame_index("flange")])[0, 0]
    np.testing.assert_allclose(T, _T(np.diag([1.0, -1, -1]), (0.088, 0, 0.926)), atol=1e-12)


def test_panda_ready_pose_matches_robotics_toolbox_readme(panda):
    # Robotics Toolbox for Python README ("Code Examples"): rtb.models.Panda().fkine(qr) with
    # qr = (0, -0.3, 0, -2.2, 0, 2.0, pi/4), the Franka Hand TCP; printed to 4 digits, compared at
    # half a unit of the last printed digit.
    qr = np.array([[0, -0.3, 0, -2.2, 0, 2.0, np.pi / 4]])
    T = frame_poses(panda, qr, [panda.frame_index("hand_tcp")])[0, 0]
    printed = np.array([
        [0.995, 0, 0.09983, 0.484],
        [0, -1, 0, 0],
        [0.09983, 0, -0.995, 0.4126],
    ])
    tol = np.array([
        [5e-4, 5e-4, 5e-6, 5e-4],
        [5e-4, 5e-4, 5e-4, 5e-4],
        [5e-6, 5e-4, 5e-4, 5e-5],
    ])
    assert np.all(np.abs(T[:3] - printed) <= tol)


def test_panda_limits_and_inertials(panda):
    # franka_description robots/panda/joint_limits.yaml
    np.testing.assert_array_equal(panda.lower, [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973,
                                                -0.0175, -2.8973])
    np.testing.assert_array_equal(panda.upper, [2.8973, 1.7628, 2.8973, -0.0698, 2.8973,
                                                3.7525, 2.8973])
    # Gaz et al. 2019 masses (franka_description robots/common/inertial.yaml)
    k = [panda.link_names.index(f"link{i}") for i in range(1, 8)]
    np.testing.assert_array_equal(panda.mass[k], [4.970684, 0.646926, 3.228604, 3.587895,
                                                  1.225946, 1.666555, 0.735522])


# ---- park's planar 2R arm --------------------------------------------------------------------


@pytest.fixture(scope="module")
def scara():
    return load_mechanism(MECH_DIR / "park_scara2.yaml")


def test_park_scara_fk_is_the_planar_formula(scara):
    qs = _random_configs(scara, 50, seed=11)
    T = frame_poses(scara, qs, [scara.frame_index("hand")])[:, 0]
    q1, q2 = qs[:, 0], qs[:, 1]
    np.testing.assert_allclose(T[:, 0, 3], np.cos(q1) + np.cos(q1 + q2), atol=1e-12)
    np.testing.assert_allclose(T[:, 1, 3], np.sin(q1) + np.sin(q1 + q2), atol=1e-12)
    np.testing.assert_allclose(T[:, 2, 3], 0.0, atol=1e-12)
    np.testing.assert_allclose(T[:, 0, 0], np.cos(q1 + q2), atol=1e-12)
    np.testing.assert_allclose(T[:, 1, 0], np.sin(q1 + q2), atol=1e-12)


def test_park_scara_home_is_the_path_start_elbow_positive(scara):
    # park: hand path x = -0.8 + 0.5 r, y = 1.732 (m); home at r = 0 with q2 > 0
    T = frame_poses(scara, scara.home[None], [scara.frame_index("hand")])[0, 0]
    np.testing.assert_allclose(T[:2, 3], [-0.8, 1.732], atol=1e-8)
    assert scara.home[1] > 0


def test_park_scara_inertials_give_the_papers_mass_matrix(scara):
    # park Table 1: M = [[5/3 + c2, 1/3 + c2/2], [1/3 + c2/2, 1/3]]; no gravity torque (the
    # gravity vector is along the joint axes)
    qs = _random_configs(scara, 5, seed=5)
    kin = forward_kinematics(scara, qs)
    for i, q in enumerate(qs):
        M = np.zeros((2, 2))
        for link in (1, 2):
            J = frame_jacobian(scara, kin, link)[i]
            R = kin.T_links[i, link, :3, :3]
            r = R @ scara.com[link]
            Jv = J[3:] - np.cross(r, J[:3].T).T  # v_com = v_o + omega x r
            Jw = J[:3]
            M += scara.mass[link] * Jv.T @ Jv + Jw.T @ R @ scara.inertia[link] @ R.T @ Jw
            tau_g = -scara.mass[link] * Jv.T @ scara.gravity
            np.testing.assert_allclose(tau_g, 0.0, atol=1e-12)
        c2 = np.cos(q[1])
        np.testing.assert_allclose(
            M, [[5 / 3 + c2, 1 / 3 + c2 / 2], [1 / 3 + c2 / 2, 1 / 3]], atol=1e-12
        )


# ---- lee's spherical 3-DOF parallel mechanism ------------------------------------------------

LEE_R, LEE_r = 1.0, 0.5
LEE_G = np.radians([0.0, 120.0, 240.0])
LEE_P = np.array([0.0, 0.0, 1.0])


def _lee_leg_lengths(alpha: float, beta: float, gamma: float) -> np.ndarray:
    """lee Eq. (5)-(9): l_i = |P + [R] r_i - R_i|, [R] = Rx(alpha) Ry(beta) Rz(gamma) (Eq. 4)."""
    R = _rx(alpha) @ _ry(beta) @ _rz(gamma)
    u = np.stack([np.cos(LEE_G), np.sin(LEE_G), np.zeros(3)], axis=1)
    return np.linalg.norm(LEE_P + (LEE_r * u) @ R.T - LEE_R * u, axis=1)


@pytest.fixture(scope="module")
def lee():
    return load_mechanism(MECH_DIR / "lee_spherical_rrps.yaml")


def test_lee_sizes(lee):
    assert lee.n == 21
    assert lee.n_cuts == 3
    assert lee.n_equations == 18
    assert lee.independent_names == ["l1", "l2", "l3"]
    _, J = closure_jacobian(lee, forward_kinematics(lee, lee.home[None]))
    assert lee.n - np.linalg.matrix_rank(J[0], tol=1e-9) == 3  # Grubler M = 3 (lee Eq. 1)


def test_lee_home_is_the_gamma_30_pose(lee):
    idx = [lee.joint_index(f"plate_rpy_{k}") for k in (1, 2, 3)]
    np.testing.assert_allclose(lee.home[idx], np.radians([0.0, 0.0, 30.0]), atol=1e-12)
    np.testing.assert_allclose(lee.home[lee.independent], _lee_leg_lengths(0, 0, np.pi / 6),
                               atol=1e-9)


@pytest.mark.parametrize("abg_deg", [(5.0, -5.0, 35.0), (10.0, 0.0, 25.0), (0.0, 8.0, 40.0),
                                     (-8.0, 6.0, 28.0)])
def test_lee_closure_from_leg_lengths_reproduces_orientation(lee, abg_deg):
    abg = np.radians(abg_deg)
    lengths = _lee_leg_lengths(*abg)
    assert np.all((lengths >= 0.5) & (lengths <= 2.0))
    res = solve_closure(lee, lengths[None], lee.home[None, lee.dependent])
    assert res.status[0] is ClosureStatus.CONVERGED
    idx = [lee.joint_index(f"plate_rpy_{k}") for k in (1, 2, 3)]
    np.testing.assert_allclose(res.q[0, idx], abg, atol=1e-10)
    T = frame_poses(lee, res.q, [lee.frame_index("plate")])[0, 0]
    np.testing.assert_allclose(T[:3, :3], _rx(abg[0]) @ _ry(abg[1]) @ _rz(abg[2]), atol=1e-10)
    np.testing.assert_allclose(T[:3, 3], LEE_P, atol=1e-12)


# ---- hwang2023 biped -------------------------------------------------------------------------

# Geometry of mechanisms/hwang2023_biped.yaml (ESTIMATES identified from hwang2023 Table 6, plus
# the free choices l1 = 50 mm, l2/l5 = 115/60 mm and zero hip y/z offsets), in m; l6 reaches the
# blade point E, the sole point lies BIPED_FOOT_EXT beyond it.
BIPED_L = (0.050, 0.115, 0.175, 0.165, 0.060, 0.1485)
BIPED_HIP = (0.110, 0.0, 0.0)
BIPED_FOOT_EXT = 0.0015


def _hwang_leg(theta: np.ndarray) -> np.ndarray:
    """hwang2023 Eq. (1b)-(1h) as printed, right leg: A_G0' A_0'1' ... A_5'6' (frame 0_6')."""
    l1, l2, l3, l4, l5, l6 = BIPED_L
    c, s = np.cos(theta), np.sin(theta)
    A = [np.array([[1.0, 0, 0, BIPED_HIP[0]], [0, -1, 0, BIPED_HIP[1]], [0, 0, -1, BIPED_HIP[2]],
                   [0, 0, 0, 1]])]
    A.append(np.array([[c[0], -s[0], 0, 0], [s[0], c[0], 0, 0], [0, 0, 1, l1], [0, 0, 0, 1]]))
    A.append(np.array([[c[1], 0, s[1], l2 * s[1]], [0, 1, 0, 0], [-s[1], 0, c[1], l2 * c[1]],
                       [0, 0, 0, 1]]))
    for k, lk in ((2, l3), (3, l4), (4, l5)):
        A.append(np.array([[1.0, 0, 0, 0], [0, c[k], -s[k], -lk * s[k]],
                           [0, s[k], c[k], lk * c[k]], [0, 0, 0, 1]]))
    A.append(np.array([[c[5], 0, s[5], l6 * s[5]], [0, 1, 0, 0], [-s[5], 0, c[5], l6 * c[5]],
                       [0, 0, 0, 1]]))
    T = np.eye(4)
    for Ak in A:
        T = T @ Ak
    return T


MIRROR = np.diag([-1.0, 1.0, 1.0, 1.0])


@pytest.fixture(scope="module")
def biped():
    return load_mechanism(MECH_DIR / "hwang2023_biped.yaml")


def test_biped_is_two_open_6r_legs(biped):
    assert biped.n == 12 and not biped.cuts and len(biped.independent) == 12
    assert biped.frame_names[biped.end_effector] in ("foot_r", "foot_l")
    np.testing.assert_allclose(np.degrees(biped.upper), [90, 90, 90, 150, 90, 90] * 2)
    np.testing.assert_allclose(np.degrees(biped.lower), [-90, -90, -90, -150, -90, -90] * 2)


def test_biped_legs_match_eq1_product(biped):
    qs = _random_configs(biped, 20, seed=17)
    names = ["e6_r", "e6_l", "foot_r", "foot_l", "blade_r", "blade_l"]
    T = frame_poses(biped, qs, [biped.frame_index(f) for f in names])
    right = [biped.joint_index(f"r_theta{k}") for k in range(1, 7)]
    left = [biped.joint_index(f"l_theta{k}") for k in range(1, 7)]
    for i, q in enumerate(qs):
        T_r = _hwang_leg(q[right])
        # left leg = mirror image of the right in the body's y-z plane
        T_l = MIRROR @ _hwang_leg(q[left]) @ MIRROR
        np.testing.assert_allclose(T[i, 0], T_r, atol=1e-12)
        np.testing.assert_allclose(T[i, 1], T_l, atol=1e-12)
        # Eq. (3): i_06' = u_X'', j_06' = -u_Y'', k_06' = -u_Z'' (right); left with gamma_Y = 180
        ext = _T(None, (0, 0, BIPED_FOOT_EXT))
        np.testing.assert_allclose(T[i, 4], T_r @ _T(np.diag([1.0, -1, -1])), atol=1e-12)
        np.testing.assert_allclose(T[i, 5], T_l @ _T(np.diag([-1.0, -1, 1])), atol=1e-12)
        np.testing.assert_allclose(T[i, 2], T_r @ ext @ _T(np.diag([1.0, -1, -1])), atol=1e-12)
        np.testing.assert_allclose(T[i, 3], T_l @ ext @ _T(np.diag([-1.0, -1, 1])), atol=1e-12)


def test_biped_matches_the_closed_form_module(biped):
    """The file and mechkin.solvers.biped.leg describe the same legs (same
    estimates)."""
    bl = pytest.importorskip("mechkin.solvers.biped.leg")
    geo = bl.HWANG2023_ESTIMATED
    qs = _random_configs(biped, 10, seed=23)
    for side, s in (("right", "r"), ("left", "l")):
        idx = [biped.joint_index(f"{s}_theta{k}") for k in range(1, 7)]
        for kind in ("foot", "blade"):
            T = frame_poses(biped, qs, [biped.frame_index(f"{kind}_{s}")])[:, 0]
            T_cf = bl.leg_fk(geo, side, qs[:, idx], np.eye(4), kind)
            # biped_leg returns the paper's 0_6' frame: Psi_1 diag(1,-1,-1) right, Psi_2 left
            flip = _T(np.diag([1.0, -1, -1])) if side == "right" else np.eye(4)
            np.testing.assert_allclose(T, T_cf @ flip, atol=1e-12)


# hwang2023 Table 6 (deg; row (a) q1 with its two lost commas restored, PAPER_NOTES) and Table 5
# planes: (a) lX = 0, lY = 15 deg; (b) lX = 15, lY = 15 deg; right plane Rx(lX) Ry(lY), left
# plane additionally Ry(180) (gamma_Y = 180, Table 1), so its Z2 is the negated normal.
HWANG_TABLE6 = {
    "a": ((0, 4.34, 5.63, -11.60, 5.97, -19.34), (0, -4.90, 33.56, -69.45, 35.89, 19.90), 0.0,
          "foot"),
    "b": ((0, 4.28, 2.43, -5.00, 2.57, -19.28), (0, -4.84, 33.16, -68.61, 35.45, 19.84), 0.0,
          "blade"),
    "g": ((1.19, 4.42, -6.36, -5.00, 26.41, -19.58), (-1.35, -5.03, 22.82, -69.32, 61.56, 20.21),
          15.0, "blade"),
}


@pytest.mark.parametrize("case", sorted(HWANG_TABLE6))
def test_biped_table6_soles_lie_on_the_plane(biped, case):
    """Orientation part of Table 6 (independent of the estimated lengths): the right sole/blade
    normal Z1'' is the plane normal and the left Z2'' its opposite, to 0.01 deg."""
    q_r, q_l, lam_x, kind = HWANG_TABLE6[case]
    q = np.zeros(12)
    q[[biped.joint_index(f"r_theta{k}") for k in range(1, 7)]] = np.radians(q_r)
    q[[biped.joint_index(f"l_theta{k}") for k in range(1, 7)]] = np.radians(q_l)
    T = frame_poses(biped, q[None], [biped.frame_index(f"{kind}_{s}") for s in "rl"])[0]
    normal = (_rx(np.radians(lam_x)) @ _ry(np.radians(15.0)))[:, 2]
    ang_r = np.degrees(np.arccos(np.clip(T[0, :3, 2] @ normal, -1, 1)))
    ang_l = np.degrees(np.arccos(np.clip(-T[1, :3, 2] @ normal, -1, 1)))
    assert ang_r < 0.01 and ang_l < 0.01
    if lam_x == 0.0:
        # on plane (a) both contact points are at the same distance from the plane: a check of
        # the estimated lengths l3, l4, l6, l2 + l5 against Table 6 (rounding: ~0.02 mm)
        assert abs(T[0, :3, 3] @ normal - T[1, :3, 3] @ normal) < 5e-5

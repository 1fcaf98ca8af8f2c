"""Closed-form kinematics of lee's spherical RRPS mechanism: cross-checks (DESIGN.md, STYLE 2.8)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.errors import ModelError
from mechkin.solvers.closed_form import lee_forward
from mechkin.solvers.closed_form.lee_spherical import (
    LeeGeometry,
    euler_xyz_from_matrix,
    evaluate_poses,
    forward_position,
    forward_position_batch,
    forward_position_newton,
    forward_rates,
    inverse_position,
    isotropy_from_jacobian,
    isotropy_index,
    jacobian,
    leg_residuals,
    matrix_from_euler_xyz,
    sym3_eigvalsh,
    within_stroke,
)
from mechkin.spatial import matrix_from_quat, rot_x, rot_y, rot_z

RADII = (0.25, 0.5, 0.75, 1.0)
DEG = np.pi / 180.0


def _random_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """Poses over SO(3) with beta away from the Euler-angle singularity +-90 deg."""
    return np.column_stack(
        [rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.4, 1.4, n), rng.uniform(-np.pi, np.pi, n)]
    )


def _angle_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.angle(np.exp(1j * (a - b))))


# --------------------------------------------------------------------------- geometry, Eq. 4, 9


def test_geometry_defaults_are_the_papers():
    g = LeeGeometry()
    assert_allclose(g.base_points[1], [np.cos(120 * DEG), np.sin(120 * DEG), 0.0])  # Eq. (2), (22)
    assert_allclose(g.top_points[2], 0.75 * np.array([np.cos(240 * DEG), np.sin(240 * DEG), 0]))
    assert (g.l_min, g.l_max, g.center) == (0.5, 2.0, (0.0, 0.0, 1.0))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"r": 0.0}, "r: expected a positive number"),
        ({"R": -1.0}, "R: expected a positive number"),
        ({"l_min": 2.0, "l_max": 1.0}, "l_min < l_max"),
        ({"top_angles": (0.0, 0.0, 1.0)}, "3 distinct angles"),
    ],
)
def test_geometry_rejects_bad_input(kwargs, match):
    with pytest.raises(ModelError, match=match):
        LeeGeometry(**kwargs)


def test_rotation_is_rx_ry_rz_eq4():
    mu = _random_poses(np.random.default_rng(0), 50)
    R = matrix_from_euler_xyz(mu)
    assert_allclose(R, rot_x(mu[:, 0]) @ rot_y(mu[:, 1]) @ rot_z(mu[:, 2]), atol=1e-15)
    assert_allclose(euler_xyz_from_matrix(R), mu, atol=1e-13)


def test_inverse_position_eq9_expanded_form():
    """Eq. (9) term by term equals |P + [R] r_i - R_i| (and the corrected Eq. 10 holds)."""
    g = LeeGeometry(r=0.6)
    mu = _random_poses(np.random.default_rng(1), 40)
    lengths = inverse_position(g, mu)
    R = matrix_from_euler_xyz(mu)
    P = np.array(g.center)
    for i in range(3):
        Ri, ri = g.base_points[i], R @ g.top_points[i]
        l2 = P @ P + Ri @ Ri + 0.6**2 - 2 * Ri @ P + 2 * (P - Ri) @ ri.T  # lee Eq. (9)
        assert_allclose(lengths[:, i] ** 2, l2, rtol=1e-14)
    assert_allclose(leg_residuals(g, R, lengths), 0.0, atol=1e-14)


def test_within_stroke_marks_each_leg():
    g = LeeGeometry()
    assert within_stroke(
        g, np.array([[0.5, 1.0, 2.0], [0.49, 1.0, 1.0], [1.0, 2.01, 1.0]])
    ).tolist() == [
        True,
        False,
        False,
    ]


# --------------------------------------------------------------------------- rates, Eqs. 17-21


@pytest.mark.parametrize("r", RADII)
def test_jacobian_matches_finite_differences(r):
    g = LeeGeometry(r=r)
    mu = _random_poses(np.random.default_rng(2), 30)
    G = jacobian(g, mu)
    h = 1e-6
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        fd = (inverse_position(g, mu + e) - inverse_position(g, mu - e)) / (2 * h)
        assert_allclose(G[:, :, k], fd, atol=1e-8)


def test_forward_rates_invert_the_jacobian():
    g = LeeGeometry(r=0.5)
    rng = np.random.default_rng(3)
    mu = _random_poses(rng, 20)
    mu_dot = rng.standard_normal((20, 3))
    l_dot = np.einsum("mij,mj->mi", jacobian(g, mu), mu_dot)  # lee Eq. (17)
    back, singular = forward_rates(g, mu, l_dot)  # lee Eq. (19)-(20)
    assert not singular.any()
    assert_allclose(back, mu_dot, rtol=1e-8, atol=1e-9)
    _, singular = forward_rates(g, np.zeros((1, 3)), np.ones((1, 3)))
    assert singular.tolist() == [True]


@pytest.mark.parametrize("r", RADII)
def test_isotropy_at_alpha_beta_zero_closed_form(r):
    """sigma_KI(0, 0, gamma) = min(sqrt2 sin g, 1/(sqrt2 sin g)) for every r (PAPER_NOTES)."""
    gam = np.deg2rad(np.arange(1.0, 180.0, 1.0))
    mu = np.column_stack([0 * gam, 0 * gam, gam])
    expected = np.minimum(np.sqrt(2) * np.sin(gam), 1 / (np.sqrt(2) * np.sin(gam)))
    g = LeeGeometry(r=r)
    assert_allclose(isotropy_index(g, mu), expected, rtol=1e-12)
    assert_allclose(isotropy_index(g, -mu), expected, rtol=1e-12)
    assert_allclose(isotropy_index(g, mu, method="svd"), expected, rtol=1e-12)


@pytest.mark.parametrize("r", RADII)
def test_home_and_other_singular_poses_give_zero_not_nan(r):
    g = LeeGeometry(r=r)
    mu = np.array([[0, 0, 0], [0.3, np.pi / 2, 0.2], [-0.4, -np.pi / 2, 1.0], [0, 0, np.pi]])
    for method in ("closed_form", "svd"):
        s = isotropy_index(g, mu, method=method)
        assert np.all(np.isfinite(s))
        assert_allclose(s, 0.0, atol=1e-12)


def test_isotropy_closed_form_matches_svd():
    rng = np.random.default_rng(4)
    g = LeeGeometry(r=0.75)
    mu = _random_poses(rng, 20000)
    s_cf = isotropy_index(g, mu)
    s_svd = isotropy_index(g, mu, method="svd")
    assert_allclose(s_cf, s_svd, rtol=1e-9, atol=1e-13)
    # Random matrices, rank-deficient ones and a zero matrix.
    G = rng.standard_normal((500, 3, 3))
    G[:100, :, 2] = G[:100, :, 0] * 0.3 - G[:100, :, 1]
    G[100:150] = rng.standard_normal((50, 3, 1)) * rng.standard_normal((50, 1, 3))
    G[150] = 0.0
    assert_allclose(isotropy_from_jacobian(G), isotropy_from_jacobian(G, method="svd"), atol=1e-12)


def test_sym3_eigvalsh_including_repeated_eigenvalues():
    rng = np.random.default_rng(5)
    Q = matrix_from_quat(rng.standard_normal((400, 4)))
    lam = np.sort(rng.standard_normal((400, 3)), axis=-1)
    lam[:100, 1] = lam[:100, 2]  # double largest
    lam[100:200, 0] = lam[100:200, 1]  # double smallest
    lam[200:250] = lam[200:250, :1]  # triple
    A = Q @ (lam[:, :, None] * np.swapaxes(Q, -1, -2))
    assert_allclose(sym3_eigvalsh(A), lam, atol=1e-13)


def test_evaluate_poses_chunks_agree():
    g = LeeGeometry(r=0.5)
    mu = _random_poses(np.random.default_rng(6), 1000)
    a = evaluate_poses(g, mu, chunk=1000)
    b = evaluate_poses(g, mu, chunk=37)
    for x, y in zip(a, b, strict=True):
        assert_allclose(x, y, rtol=0, atol=0)
    assert_allclose(a.det_G, np.linalg.det(jacobian(g, mu)), atol=1e-13)


# --------------------------------------------------------------------------- forward position


@pytest.mark.parametrize("r", (0.25, 0.75))
def test_forward_returns_the_inverse_pose_every_time(r):
    """Inverse then forward round-trips on 300 seeded random poses; every mode is exact."""
    g = LeeGeometry(r=r)
    mu = _random_poses(np.random.default_rng(7), 300)
    lengths = inverse_position(g, mu)
    sigma = isotropy_index(g, mu)
    results = forward_position_batch(g, lengths)
    for i, res in enumerate(results):
        err = _angle_diff(res.mu, mu[i]).max(axis=-1).min()
        # At singular poses two modes merge and the root is only sqrt(eps)-accurate; every
        # workspace pose (sigma_KI >= 0.01) is far from that.
        assert err < (1e-12 if sigma[i] >= 1e-3 else 1e-9), (i, mu[i], sigma[i], err)
        assert_allclose(
            inverse_position(g, res.mu), np.broadcast_to(lengths[i], res.mu.shape), atol=1e-12
        )
        assert res.n_modes % 2 == 0 and res.n_modes <= 8


def test_mode_counts_reach_the_bound_of_eight():
    g = LeeGeometry(r=0.75)
    mu = _random_poses(np.random.default_rng(8), 300)
    counts = np.bincount([r.n_modes for r in forward_position_batch(g, inverse_position(g, mu))])
    assert counts[8] > 0 and counts[2] > 0 and counts.sum() == 300


@pytest.mark.parametrize("seed", range(6))
def test_forward_misses_no_mode_found_by_multistart_newton(seed):
    """2000 random starts over SO(3), each polished, find nothing the closed form missed."""
    rng = np.random.default_rng(100 + seed)
    g = LeeGeometry(r=float(rng.uniform(0.2, 1.0)))
    mu = _random_poses(rng, 1)[0]
    lengths = inverse_position(g, mu)
    res = forward_position(g, lengths)
    b = g.leg_offsets
    c = 0.5 * (lengths**2 - np.sum(b * b, -1) - g.r**2)
    R, resid = lee_forward._polish(
        g, matrix_from_quat(rng.standard_normal((2000, 4))), np.broadcast_to(c, (2000, 3))
    )
    found = R[resid < 1e-10]
    assert found.shape[0] > 100
    dist = np.linalg.norm(found[:, None] - res.R[None], axis=(-2, -1)).min(axis=1)
    assert dist.max() < 1e-7


def test_forward_agrees_with_plain_newton_from_the_inverse_pose():
    rng = np.random.default_rng(9)
    g = LeeGeometry(r=0.5)
    mu = _random_poses(rng, 60)
    keep = isotropy_index(g, mu) > 0.05
    for m in mu[keep]:
        lengths = inverse_position(g, m)
        newton = forward_position_newton(g, lengths, m + rng.normal(0, 0.02, 3))
        assert newton.status == "ok"
        assert _angle_diff(newton.mu, m).max() < 1e-11
        modes = forward_position(g, lengths)
        assert _angle_diff(modes.mu, newton.mu).max(axis=-1).min() < 1e-11


def test_newton_reports_singular_and_not_converged():
    g = LeeGeometry(r=0.5)
    lengths = inverse_position(g, np.array([0.1, 0.2, 0.3]))
    assert forward_position_newton(g, lengths, np.zeros(3)).status == "singular"
    assert forward_position_newton(g, lengths, np.array([0.1, 0.2, 0.2]), max_iter=1).status == (
        "not converged"
    )


def test_unreachable_lengths_have_no_mode():
    g = LeeGeometry(r=0.5)
    for lengths in ([0.1, 0.1, 0.1], [5.0, 5.0, 5.0], [1.5, 0.2, 1.5]):
        res = forward_position(g, np.array(lengths))
        assert res.n_modes == 0 and res.mu.shape == (0, 3)


def test_general_geometry_round_trips():
    """Unequal offset angles and a moved centre: the elimination never assumes symmetry."""
    g = LeeGeometry(
        r=0.6,
        R=1.2,
        base_angles=(0.1, 2.3, 4.0),
        top_angles=(0.0, 100 * DEG, 230 * DEG),
        center=(0.05, -0.1, 0.9),
    )
    mu = _random_poses(np.random.default_rng(10), 100)
    sigma = isotropy_index(g, mu)
    mu = mu[sigma > 1e-3]
    for m, res in zip(mu, forward_position_batch(g, inverse_position(g, mu)), strict=True):
        assert _angle_diff(res.mu, m).max(axis=-1).min() < 1e-12


def test_antipodal_top_joints_are_handled():
    g = LeeGeometry(r=0.5, top_angles=(0.0, np.pi / 2, np.pi))
    mu = _random_poses(np.random.default_rng(11), 50)
    mu = mu[isotropy_index(g, mu) > 1e-3]
    for m, res in zip(mu, forward_position_batch(g, inverse_position(g, mu)), strict=True):
        assert _angle_diff(res.mu, m).max(axis=-1).min() < 1e-12


def test_papers_eqs_11_to_16_do_not_recover_the_pose():
    """lee Eq. (13) solves [B] v = A for one vector v, but each leg has its own [R] r_i."""
    g = LeeGeometry(r=0.75)
    mu = np.array([0.2, -0.3, 0.5])
    lengths = inverse_position(g, mu)
    B = g.leg_offsets  # rows (P - R_i), Eq. (11)
    A = 0.5 * (lengths**2 - np.sum(B * B, -1) - g.r**2)  # Eq. (12), sign corrected
    v = np.linalg.solve(B, A)  # Eq. (13)
    Rr = g.top_points @ matrix_from_euler_xyz(mu).T
    assert np.min(np.linalg.norm(Rr - v, axis=-1)) > 0.1  # v is none of the [R] r_i


def test_forward_matches_general_loop_closure_fk():
    """The general model (kim1995 cut links, Newton on phi_R) lands on one of our modes.

    mechanisms/lee_spherical_rrps.yaml has r = 0.5; its closure is solved from the home pose for
    leg lengths of random poses around it. Newton may converge to another assembly mode than the
    pose the lengths came from, but always to one that :func:`forward_position` lists.
    """
    closure = pytest.importorskip("mechkin.model.closure")
    kinematics = pytest.importorskip("mechkin.model.kinematics")
    from mechkin.model import load_mechanism

    path = Path(__file__).resolve().parents[2] / "mechanisms" / "lee_spherical_rrps.yaml"
    if not path.exists():
        pytest.skip(f"{path.name} not in this tree")
    mech = load_mechanism(path)
    g = LeeGeometry(r=0.5)
    rng = np.random.default_rng(12)
    n = 40
    mu = np.column_stack(
        [rng.normal(0, 0.25, n), rng.normal(0, 0.25, n), 30 * DEG + rng.normal(0, 0.25, n)]
    )
    lengths = inverse_position(g, mu)
    q_w0 = np.broadcast_to(mech.home[mech.dependent], (n, len(mech.dependent)))
    res = closure.solve_closure(mech, lengths, q_w0)
    assert res.ok.all()
    kin = kinematics.forward_kinematics(mech, res.q)
    R_model = kin.T_links[:, mech.link_names.index("plate"), :3, :3]
    for i in range(n):
        modes = forward_position(g, lengths[i])
        assert np.linalg.norm(modes.R - R_model[i], axis=(1, 2)).min() < 1e-9

"""Joint rates, frame twists and accelerations of complex chains against finite differences.

Along smooth motions of the independent joints, the loop closure is solved at t0 + k h
(k = -2..2) and central differences of the solved positions are compared with
:func:`motion_derivatives` at t0: dependent joint rates and accelerations (kim1995 Eq. (3)-(4)
differentiated), frame origin velocities and accelerations, angular velocities (from
``R' R^T``) and angular accelerations. The quadratic term gamma is checked on its own against
the finite-difference derivative of the analytic closure Jacobian, on and off the closure.
"""

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_trajectory
from mechkin.model.differential import (
    closure_bias,
    motion_derivatives,
    reduced_jacobian,
)
from mechkin.model.kinematics import closure_jacobian, forward_kinematics, frame_jacobian

ROOT = Path(__file__).resolve().parents[2]
MECHS = ["kim1995_direct_drive", "kim1995_stewart", "kim1995_end_effector_robot", "puma560",
         "lee_spherical_rrps", "data/fourbar", "data/fourbar_ground_cut", "delta", "five_bar"]
H_TRAJ = 2.5e-4  # time step of the central differences along the trajectory [s]
H_JAC = 1e-5  # step of the Jacobian differences for gamma
# central differences are O(h^2) ~ 6e-8 times the fourth derivative; closure round-off
# (~1e-14 in q for cond ~ 100) adds ~2e-7 after division by h^2
ATOL_TRAJ = 2e-6
RTOL_GAMMA = 1e-7


def _mech(name):
    if name.startswith("data/"):  # test mechanisms in tests/data
        return load_mechanism(ROOT / "tests" / f"{name}.yaml")
    return load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")


def _home(mech):
    return np.where(np.isfinite(mech.home), mech.home, 0.0)


def _motion(mech, seed):
    """q_v(t) = q_v0 + A sin(w t + ph): values and analytic first and second derivatives."""
    rng = np.random.default_rng(seed)
    nv = len(mech.independent)
    q0 = _home(mech)[mech.independent]
    A = 0.05 * (1.0 + rng.random(nv))
    w = 1.0 + rng.random(nv)
    ph = 2 * np.pi * rng.random(nv)

    def f(t):
        t = np.asarray(t, dtype=float)[..., None]
        return (q0 + A * np.sin(w * t + ph), A * w * np.cos(w * t + ph),
                -A * w**2 * np.sin(w * t + ph))

    return f


def _solve(mech, qv):
    res = solve_trajectory(mech, qv, _home(mech)[mech.dependent], chunk=1)
    assert res.ok.all(), [s.value for s in res.status]
    return res.q


def _omega_from_R(R_prev, R, R_next, h):
    """Angular velocity from [w]x = R' R^T with a central difference for R' (base frame)."""
    W = ((R_next - R_prev) / (2 * h)) @ np.swapaxes(R, -1, -2)
    return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)


@pytest.mark.parametrize("name", MECHS)
@pytest.mark.parametrize("seed", [0, 1])
def test_rates_and_accelerations_match_finite_differences(name, seed):
    mech = _mech(name)
    f = _motion(mech, seed)
    t0 = 0.4
    ts = t0 + H_TRAJ * np.arange(-2, 3)
    qv, _, _ = f(ts)
    q = _solve(mech, qv)
    _, qd_v, qdd_v = f(t0)
    md = motion_derivatives(mech, q[2:3], qd_v, qdd_v)
    # dependent and independent joints
    qd_fd = (q[3] - q[1]) / (2 * H_TRAJ)
    qdd_fd = (q[3] - 2 * q[2] + q[1]) / H_TRAJ**2
    np.testing.assert_allclose(md.qd[0], qd_fd, atol=ATOL_TRAJ)
    np.testing.assert_allclose(md.qdd[0], qdd_fd, atol=ATOL_TRAJ)
    assert np.abs(md.qdd[0, mech.dependent]).max(initial=0.0) > 1e-3 or not len(mech.dependent)
    # frames: origin velocity and acceleration, angular velocity and acceleration
    T = forward_kinematics(mech, q).frames(mech)
    p, R = T[..., :3, 3], T[..., :3, :3]
    v_fd = (p[3] - p[1]) / (2 * H_TRAJ)
    a_fd = (p[3] - 2 * p[2] + p[1]) / H_TRAJ**2
    w_fd = [_omega_from_R(R[k - 1], R[k], R[k + 1], H_TRAJ) for k in (1, 2, 3)]
    al_fd = (w_fd[2] - w_fd[0]) / (2 * H_TRAJ)
    np.testing.assert_allclose(md.twists[0, :, 3:], v_fd, atol=ATOL_TRAJ)
    np.testing.assert_allclose(md.twists[0, :, :3], w_fd[1], atol=ATOL_TRAJ)
    np.testing.assert_allclose(md.accelerations[0, :, 3:], a_fd, atol=ATOL_TRAJ)
    np.testing.assert_allclose(md.accelerations[0, :, :3], al_fd, atol=ATOL_TRAJ)
    # the closure holds to first and second order
    assert md.closure_rate_residual[0] < 1e-12
    assert md.closure_accel_residual[0] < 1e-12


@pytest.mark.parametrize("name", MECHS)
def test_twists_are_jacobian_times_rates(name):
    """Twist = geometric Jacobian (omega, v) @ qd for every frame, and J_r qd_v for {E}."""
    mech = _mech(name)
    f = _motion(mech, 3)
    q = _solve(mech, f([0.2])[0])
    qd_v = f(0.2)[1]
    md = motion_derivatives(mech, q, qd_v)
    kin = forward_kinematics(mech, q)
    for k, fi in enumerate(md.frames):
        np.testing.assert_allclose(md.twists[0, k], frame_jacobian(mech, kin, fi)[0] @ md.qd[0],
                                   atol=1e-14)
    if mech.end_effector is not None:
        Jr = reduced_jacobian(mech, q)
        np.testing.assert_allclose(Jr[0] @ qd_v, md.twists[0, md.frame(
            mech.frame_names[mech.end_effector])], atol=1e-13)


@pytest.mark.parametrize("name", ["kim1995_direct_drive", "kim1995_stewart",
                                  "kim1995_end_effector_robot", "lee_spherical_rrps",
                                  "data/fourbar_ground_cut", "delta"])
@pytest.mark.parametrize("closed", [True, False])
def test_gamma_is_derivative_of_jacobian_times_rates(name, closed):
    """gamma(q, qd) = (d/dt dphi/dq) qd by central differences of the analytic Jacobian."""
    mech = _mech(name)
    rng = np.random.default_rng(7)
    q = np.tile(_home(mech), (4, 1))
    if closed:
        f = _motion(mech, 5)
        q = _solve(mech, f(np.linspace(0.0, 0.3, 4))[0])
    else:
        q = q + 0.05 * rng.standard_normal(q.shape)  # off the closure: gamma is still exact
    qd = rng.standard_normal(q.shape)
    _, Jp = closure_jacobian(mech, forward_kinematics(mech, q + H_JAC * qd))
    _, Jm = closure_jacobian(mech, forward_kinematics(mech, q - H_JAC * qd))
    g_fd = np.einsum("mij,mj->mi", (Jp - Jm) / (2 * H_JAC), qd)
    g = closure_bias(mech, q, qd)
    assert g.shape == (4, mech.n_equations)
    assert np.abs(g).max() > 1e-2
    np.testing.assert_allclose(g, g_fd, atol=RTOL_GAMMA * np.abs(g_fd).max())


def test_gamma_zero_for_open_chain_and_for_zero_rates():
    puma = _mech("puma560")
    assert closure_bias(puma, _home(puma)[None], np.ones((1, 6))).shape == (1, 0)
    dd = _mech("kim1995_direct_drive")
    np.testing.assert_array_equal(closure_bias(dd, _home(dd)[None], np.zeros((1, 6))), 0.0)


def test_spatial_acceleration_is_derivative_of_spatial_twist():
    """(alpha, a - alpha x p - omega x v) = d/dt (omega, v - omega x p), by central differences
    of the analytic twists along the Stewart platform's motion."""
    mech = _mech("kim1995_stewart")
    f = _motion(mech, 2)
    ts = 0.3 + H_TRAJ * np.array([-1.0, 0.0, 1.0])
    qv, qd_v, qdd_v = f(ts)
    q = _solve(mech, qv)
    md = motion_derivatives(mech, q, qd_v, qdd_v)
    tw, p = md.twists, md.positions
    sp = np.concatenate([tw[..., :3], tw[..., 3:] - np.cross(tw[..., :3], p)], axis=-1)
    np.testing.assert_allclose(md.spatial_accelerations[1], (sp[2] - sp[0]) / (2 * H_TRAJ),
                               atol=ATOL_TRAJ * 10)


def test_requested_frames_and_batch_broadcast():
    mech = _mech("kim1995_direct_drive")
    f = _motion(mech, 4)
    q = _solve(mech, f(np.linspace(0, 1, 5))[0])
    qd_v = f(0.5)[1]  # one row broadcast over the batch
    full = motion_derivatives(mech, q, qd_v)
    sub = motion_derivatives(mech, q, qd_v, frames=["tool", 0])
    assert sub.frame_names == ("tool", mech.frame_names[0])
    np.testing.assert_array_equal(sub.twists[:, 0], full.twists[:, full.frame("tool")])
    np.testing.assert_array_equal(sub.qdd, full.qdd)
    with pytest.raises(KeyError):
        motion_derivatives(mech, q, qd_v, frames=["nope"])
    with pytest.raises(ValueError):
        motion_derivatives(mech, q, np.zeros(2))
    with pytest.raises(ValueError):
        motion_derivatives(mech, q[:, :4], qd_v)


def test_direct_drive_passive_rates_closed_form():
    """kim1995 direct-drive arm (mechanism file notes): p_C = pi/2 - q2 - q3 and
    p_R = p_Q = q2 + q3 + pi/2, so the passive rates and accelerations are those sums."""
    mech = _mech("kim1995_direct_drive")
    f = _motion(mech, 6)
    q = _solve(mech, f(np.linspace(0.0, 2.0, 7))[0])
    _, qd_v, qdd_v = f(np.linspace(0.0, 2.0, 7))
    md = motion_derivatives(mech, q, qd_v, qdd_v)
    for x, xv in ((md.qd, qd_v), (md.qdd, qdd_v)):
        s = xv[:, 1] + xv[:, 2]
        np.testing.assert_allclose(x[:, mech.joint_index("p_C")], -s, atol=1e-12)
        np.testing.assert_allclose(x[:, mech.joint_index("p_R")], s, atol=1e-12)
        np.testing.assert_allclose(x[:, mech.joint_index("p_Q")], s, atol=1e-12)


def test_rates_from_samples_second_order():
    """Sampled sine on a non-uniform grid: the error falls ~4x when the steps halve."""
    from mechkin.model.differential import rates_from_samples

    errs = []
    for n in (101, 201):
        u = np.linspace(0.0, 1.0, n)
        t = u + 0.1 * u**2  # non-uniform
        x = np.stack([np.sin(3 * t), np.cos(2 * t)], axis=1)
        xd, xdd = rates_from_samples(t, x)
        ref_d = np.stack([3 * np.cos(3 * t), -2 * np.sin(2 * t)], axis=1)
        ref_dd = np.stack([-9 * np.sin(3 * t), -4 * np.cos(2 * t)], axis=1)
        errs.append((np.abs(xd - ref_d)[1:-1].max(), np.abs(xdd - ref_dd)[2:-2].max()))
    assert errs[1][0] < errs[0][0] / 3 and errs[1][1] < errs[0][1] / 3
    assert errs[1][0] < 1e-3 and errs[1][1] < 1e-2
    with pytest.raises(ValueError):
        rates_from_samples(np.array([0.0, 1.0, 1.0]), np.zeros((3, 1)))

"""mechkin.model.moving_base: the base twist and acceleration from roll-pitch-yaw rates, and
frame motion composed with a moving base, against central finite differences of the poses."""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.model.moving_base import base_motion, in_world
from mechkin.spatial.rotations import matrix_from_rpy, rotation_log

H = 1e-4


def _fd_omega(R):
    return rotation_log(R[2:] @ np.swapaxes(R[:-2], 1, 2)) / (2 * H)


@pytest.mark.parametrize("seed", range(4))
def test_base_twist_and_acceleration_match_finite_differences(seed):
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(6, 6)) * 0.6
    t = 0.3 + H * np.arange(-1, 8)
    # coefficients of xyz (first 3) and rpy (last 3)
    x = c[0][:, None] + c[2][:, None] * t + c[4][:, None] * np.sin(2 * t)
    xd = c[2][:, None] + 2 * c[4][:, None] * np.cos(2 * t)
    xdd = -4 * c[4][:, None] * np.sin(2 * t)
    x, xd, xdd = x.T, xd.T, xdd.T
    T, tw, ac = base_motion(x[:, :3], x[:, 3:], xd[:, :3], xd[:, 3:], xdd[:, :3], xdd[:, 3:])
    np.testing.assert_allclose(T[:, :3, :3], matrix_from_rpy(x[:, 3:]), atol=0)
    np.testing.assert_allclose(tw[1:-1, :3], _fd_omega(T[:, :3, :3]), atol=1e-6)
    np.testing.assert_allclose(ac[1:-1, :3], (tw[2:, :3] - tw[:-2, :3]) / (2 * H), atol=1e-6)
    np.testing.assert_allclose(tw[:, 3:], xd[:, :3], atol=0)


@pytest.mark.parametrize("seed", range(4))
def test_frame_motion_in_world_matches_finite_differences(seed):
    """A frame moving in the base frame (its own rpy/xyz trajectory), seen from a moving base:
    the world twist and classical acceleration of in_world are the derivatives of T_0 T."""
    rng = np.random.default_rng(100 + seed)
    t = 0.7 + H * np.arange(-1, 6)
    parts = []
    for _ in range(2):  # base, frame
        c = rng.normal(size=(3, 6)) * 0.7
        x = (c[0][:, None] + c[1][:, None] * t + c[2][:, None] * np.sin(2 * t)).T
        xd = (c[1][:, None] + 2 * c[2][:, None] * np.cos(2 * t)).T
        xdd = (-4 * c[2][:, None] * np.sin(2 * t)).T
        parts.append(base_motion(x[:, :3], x[:, 3:], xd[:, :3], xd[:, 3:], xdd[:, :3],
                                 xdd[:, 3:]))
    (T0, tw0, ac0), (Tf, twf, acf) = parts
    T_w, tw_w, ac_w = in_world(T0, tw0, ac0, Tf[:, None], twf[:, None], acf[:, None])
    T_w, tw_w, ac_w = T_w[:, 0], tw_w[:, 0], ac_w[:, 0]
    np.testing.assert_allclose(T_w, T0 @ Tf, atol=1e-15)
    p = T_w[:, :3, 3]
    np.testing.assert_allclose(tw_w[1:-1, :3], _fd_omega(T_w[:, :3, :3]), atol=1e-6)
    np.testing.assert_allclose(tw_w[1:-1, 3:], (p[2:] - p[:-2]) / (2 * H), atol=1e-6)
    np.testing.assert_allclose(ac_w[1:-1, :3], (tw_w[2:, :3] - tw_w[:-2, :3]) / (2 * H),
                               atol=1e-6)
    np.testing.assert_allclose(ac_w[1:-1, 3:], (p[2:] - 2 * p[1:-1] + p[:-2]) / H ** 2,
                               atol=2e-4)
    # a still base at the world frame leaves the motion as it is
    I4 = np.broadcast_to(np.eye(4), T0.shape)
    Z = np.zeros_like(tw0)
    T2, tw2, ac2 = in_world(I4, Z, Z, Tf[:, None], twf[:, None], acf[:, None])
    np.testing.assert_allclose(T2[:, 0], Tf, atol=0)
    np.testing.assert_allclose(tw2[:, 0], twf, atol=0)
    np.testing.assert_allclose(ac2[:, 0], acf, atol=0)

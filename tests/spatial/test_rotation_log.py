"""rotation_log: rotation vectors of rotation matrices, also at and near half turns."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mechkin.spatial.rotations import rotation_log


def test_matches_scipy_for_every_angle_up_to_a_half_turn():
    rng = np.random.default_rng(0)
    axes = rng.normal(size=(2000, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    ang = np.concatenate([np.linspace(0.0, np.pi - 1e-9, 1990), np.pi - np.logspace(-3, -12, 10)])
    rv = axes * ang[:, None]
    out = rotation_log(Rotation.from_rotvec(rv).as_matrix())
    np.testing.assert_allclose(out, rv, atol=1e-9)
    assert np.all(np.isfinite(out))


def test_half_turn_gives_angle_pi_and_the_same_rotation():
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(50, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    R = Rotation.from_rotvec(axes * np.pi).as_matrix()
    out = rotation_log(R)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), np.pi, atol=1e-12)
    np.testing.assert_allclose(Rotation.from_rotvec(out).as_matrix(), R, atol=1e-12)


def test_identity_is_zero():
    np.testing.assert_array_equal(rotation_log(np.eye(3)[None]), np.zeros((1, 3)))

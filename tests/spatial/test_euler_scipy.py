"""Euler strings read exactly as scipy's ``Rotation.from_euler``: upper case intrinsic, lower case
extrinsic; every sequence scipy accepts (1 to 3 axes, consecutive axes distinct), on random
angles, to 1e-12; the inverse (:func:`euler_angles_from_matrix`) round-trips both cases."""

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from mechkin.spatial.euler_conventions import (
    euler_angles_from_matrix,
    euler_matrix,
    is_extrinsic,
)


def _scipy_sequences():
    out = []
    for n in (1, 2, 3):
        for axes in itertools.product("xyz", repeat=n):
            if any(a == b for a, b in itertools.pairwise(axes)):
                continue  # scipy refuses consecutive equal axes
            s = "".join(axes)
            out += [s, s.upper()]
    return out


SEQUENCES = _scipy_sequences()


def test_every_scipy_sequence_is_covered():
    assert len(SEQUENCES) == 2 * (3 + 6 + 12)  # 21 sequences, both cases


@pytest.mark.parametrize("seq", SEQUENCES)
def test_matrix_equals_scipy(seq):
    rng = np.random.default_rng(abs(hash(seq)) % 2**32)
    t = rng.uniform(-np.pi, np.pi, size=(200, len(seq)))
    want = Rotation.from_euler(seq, t).as_matrix()
    assert_allclose(euler_matrix(seq, t), want, rtol=0, atol=1e-12)
    assert is_extrinsic(seq) == seq.islower()


@pytest.mark.parametrize("seq", [s for s in SEQUENCES if len(s) == 3])
def test_angles_round_trip_and_match_scipy_matrix(seq):
    rng = np.random.default_rng(7)
    t = rng.uniform(-np.pi, np.pi, size=(200, 3))
    R = Rotation.from_euler(seq, t).as_matrix()
    ang = euler_angles_from_matrix(seq, R)
    assert_allclose(euler_matrix(seq, ang), R, rtol=0, atol=1e-12)
    assert_allclose(Rotation.from_euler(seq, ang).as_matrix(), R, rtol=0, atol=1e-12)


def test_signed_lower_case_is_extrinsic():
    t = np.array([0.3, -0.7, 1.1])
    assert_allclose(euler_matrix("x -y z", t),
                    Rotation.from_euler("xyz", t * [1, -1, 1]).as_matrix(), atol=1e-12)


@pytest.mark.parametrize("bad", ["xYz", "Xyz", "x Y"])
def test_mixed_case_is_refused(bad):
    with pytest.raises(ValueError, match="upper case .intrinsic.*lower"):
        euler_matrix(bad, np.zeros(len([c for c in bad if c.isalpha()])))

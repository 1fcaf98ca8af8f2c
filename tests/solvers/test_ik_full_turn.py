"""IK of joints whose limits span more than a full turn: the answer is the 2 pi representative
within the limits nearest the guess, never shifted by a turn for no reason (both back ends)."""

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, IkStatus, pose_errors, solve_ik, solve_ik_batch

DEG = np.pi / 180.0
Q_TRUE = np.array([20.0, 60.0, -70.0, 100.0, 40.0, 120.0]) * DEG  # q4 = 100, q6 = 120 deg


@pytest.fixture
def puma270(root, tmp_path):
    """The bundled PUMA 560 with its wrist limits widened to +-270 deg (more than a turn)."""
    text = (root / "mechanisms" / "puma560.yaml").read_text()
    assert text.count("limits: [-266, 266]") == 2
    p = tmp_path / "puma560_270.yaml"
    p.write_text(text.replace("limits: [-266, 266]", "limits: [-270, 270]"))
    mech = load_mechanism(p)
    np.testing.assert_allclose(mech.upper[[3, 5]], 270 * DEG)
    return mech


def _target(mech, q):
    return forward_kinematics(mech, q[None]).frames(mech, [mech.end_effector])[0, 0]


def _check(mech, q, T, tol=1e-9):
    pe, oe = pose_errors(_target(mech, q)[None], T[None])
    assert pe[0] < tol and oe[0] < tol
    assert np.all(q >= mech.lower - 1e-12) and np.all(q <= mech.upper + 1e-12)


def test_exact_guess_is_returned_unchanged(puma270, lm_backend):
    T = _target(puma270, Q_TRUE)
    r = solve_ik(puma270, T, q_v0=Q_TRUE)
    assert r.status is IkStatus.OK and r.iterations == 0
    np.testing.assert_allclose(r.q_v / DEG, Q_TRUE / DEG, atol=1e-9)


@pytest.mark.parametrize("method", ["lm", "cg-golden"])
def test_near_guess_returns_the_nearest_turn(puma270, lm_backend, method):
    T = _target(puma270, Q_TRUE)
    guess = Q_TRUE + np.array([2.0, -3.0, 2.0, 4.0, -3.0, 5.0]) * DEG
    r = solve_ik(puma270, T, q_v0=guess, options=IkOptions(method=method))
    assert r.ok
    _check(puma270, r.q, T, 1e-9 if method == "lm" else 1e-6)  # the default tolerances
    # the same solution branch as the guess: q4 = 100 deg, q6 = 120 deg (not -260, -240)
    np.testing.assert_allclose(r.q_v / DEG, Q_TRUE / DEG, atol=1e-6 if method == "lm" else 1e-3)


def test_batch_returns_the_nearest_turn(puma270, lm_backend):
    T = _target(puma270, Q_TRUE)
    guess = Q_TRUE + np.array([2.0, -3.0, 2.0, 4.0, -3.0, 5.0]) * DEG
    r = solve_ik_batch(puma270, np.stack([T, T]), q_v0=np.stack([Q_TRUE, guess]))
    assert r.ok.all()
    assert r.iterations[0] == 0
    for q in r.q:
        _check(puma270, q, T)
    np.testing.assert_allclose(r.q_v / DEG, np.stack([Q_TRUE, Q_TRUE]) / DEG, atol=1e-6)


def test_guess_a_turn_away_gives_the_representative_near_it(puma270, lm_backend):
    """A guess at q4 = -260 deg (the same wrist pose one turn down) keeps that turn."""
    T = _target(puma270, Q_TRUE)
    guess = Q_TRUE.copy()
    guess[3] -= 2 * np.pi
    r = solve_ik(puma270, T, q_v0=guess)
    assert r.ok and r.iterations == 0
    assert r.q_v[3] / DEG == pytest.approx(-260.0, abs=1e-9)
    assert r.q_v[5] / DEG == pytest.approx(120.0, abs=1e-9)

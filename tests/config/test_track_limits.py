"""Track limits of a closed chain: one value per joint, or one per independent joint (widened,
the passive joints unbounded), and the count message naming both."""

from pathlib import Path

import numpy as np
import pytest

from mechkin.config.scenario import Units
from mechkin.config.track_spec import LimitsSpec, limit_count_message, mechanism_limits_si
from mechkin.model import load_mechanism

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def stewart():
    return load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")


def test_independent_lists_widen_to_every_joint(stewart):
    iv = np.asarray(stewart.independent)
    units = Units(length="m", angle="deg")
    lim = mechanism_limits_si(LimitsSpec(torque=[4000.0] * 6, qd=[1.0] * 6), units, stewart)
    for name, value in (("torque", 4000.0), ("qd", 1.0)):  # legs are prismatic: m/s as given
        lo, hi = lim[name]
        assert lo.shape == hi.shape == (stewart.n,)
        np.testing.assert_array_equal(hi[iv], value)
        np.testing.assert_array_equal(lo[iv], -value)
        passive = np.setdiff1d(np.arange(stewart.n), iv)
        assert np.all(np.isinf(hi[passive])) and np.all(np.isinf(lo[passive]))


def test_full_lists_unchanged_and_angles_scaled(stewart):
    units = Units(length="m", angle="deg")
    lim = mechanism_limits_si(LimitsSpec(qd=[90.0] * stewart.n), units, stewart)
    hi = lim["qd"][1]
    pris = np.asarray(stewart.s) == 1
    np.testing.assert_allclose(hi[~pris], np.pi / 2)  # 90 deg/s of the passive angles
    np.testing.assert_allclose(hi[pris], 90.0)


def test_wrong_count_names_both_forms(stewart):
    msg = limit_count_message(stewart, 5)
    assert f"expected {stewart.n} values" in msg and "or 6 (one per independent joint: leg1" in msg
    assert msg.endswith("got 5")
    lim = mechanism_limits_si(LimitsSpec(torque=[1.0] * 5), Units(), stewart)
    assert lim["torque"][0].shape == (5,)  # left for the caller to refuse with that message

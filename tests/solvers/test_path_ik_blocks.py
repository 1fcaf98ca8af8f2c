"""Continuation in blocks (issue 29) against the point-by-point continuation it replaces: the
same table to the IK tolerance, the same q(r), f', f'' and the same located failures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.track.path_ik import COMPONENTS, HandLineIK, PathIKError

ROOT = Path(__file__).resolve().parents[2]
DEG = np.pi / 180.0
R = np.linspace(0.0, 1.0, 101)


class SerialLineIK(HandLineIK):
    """The point-by-point continuation (one table point per Newton solve)."""

    BLOCK = 1


def _pair(mech, p0, p1, q0, **kw):
    return (HandLineIK(mech, mech.end_effector, p0, p1, q0, 1e-12, **kw),
            SerialLineIK(mech, mech.end_effector, p0, p1, q0, 1e-12, **kw))


def test_park_2r_blocks_equal_the_serial_table() -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "park_scara2.yaml")
    blk, ser = _pair(mech, np.array([-0.8, 1.732, 0.0]), np.array([-0.3, 1.732, 0.0]),
                     mech.home, branch={1: 1})
    assert blk.BLOCK > 1 and ser.BLOCK == 1
    assert_allclose(blk.tab, ser.tab, rtol=0, atol=1e-10)  # tolerance 1e-12 m
    assert_allclose(blk.q(R), ser.q(R), rtol=0, atol=1e-10)
    assert_allclose(blk.dq(R), ser.dq(R), rtol=0, atol=1e-10)
    assert_allclose(blk.ddq(R), ser.ddq(R), rtol=0, atol=1e-7)


def test_puma_6d_line_blocks_equal_the_serial_table() -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q0 = np.array([0, 30, -120, 0, -40, 0]) * DEG
    p0 = forward_kinematics(mech, q0[None]).frames(mech, [mech.end_effector])[0, 0, :3, 3]
    blk, ser = _pair(mech, p0, p0 + [0.0, 0.4, 0.0], q0, mask=COMPONENTS)
    assert_allclose(blk.tab, ser.tab, rtol=0, atol=1e-10)
    assert_allclose(blk.q(R), ser.q(R), rtol=0, atol=1e-10)
    assert_allclose(blk.dq(R), ser.dq(R), rtol=0, atol=1e-9)


@pytest.mark.parametrize("end", [[1.2, 1.732, 0.0], [0.8, -1.732, 0.0]])
def test_a_failing_path_fails_where_the_serial_one_does(end) -> None:
    """Out of reach, or through the elbow's singularity: the block continuation falls back to
    one point at a time and raises the same located error."""
    mech = load_mechanism(ROOT / "mechanisms" / "park_scara2.yaml")
    errs = []
    for cls in (HandLineIK, SerialLineIK):
        with pytest.raises(PathIKError) as ei:
            cls(mech, mech.end_effector, np.array([-0.8, 1.732, 0.0]), np.array(end),
                mech.home, 1e-12)
        errs.append(ei.value)
    assert errs[0].key == errs[1].key == "path"
    assert errs[0].r == errs[1].r
    # the same message up to the error left by the failed Newton solve (not converged: its
    # last iterate depends on the start at round-off)
    assert str(errs[0]).split("IK error")[0] == str(errs[1]).split("IK error")[0]

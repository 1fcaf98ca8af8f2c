"""Closed forms chosen by structure (mechkin.solvers.closed_form.recognise), not by name.

A 6-6 Stewart platform that is not bundled (tests/data/stewart_66.yaml) is recognised from its
geometry and its closed-form leg lengths equal the numerical lm to 1e-9; the kim1995 Stewart
file under another name is still recognised; declared forms that do not fit raise a ModelError
naming the joint or frame; every direct-drive branch is enumerated.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.config.mechanism_file import read_mechanism_spec
from mechkin.errors import ConfigError, ModelError
from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.direct_drive import (
    A3,
    A4,
    D1,
    DE,
    direct_drive_fk,
    direct_drive_solutions,
)
from mechkin.solvers.closed_form.recognise import (
    ClosedFormMismatch,
    check_closed_form,
    closed_form_ik,
    closed_form_solutions,
    declared_closed_form,
    recognise_closed_form,
)
from mechkin.solvers.ik import IkOptions, IkStatus, pose_errors, solve_ik

ROOT = Path(__file__).resolve().parents[2]
STEWART_66 = ROOT / "tests" / "data" / "stewart_66.yaml"


def _rot(rx: float, ry: float, rz: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _copy(tmp_path: Path, src: Path, edits: list[tuple[str, str]]) -> Path:
    s = src.read_text()
    for old, new in edits:
        assert old in s, old
        s = s.replace(old, new, 1)
    p = tmp_path / src.name
    p.write_text(s)
    return p


def _pose(mech, q_v):
    res = solve_closure(mech, q_v, np.broadcast_to(mech.home[mech.dependent],
                                                   (len(q_v), len(mech.dependent))))
    assert res.ok.all()
    return forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]


# ---- Stewart 6-6 -----------------------------------------------------------------------------
def test_66_geometry_read_from_the_file():
    """a_i, b_i typed from the file's comment: radius 1.0 at (-15, 15, 105, 135, 225, 255) deg;
    radius 0.5 at (-45, 45, 75, 165, 195, 285) deg, z = -0.05 in {E}; leg zero 0.3 m."""
    mech = load_mechanism(STEWART_66)
    assert declared_closed_form(mech) is None
    assert recognise_closed_form(mech) == "stewart"
    g = check_closed_form(mech, "stewart")
    ta = np.deg2rad([-15, 15, 105, 135, 225, 255])
    tb = np.deg2rad([-45, 45, 75, 165, 195, 285])
    a = np.column_stack([np.cos(ta), np.sin(ta), np.zeros(6)])
    b = np.column_stack([0.5 * np.cos(tb), 0.5 * np.sin(tb), np.full(6, -0.05)])
    np.testing.assert_allclose(g.a, a, atol=1e-9)
    np.testing.assert_allclose(g.b, b, atol=1e-9)
    np.testing.assert_allclose(g.sigma, 1.0)
    np.testing.assert_allclose(g.c, 0.3, atol=1e-9)


def test_66_closed_form_equals_lm():
    mech = load_mechanism(STEWART_66)
    rng = np.random.default_rng(5)
    T = np.tile(np.eye(4), (4, 1, 1))
    for k in range(4):
        T[k, :3, :3] = _rot(*np.deg2rad(rng.uniform(-8, 8, 3)))
        T[k, :3, 3] = [0, 0, 0.8] + rng.uniform(-0.08, 0.08, 3)
    q_cf, ok = closed_form_ik(mech, T)
    assert ok.all()
    # the closed form's legs, assembled by loop closure, put {E} on the pose
    pe, oe = pose_errors(_pose(mech, q_cf), T)
    assert pe.max() < 1e-12 and oe.max() < 1e-12
    opts = IkOptions(grad_tol=1e-15, tol_pos=1e-12, tol_ori=1e-12, max_iter=200)
    for k in range(4):
        r = solve_ik(mech, T[k], options=opts)
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, q_cf[k], atol=1e-9)


def test_renamed_kim1995_stewart_still_recognised(tmp_path):
    """kim1995 Table 6 (legs at the poses of Table 5) from the file renamed, with and without
    the declaration."""
    from tests.papers.test_kim1995_ik_tables import TABLE5, TABLE6

    src = ROOT / "mechanisms" / "kim1995_stewart.yaml"
    plain = _copy(tmp_path, src, [("name: kim1995_stewart", "name: my_hexapod"),
                                  ("closed_form: stewart\n", "")])
    mech = load_mechanism(plain)
    assert mech.name == "my_hexapod" and declared_closed_form(mech) is None
    assert recognise_closed_form(mech) == "stewart"
    q, ok = closed_form_ik(mech, np.array(TABLE5))
    assert ok.all()
    np.testing.assert_allclose(q, TABLE6, atol=5e-6)
    bundled = load_mechanism(src)
    assert declared_closed_form(bundled) == "stewart" == recognise_closed_form(bundled)


# ---- mismatches ------------------------------------------------------------------------------
def test_declared_stewart_on_lee_names_the_mismatch(tmp_path):
    p = _copy(tmp_path, ROOT / "mechanisms" / "lee_spherical_rrps.yaml",
              [("closed_form: lee_spherical", "closed_form: stewart")])
    with pytest.raises(ModelError, match=r"closed_form stewart: .*3 independent joints, "
                                         r"expected 6 prismatic legs"):
        recognise_closed_form(load_mechanism(p))


def test_leg_axis_off_its_base_joint_names_the_leg(tmp_path):
    p = _copy(tmp_path, STEWART_66, [
        ("child: upper3, axis: [0, 0, 1]", "child: upper3, origin: {xyz: [0.01, 0, 0]}, "
                                           "axis: [0, 0, 1]"),
        ("name: hexapod_66_test", "name: hexapod_66_test\nclosed_form: stewart")])
    mech = load_mechanism(p)
    with pytest.raises(ModelError, match=r"leg leg3: the prismatic axis misses the base joint "
                                         r"centre by 0.01 m"):
        recognise_closed_form(mech)


def test_direct_drive_tool_frame_turned_names_the_frame(tmp_path):
    p = _copy(tmp_path, ROOT / "mechanisms" / "kim1995_direct_drive.yaml",
              [("rpy: [0, 90, 0]", "rpy: [0, 90, 10]")])
    with pytest.raises(ClosedFormMismatch,
                       match=r"frame tool: its y axis \(sliding s = shoulder axis\) differs"):
        check_closed_form(load_mechanism(p), "direct_drive")


def test_direct_drive_shoulder_off_the_base_axis_names_the_motor(tmp_path):
    p = _copy(tmp_path, ROOT / "mechanisms" / "kim1995_direct_drive.yaml",
              [("origin: {xyz: [0, -0.20, 0.40]}", "origin: {xyz: [0.05, -0.20, 0.40]}")])
    with pytest.raises(ClosedFormMismatch, match=r"motors q2 and q3 are not coaxial"):
        check_closed_form(load_mechanism(p), "direct_drive")


def test_serial_arm_has_no_closed_form():
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    assert recognise_closed_form(mech) is None
    with pytest.raises(ClosedFormMismatch, match="no closed form fits"):
        closed_form_ik(mech, np.eye(4)[None])


def test_unknown_closed_form_is_a_config_error(tmp_path):
    p = _copy(tmp_path, STEWART_66, [("name: hexapod_66_test",
                                      "name: hexapod_66_test\nclosed_form: hexapod")])
    with pytest.raises(ConfigError, match=r"stewart_66.yaml:\d+: closed_form: "):
        read_mechanism_spec(p)


# ---- direct drive ----------------------------------------------------------------------------
def test_direct_drive_lengths_read_from_the_model():
    """kim1995 Table 1: l0 = 0.40, l1 = 0.25, l2 = 0.40, l4 = 0.65 (dE = -l4)."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    assert recognise_closed_form(mech) == "direct_drive"
    g = check_closed_form(mech, "direct_drive")
    np.testing.assert_allclose([g.d1, g.a3, g.a4, g.dE], [0.40, 0.25, 0.40, -0.65], atol=1e-12)
    np.testing.assert_allclose([g.d1, g.a3, g.a4, g.dE], [D1, A3, A4, DE], atol=1e-12)


def test_direct_drive_all_solutions():
    """All four branches are tried; each returned solution reproduces the pose; the motors that
    made the pose are among them. With the approach a = -u(q2) fixing q2 and s fixing q1, the
    elbow is fixed too: one solution per reachable pose, none for an unreachable one."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    rng = np.random.default_rng(7)
    qv = rng.uniform(-0.6, 0.6, (10, 3))
    T = _pose(mech, qv)
    sols = closed_form_solutions(mech, T)
    assert len(sols) == 10
    for q, S in zip(qv, sols, strict=True):
        assert S.shape[1] == 3 and len(S) >= 1
        np.testing.assert_allclose(direct_drive_fk(S), np.broadcast_to(
            direct_drive_fk(q[None]), (len(S), 4, 4)), atol=1e-9)
        assert min(np.abs(s - q).max() for s in S) < 1e-10
    far = T[:1].copy()
    far[0, :3, 3] += [5.0, 0, 0]
    assert direct_drive_solutions(far)[0].shape == (0, 3)
    q_cf, ok = closed_form_ik(mech, far)
    assert not ok[0] and np.all(np.isfinite(q_cf))


# ---- lee -------------------------------------------------------------------------------------
def test_lee_geometry_and_leg_lengths():
    """lee §3.2: R = 1, r = 0.5 (this file), P = (0, 0, 1), stroke 0.5 .. 2."""
    mech = load_mechanism(ROOT / "mechanisms" / "lee_spherical_rrps.yaml")
    assert recognise_closed_form(mech) == "lee_spherical"
    g = check_closed_form(mech, "lee_spherical").geometry
    np.testing.assert_allclose([g.R, g.r, g.l_min, g.l_max], [1.0, 0.5, 0.5, 2.0], atol=1e-9)
    np.testing.assert_allclose(g.center, [0, 0, 1], atol=1e-9)
    rng = np.random.default_rng(3)
    qv = mech.home[mech.independent] + rng.uniform(-0.05, 0.05, (5, 3))
    T = _pose(mech, qv)
    q, ok = closed_form_ik(mech, T)
    assert ok.all()
    np.testing.assert_allclose(q, qv, atol=1e-10)
    off = T[:1].copy()
    off[0, 2, 3] += 0.1  # the plate centre cannot leave P
    assert closed_form_solutions(mech, off)[0].shape == (0, 3)

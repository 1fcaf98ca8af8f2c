"""Real robot files as they are shipped (issue 25): example-robot-data's UR5, Panda (mimic
finger), Talos (12 mimic joints) and Solo12, imported without a sidecar; FK against Pinocchio
(an independent implementation) <= 1e-12 and IK with the defaults verified by Pinocchio's FK
(25 random reachable targets per robot, every one verified)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mechkin.api import fk, ik
from mechkin.model import load_mechanism
from tests.config.robot_files import pin_frames, pin_model, pin_q, random_q_v, robots_dir

ROBOTS = {
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "talos": "talos_data/robots/talos_full_v2.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
}
#: random reachable targets per robot for IK with the defaults (every one must be verified)
N_IK = 25
#: a frame per robot for IK (the default end effector where the file has one)
IK_FRAME = {"ur5": None, "panda": None, "talos": "gripper_left_fingertip_1_link",
            "solo12": "FL_FOOT"}


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request):
    path = robots_dir() / ROBOTS[request.param]
    return request.param, path, load_mechanism(path)


def test_fk_matches_pinocchio_at_100_configurations(robot):
    name, path, mech = robot
    pin, model, data = pin_model(path)
    rng = np.random.default_rng(25)
    qv = random_q_v(mech, rng, 100)
    res = fk(mech, qv, frames=[])
    assert all(s == "converged" for s in res.status)
    for c in mech.couplings:  # the coupled joints follow their masters exactly
        assert np.allclose(res.q[:, c.joint], c.multiplier * res.q[:, c.master] + c.offset,
                           atol=1e-14, rtol=0)
    names = [n for n in mech.frame_names if model.existFrame(n)]
    assert len(names) >= mech.n_links - len(mech.virtual_links) - 1
    from mechkin.model.kinematics import frame_poses

    idx = [mech.frame_index(n) for n in names]
    T = frame_poses(mech, res.q, idx)
    err = 0.0
    for k in range(100):
        Tp = pin_frames(pin, model, data, pin_q(model, mech, res.q[k]), names)
        err = max(err, float(np.abs(T[k] - Tp).max()))
    assert err <= 1e-12, f"{name}: max |T_mechkin - T_pinocchio| = {err:.3g}"


def test_ik_with_defaults_verified_by_pinocchio(robot):
    name, path, mech = robot
    if IK_FRAME[name] is not None:
        mech = replace(mech, end_effector=mech.frame_index(IK_FRAME[name]))
    assert mech.end_effector is not None, f"{name}: no default end effector"
    pin, model, data = pin_model(path)
    rng = np.random.default_rng(7)
    qv = random_q_v(mech, rng, N_IK)
    ee = mech.frame_names[mech.end_effector]
    q_true = fk(mech, qv, frames=[]).q
    targets = np.stack([pin_frames(pin, model, data, pin_q(model, mech, q), [ee])[0]
                        for q in q_true])
    results = ik(mech, targets)
    for T, r in zip(targets, results, strict=True):
        assert r.status.value == "ok", f"{name}: {r.status}"
        Tp = pin_frames(pin, model, data, pin_q(model, mech, r.q), [ee])[0]
        assert np.abs(Tp[:3, 3] - T[:3, 3]).max() < 1e-6
        assert np.abs(Tp[:3, :3] - T[:3, :3]).max() < 1e-6
        for c in mech.couplings:
            assert abs(r.q[c.joint] - c.multiplier * r.q[c.master] - c.offset) < 1e-10


@pytest.mark.parametrize("rel", ["romeo_description/urdf/romeo_laas_small.urdf",
                                 "iris_description/robots/iris.urdf"])
def test_vendor_names_with_slashes_and_huge_limits_import(rel, capfd):
    """Romeo's sensor frames are named ``LFoot/FSR/...`` and Iris' rotors have limits +-1e16:
    the names are renamed (``/`` -> ``_``, one note) and the limits read as none; FK of every
    frame equals Pinocchio's, frames matched through the renaming."""
    path = robots_dir() / rel
    mech = load_mechanism(path)
    note = capfd.readouterr().err
    assert f"{path.name}: note: renamed " in note and "/" in note
    pin, model, data = pin_model(path)
    rng = np.random.default_rng(11)
    res = fk(mech, random_q_v(mech, rng, 20), frames=[])
    bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY]  # links
    pairs = [(n.replace("/", "_"), n) for n in bodies if "/" in n]
    assert pairs and all(a in mech.frame_names for a, _ in pairs), pairs
    from mechkin.model.kinematics import frame_poses

    T = frame_poses(mech, res.q, [mech.frame_index(a) for a, _ in pairs])
    for k in range(20):
        Tp = pin_frames(pin, model, data, pin_q(model, mech, res.q[k]), [b for _, b in pairs])
        assert np.abs(T[k] - Tp).max() <= 1e-12
    if rel.startswith("iris"):
        assert np.all(np.isinf(mech.lower)) and np.all(np.isinf(mech.upper))

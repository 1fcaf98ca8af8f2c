"""Several end effectors solved together (issue 25, mechkin.solvers.ik.multi_frame), with the
defaults, every answer verified per frame by forward kinematics.

* A floating-base biped (tests/config/test_mjcf_shipped.py's MJCF: free joint, ball hips,
  knee, ankle pitch and roll): both soles flat on the ground plane z = 0 and the pelvis height
  given (weights [0, 0, 1, 0, 0, 0]). The 50 target sets are made feasible independently of
  mechkin: a random left-leg configuration and pelvis pose put the left sole flat on the plane,
  then scipy's least_squares with MuJoCo's own kinematics finds right-leg joints that put the
  right sole on the plane at a random place beside it (kept when MuJoCo reaches it to 1e-10).
* A humanoid (example-robot-data's Talos with its 12 mimic joints, a floating base from the
  sidecar): both soles and both grippers, 6-D each, at the poses of random configurations.
"""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
scipy_opt = pytest.importorskip("scipy.optimize")

from mechkin.api import fk  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402
from mechkin.solvers.ik.multi_frame import FrameTarget, solve_multi_frame, verify  # noqa: E402
from tests.config.robot_files import robots_dir  # noqa: E402
from tests.config.test_mjcf_shipped import SPHERE_GEOM, _biped, _mujoco_qpos  # noqa: E402

TOL_POS, TOL_ORI = 1e-6, 1e-6  # the IK defaults (mechkin.solvers.ik.results)
SETS = 50


def _site(m, d, name):
    s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = d.site_xmat[s].reshape(3, 3), d.site_xpos[s]
    return T


def _flat(yaw: float, x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:3, 3] = [x, y, 0.0]
    return T


def _feasible_stances(m, mech, rng, k):
    """k (q, T_left_sole, T_right_sole, pelvis height) with both soles flat on z = 0, by
    MuJoCo's kinematics and scipy (see the module docstring)."""
    d = mujoco.MjData(m)
    leg = {s: [mech.joint_index(f"{s}_hip_{i}") for i in (1, 2, 3)]
           + [mech.joint_index(f"{s}_{j}") for j in ("knee", "ankle", "ankle_roll")]
           for s in ("left", "right")}
    base = [mech.joint_index(f"base_{a}") for a in ("x", "y", "z", "yaw", "pitch", "roll")]
    out = []
    while len(out) < k:
        q = mech.home.copy()
        q[leg["left"]] = [*rng.uniform(-0.3, 0.3, 3), rng.uniform(0.3, 1.2),
                          *rng.uniform(-0.4, 0.4, 2)]
        q[base] = [0, 0, 1.0, rng.uniform(-0.5, 0.5), *rng.uniform(-0.15, 0.15, 2)]
        d.qpos[:] = _mujoco_qpos(m, mech, q)
        mujoco.mj_kinematics(m, d)
        TL = _site(m, d, "left_sole")
        # move the whole robot (its base pose) so that the left sole lies flat at the origin
        yaw = np.arctan2(TL[1, 0], TL[0, 0])
        G = _flat(yaw, 0.0, 0.0) @ np.linalg.inv(TL)
        T_base = np.eye(4)
        T_base[:3, 3] = q[base[:3]]
        cy, sy = np.cos(q[base[3]]), np.sin(q[base[3]])
        cp, sp = np.cos(q[base[4]]), np.sin(q[base[4]])
        cr, sr = np.cos(q[base[5]]), np.sin(q[base[5]])
        T_base[:3, :3] = (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
                          @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
                          @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))
        Tb = G @ T_base
        q[base[:3]] = Tb[:3, 3]
        q[base[3]] = np.arctan2(Tb[1, 0], Tb[0, 0])
        q[base[4]] = np.arctan2(-Tb[2, 0], np.hypot(Tb[2, 1], Tb[2, 2]))
        q[base[5]] = np.arctan2(Tb[2, 1], Tb[2, 2])
        fwd, side, turn = rng.uniform(-0.15, 0.15), rng.uniform(-0.28, -0.16), rng.uniform(
            -0.3, 0.3)
        TR_goal = _flat(yaw + turn, 0.0, 0.0)
        TR_goal[:3, 3] = _flat(yaw, 0, 0)[:3, :3] @ [fwd, side, 0.0]

        def resid(x, q=q, TR_goal=TR_goal):
            qq = q.copy()
            qq[leg["right"]] = x
            d.qpos[:] = _mujoco_qpos(m, mech, qq)
            mujoco.mj_kinematics(m, d)
            T = _site(m, d, "right_sole")
            dR = TR_goal[:3, :3].T @ T[:3, :3]
            return np.concatenate([T[:3, 3] - TR_goal[:3, 3], (dR - np.eye(3)).ravel()])

        sol = scipy_opt.least_squares(resid, q[leg["right"]], xtol=1e-15, ftol=1e-15,
                                      gtol=1e-15)
        x = sol.x
        if np.abs(resid(x)).max() > 1e-10 or not (0.0 <= x[3] <= 2.5 and
                                                  np.all(np.abs(x[4:]) <= 1.0)):
            continue
        q[leg["right"]] = x
        d.qpos[:] = _mujoco_qpos(m, mech, q)
        mujoco.mj_kinematics(m, d)
        pel = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pelvis")
        out.append((q, _site(m, d, "left_sole"), _site(m, d, "right_sole"),
                    float(d.xpos[pel][2])))
    return out


def test_biped_both_soles_on_the_plane_pelvis_height_given(tmp_path):
    path = tmp_path / "biped.xml"
    path.write_text(_biped(SPHERE_GEOM).replace('<asset><mesh name="part" file="part.stl"/>'
                                                '</asset>', ""))
    mech = load_mechanism(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    stances = _feasible_stances(m, mech, np.random.default_rng(2025), SETS)
    ok = 0
    for _q_true, TL, TR, h in stances:
        assert abs(TL[2, 3]) < 1e-10 and abs(TR[2, 3]) < 1e-10  # on the plane, flat
        assert abs(TL[2, 2] - 1) < 1e-10 and abs(TR[2, 2] - 1) < 1e-10
        T_h = np.eye(4)
        T_h[2, 3] = h
        targets = [FrameTarget("left_sole", TL, np.ones(6)),
                   FrameTarget("right_sole", TR, np.ones(6)),
                   FrameTarget("pelvis", T_h, np.array([0, 0, 1.0, 0, 0, 0]))]
        r = solve_multi_frame(mech, targets)  # defaults: from home
        pe, oe = verify(mech, r.q, targets)  # FK at the answer, per frame
        good = r.ok and np.all(pe <= TOL_POS) and np.all(oe <= TOL_ORI)
        # and MuJoCo agrees: the soles are on the plane, the pelvis at its height
        d = mujoco.MjData(m)
        d.qpos[:] = _mujoco_qpos(m, mech, r.q)
        mujoco.mj_kinematics(m, d)
        for name, T in (("left_sole", TL), ("right_sole", TR)):
            good &= bool(np.abs(_site(m, d, name) - T).max() < 1e-5)
        ok += bool(good)
    assert ok == len(stances), f"{ok} of {len(stances)} target sets verified"


def test_humanoid_feet_and_hands(tmp_path):
    src = robots_dir() / "talos_data/robots/talos_full_v2.urdf"
    path = tmp_path / "talos.urdf"
    path.write_text(src.read_text())
    (tmp_path / "talos.mechkin.yaml").write_text("base: floating\n")
    mech = load_mechanism(path)
    assert mech.floating and len(mech.couplings) == 12
    frames = ["left_sole_link", "right_sole_link", "gripper_left_base_link",
              "gripper_right_base_link"]
    rng = np.random.default_rng(4)
    iv = mech.independent
    lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -0.3)
    hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], 0.3)
    n_sets = 50
    ok = 0
    for _ in range(n_sets):
        qv = rng.uniform(lo, hi)
        T = fk(mech, qv[None], frames=frames).poses
        targets = [FrameTarget(f, T[f][0], np.ones(6)) for f in frames]
        r = solve_multi_frame(mech, targets)
        pe, oe = verify(mech, r.q, targets)
        for c in mech.couplings:
            assert abs(r.q[c.joint] - c.multiplier * r.q[c.master] - c.offset) < 1e-12
        ok += bool(r.ok and np.all(pe <= TOL_POS) and np.all(oe <= TOL_ORI))
    assert ok == n_sets, f"{ok} of {n_sets} target sets verified"


def test_python_api_ik_frames(tmp_path):
    import mechkin

    path = tmp_path / "biped.xml"
    path.write_text(_biped(SPHERE_GEOM).replace('<asset><mesh name="part" file="part.stl"/>'
                                                '</asset>', ""))
    mech = mechkin.load_mechanism(path)
    q = mech.home.copy()
    q[mech.joint_index("left_knee")] = 0.7
    T = fk(mech, q[mech.independent][None], frames=["left_sole", "right_sole"]).poses
    r = mechkin.ik_frames(mech, [{"frame": "left_sole", "T": T["left_sole"][0]},
                                 {"frame": "right_sole", "T": T["right_sole"][0]}])
    assert r.ok and r.position_error.max() < TOL_POS and r.orientation_error.max() < TOL_ORI
    with pytest.raises(mechkin.ConfigError, match=r"targets\[0\]\.frame: unknown frame 'nope'"):
        mechkin.ik_frames(mech, [{"frame": "nope", "T": np.eye(4)}])

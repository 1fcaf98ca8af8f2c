"""Issue 12: hwang2023's closed forms for any biped written in YAML.

A second biped (other link lengths, hip offsets with y and z, foot extension, blade radius and
joint limits; its mechanism file is written here) is read by
:func:`mechkin.solvers.biped.sequence.geometry_from_mechanism`; every class (walk §2.2, skate
§2.2/§2.3,
roll §2.4) is solved on random planes and random full body poses for both legs and checked
against the *general model's* forward kinematics (mechkin.model), not the closed form's own.
End to end (mechkin.tasks.biped.run): a tilted body with a different plane under each leg, a pose
outside the file's joint limits, topology errors naming the joint, and the /mechkin/state schema.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from mechkin.config.scenario import load_scenario
from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.biped.leg import (
    HWANG2023_ESTIMATED,
    STATUS_AT_LIMIT,
    InclinedPlane,
    LegTask,
    ee_rotation_from_psi,
    rolled_position,
    solve_leg_case,
)
from mechkin.solvers.biped.sequence import geometry_from_mechanism
from mechkin.spatial.euler_conventions import (
    contact_angles_from_matrix,
    plane_angles_from_matrix,
    plane_matrix,
)
from mechkin.spatial.rotations import matrix_from_rpy, rot_x, rot_y, rot_z
from mechkin.spatial.transforms import T_from
from mechkin.tasks.biped import run

ROOT = Path(__file__).resolve().parents[2]
SIDES = ("right", "left")

# the second biped [mm, deg]: not the hwang2023 numbers
L = (40.0, 90.0, 200.0, 190.0, 45.0, 120.0)
FOOT = 3.0
WHEEL = 20.0
HIP = (95.0, 15.0, -30.0)
LIMITS = ((-80, 70), (-60, 85), (-90, 90), (-150, 10), (-85, 80), (-75, 75))


def mechanism_yaml(lengths=L, foot=FOOT, wheel=WHEEL, hip=HIP, limits=LIMITS,
                   left_limits=None, name="other_biped") -> str:
    """A hwang2023-topology biped (Rz-Ry-Rx-Rx-Rx-Ry legs, left = mirror image) in YAML."""
    l1, l2, l3, l4, l5, l6 = lengths
    left_limits = left_limits or limits
    axes_r = ([0, 0, 1], [0, 1, 0], [1, 0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 0])
    axes_l = ([0, 0, -1], [0, -1, 0], [1, 0, 0], [1, 0, 0], [1, 0, 0], [0, -1, 0])
    origins = (0.0, l1, l2, l3, l4, l5)
    lines = [f"name: {name}", "units: {length: mm, angle: deg}", "links:", "  - name: body",
             "    frames:",
             f"      - {{name: hip_r, xyz: [{hip[0]}, {hip[1]}, {hip[2]}], rpy: [180, 0, 0]}}",
             f"      - {{name: hip_l, xyz: [{-hip[0]}, {hip[1]}, {hip[2]}], rpy: [180, 0, 0]}}"]
    for s, rot in (("r", "[180, 0, 0]"), ("l", "[0, 0, 180]")):
        lines += [f"  - {{name: {s}_link{k}}}" for k in range(1, 6)]
        lines += [f"  - name: {s}_link6", "    frames:",
                  f"      - {{name: e6_{s}, xyz: [0, 0, {l6}]}}",
                  f"      - {{name: foot_{s}, xyz: [0, 0, {l6 + foot}], rpy: {rot}}}",
                  f"      - {{name: blade_{s}, xyz: [0, 0, {l6}], rpy: {rot}}}",
                  f"      - {{name: wheel_{s}, xyz: [0, 0, {l6 - wheel}], rpy: {rot}}}"]
    lines.append("joints:")
    for s, axes, lims in (("r", axes_r, limits), ("l", axes_l, left_limits)):
        for k in range(6):
            parent = f"hip_{s}" if k == 0 else f"{s}_link{k}"
            lines.append(f"  - {{name: {s}_theta{k + 1}, type: revolute, parent: {parent}, "
                         f"child: {s}_link{k + 1}, axis: {axes[k]}, origin: {{xyz: [0, 0, "
                         f"{origins[k]}]}}, limits: [{lims[k][0]}, {lims[k][1]}]}}")
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def other(tmp_path_factory):
    p = tmp_path_factory.mktemp("mech") / "other_biped.yaml"
    p.write_text(mechanism_yaml())
    mech = load_mechanism(p)
    return p, mech, geometry_from_mechanism(mech)


def test_geometry_is_read_from_the_file(other):
    _, _, model = other
    g = model.geometry
    np.testing.assert_allclose(g.lengths, np.array(L) * 1e-3, atol=1e-12)
    np.testing.assert_allclose(g.hip_offset, np.array(HIP) * 1e-3, atol=1e-12)
    assert g.foot_extension == pytest.approx(FOOT * 1e-3, abs=1e-12)
    assert g.wheel_radius == pytest.approx(WHEEL * 1e-3, abs=1e-12)
    np.testing.assert_allclose(g.q_min, np.deg2rad([lo for lo, _ in LIMITS]), atol=1e-12)
    np.testing.assert_allclose(g.q_max, np.deg2rad([hi for _, hi in LIMITS]), atol=1e-12)
    assert g.estimated == () and not model.estimated


def test_bundled_biped_keeps_its_estimated_geometry():
    model = geometry_from_mechanism(load_mechanism(ROOT / "mechanisms" / "hwang2023_biped.yaml"))
    assert model.geometry is HWANG2023_ESTIMATED and model.estimated
    assert "lengths" in model.geometry.estimated


# ---------------------------------------------------------------- round trips on random poses


def _leg_idx(mech, side):
    return [mech.joint_index(f"{side[0]}_theta{k}") for k in range(1, 7)]


def _random_q(rng, g):
    lo = np.maximum(np.array(g.q_min), -1.2) * 0.8
    hi = np.minimum(np.array(g.q_max), 1.2) * 0.8
    return rng.uniform(lo, hi)


def _random_body(rng):
    return T_from(matrix_from_rpy(rng.uniform(-0.4, 0.4, 3)), rng.uniform(-0.2, 0.2, 3)
                  + np.array([0.0, 0.0, 0.6]))


def _model_contact(mech, side, q6, TG, kind):
    """World pose of the foot or blade frame (Table 1's Psi) by the general model's FK."""
    q = mech.home.copy()
    q[_leg_idx(mech, side)] = q6
    f = mech.frame_index(f"{kind}_{side[0]}")
    return TG @ frame_poses(mech, q[None], [f])[0, 0]


def _plane_through(rng, Psi, side, kind, point, beta_z, beta):
    """A plane (random in-plane origin) such that Psi = Lam Rot(-Z, beta_z) Rot(+-X/Y, beta)."""
    s = (1.0 if side == "right" else -1.0)
    last = rot_x(s * beta) if kind == "foot" else rot_y(-s * beta)
    Lam = Psi @ last.T @ rot_z(-beta_z).T
    lx, ly, gx = plane_angles_from_matrix(Lam, side)
    np.testing.assert_allclose(plane_matrix(lx, ly, gx, side), Lam, atol=1e-12)
    Lr = plane_matrix(lx, ly, gx, "right")
    origin = point + rng.uniform(-0.1, 0.1) * Lr[:, 0] + rng.uniform(-0.1, 0.1) * Lr[:, 1]
    return InclinedPlane(tuple(origin), float(lx), float(ly), float(gx))


def _rim(g, T_ee, n):
    return T_ee[:3, 3] + g.wheel_radius * (-T_ee[:3, 2] - n)


def _check_roundtrip(mech, g, side, sol, TG, kind, plane, beta_z):
    """The solution through the general model: the frame lies on the plane in the family."""
    T = _model_contact(mech, side, sol.q, TG, kind)
    Psi = T[:3, :3]
    _, _, off = contact_angles_from_matrix(Psi, plane.rotation(side), side, kind)
    assert abs(off) < 1e-9
    bz, _, _ = contact_angles_from_matrix(Psi, plane.rotation(side), side, kind)
    assert abs(np.angle(np.exp(1j * (bz - beta_z)))) < 1e-9
    np.testing.assert_allclose(T[:3, 3], sol.T_0_E[:3, 3], atol=1e-9)
    return T


@pytest.mark.parametrize("side", SIDES)
def test_walk_and_skate_round_trip_through_the_general_model(other, side):
    _, mech, model = other
    g = model.legs[side]
    rng = np.random.default_rng(12 if side == "right" else 21)
    n_checked = {"walk": 0, "skate": 0, "skate theta6": 0}
    for _ in range(12):
        q0, TG = _random_q(rng, g), _random_body(rng)
        bz, beta = rng.uniform(-0.5, 0.5, 2)
        for kind, mode in (("foot", "walk"), ("blade", "skate")):
            T0 = _model_contact(mech, side, q0, TG, kind)
            plane = _plane_through(rng, T0[:3, :3], side, kind, T0[:3, 3], bz, beta)
            R_ee = ee_rotation_from_psi(T0[:3, :3], side)
            if kind == "blade":  # the plane through the rim point, not through E
                n = plane.normal
                c = _rim(g, T_from(R_ee, T0[:3, 3]), n)
                plane = InclinedPlane(tuple(np.asarray(plane.origin) + n * (n @ (c - np.asarray(
                    plane.origin)))), plane.lam_x, plane.lam_y, plane.gam_x)
            tasks = {"walk": [("walk", LegTask(tuple(T0[:3, 3]), bz, beta))],
                     "skate": [("skate", LegTask(tuple(T0[:3, 3]), bz, beta)),
                               ("skate theta6", LegTask(tuple(T0[:3, 3]), bz, None, q0[5]))]}
            for label, task in tasks[mode]:
                best, alts = solve_leg_case(plane, mode, side, task, T_0_G=TG, geometry=g)
                assert best.ok, (label, best.status)
                # the generating q is among the closed-form solutions
                assert any(np.allclose(a.q, q0, atol=1e-7) for a in alts if a.ok), label
                for a in alts:
                    T = _check_roundtrip(mech, g, side, a, TG, kind, plane, bz)
                    _, b, _ = contact_angles_from_matrix(T[:3, :3], plane.rotation(side),
                                                         side, kind)
                    if label != "skate theta6":
                        assert abs(b - beta) < 1e-9
                    else:
                        assert abs(a.q[5] - q0[5]) < 1e-12
                    if kind == "blade":  # the rim point on the plane
                        d = plane.normal @ (a.p_contact - np.asarray(plane.origin))
                        assert abs(d) < 1e-12
                    else:
                        d = plane.normal @ (T[:3, 3] - np.asarray(plane.origin))
                        assert abs(d) < 1e-12
                n_checked[label] += 1
    assert min(n_checked.values()) == 12, n_checked


@pytest.mark.parametrize("side", SIDES)
def test_roll_round_trip_through_the_general_model(other, side):
    _, mech, model = other
    g = model.legs[side]
    rng = np.random.default_rng(5 if side == "right" else 50)
    done = 0
    for _ in range(40):
        q0, TG = _random_q(rng, g), _random_body(rng)
        bz, beta_a = rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4)
        T0 = _model_contact(mech, side, q0, TG, "blade")
        plane = _plane_through(rng, T0[:3, :3], side, "blade", T0[:3, 3], bz, beta_a)
        t6 = float(np.clip(q0[5] + rng.uniform(-0.3, 0.3), g.q_min[5] + 0.05,
                           g.q_max[5] - 0.05))
        task = LegTask(tuple(T0[:3, 3]), bz, beta_a, t6)
        best, alts = solve_leg_case(plane, "roll", side, task, T_0_G=TG, geometry=g)
        if not best.ok:
            continue
        T = _check_roundtrip(mech, g, side, best, TG, "blade", plane, bz)
        assert abs(best.q[5] - t6) < 1e-12
        _, beta_b, _ = contact_angles_from_matrix(T[:3, :3], plane.rotation(side), side,
                                                  "blade")
        # rolling without slipping (Eq. 37) from E_a, beta_a to the model's E_b, beta_b
        ux = plane.contact_base(side, bz)[:, 0]  # u_X' of Delta_i (Eq. 36), both sides
        Eb = rolled_position(T0[:3, 3], ux, plane.normal, g.wheel_radius, beta_a, beta_b)
        np.testing.assert_allclose(T[:3, 3], Eb, atol=1e-9)
        done += 1
    assert done >= 10, done


def test_pose_outside_the_file_limits_is_at_a_limit(other):
    _, mech, model = other
    g = model.legs["right"]
    rng = np.random.default_rng(3)
    q0 = _random_q(rng, g)
    q0[3] = np.deg2rad(40.0)  # knee forward beyond this file's +10 deg
    TG = _random_body(rng)
    T0 = _model_contact(mech, "right", q0, TG, "foot")
    plane = _plane_through(rng, T0[:3, :3], "right", "foot", T0[:3, 3], 0.1, 0.0)
    best, alts = solve_leg_case(plane, "walk", "right", LegTask(tuple(T0[:3, 3]), 0.1, 0.0),
                                T_0_G=TG, geometry=g)
    if best.ok:  # the other knee branch may be inside the limits: then it is not q0
        assert not any(np.allclose(a.q, q0, atol=1e-7) for a in alts)
    else:
        assert best.status == STATUS_AT_LIMIT and best.q_outside is not None
        assert best.q_outside[3] > g.q_max[3]


# ---------------------------------------------------------------- end to end (tasks.biped.run)


def _scenario(tmp_path, mech_path, body, units="{length: mm, angle: deg}"):
    p = tmp_path / "s.yaml"
    p.write_text(f"name: t\ntask: ik\nmechanism: {mech_path}\nunits: {units}\nbiped:\n{body}")
    return load_scenario(p)


TILTED = """  plane: {lam_x: 0, lam_y: 0, gam_x: 0, origin: [0, 0, 0]}
  body: {position: [10, -20, 590], theta_x: 4, theta_y: -3, theta_z: 12}
  sequence:
    - name: walk
      mode: walk
      legs:
        right: {beta: 0, plane: {lam_x: 8, lam_y: 12, gam_x: -5, origin: [95, 0, 20]}}
        left: {beta: 0, below_hip: [0, 10], plane: {origin: [0, 0, 60]}}
    - name: skate
      mode: skate
      legs:
        right: {beta: 0, plane: {lam_x: 8, lam_y: 12, gam_x: -5, origin: [95, 0, 20]}}
        left: {beta: 0, plane: {origin: [0, 0, 60]}}
    - name: roll
      mode: roll
      frames: 4
      legs:
        right: {theta6: 5, plane: {lam_x: 8, lam_y: 12, gam_x: -5, origin: [95, 0, 20]}}
        left: {theta6: -3, plane: {origin: [0, 0, 60]}}
"""


def test_tilted_body_and_a_plane_per_leg(other, tmp_path):
    path, mech, _ = other
    rep = run(_scenario(tmp_path, path, TILTED))
    s = rep.summary
    assert rep.ok, [(st["name"], st["legs"]["right"]["status"], st["legs"]["left"]["status"])
                    for st in s["steps"]]
    assert s["geometry"]["estimated"] == [] and "read from" in s["geometry"]["source"]
    planes = {"right": InclinedPlane((0.095, 0.0, 0.020), *np.deg2rad([8.0, 12.0, -5.0])),
              "left": InclinedPlane((0.0, 0.0, 0.060))}
    TG = T_from(matrix_from_rpy(np.deg2rad([4.0, -3.0, 12.0])), np.array([0.01, -0.02, 0.59]))
    for k, st in enumerate(s["steps"]):
        for side in SIDES:
            leg = st["legs"][side]
            pl = planes[side]
            assert leg["plane"]["normal"] == pytest.approx(pl.normal.tolist(), abs=1e-15)
            assert abs(leg["contact_plane_distance_m"]) < 1e-12
            if k < 2:  # sole / upright blade: its normal is the plane's
                assert leg["normal_angle"] < 1e-9
            assert leg["model_fk_error_m"] < 1e-9
            # through the general model: the contact frame at the solved q
            q6 = np.array(leg["q_rad_list"])
            kind = "foot" if st["mode"] == "walk" else "blade"
            T = _model_contact(mech, side, q6, TG, kind)
            np.testing.assert_allclose(T[:3, 3], leg["end_effector_m"], atol=1e-9)
            up = -ee_rotation_from_psi(T[:3, :3], side)[:, 2]
            n = pl.normal
            ang = np.arctan2(np.linalg.norm(np.cross(up, n)), up @ n)
            if k < 2:
                assert ang < 1e-9
            else:
                assert ang == pytest.approx(abs(leg["beta"]), abs=1e-9)
    assert s["steps"][2]["legs"]["right"]["q_deg"]["r_theta6"] == pytest.approx(5.0, abs=1e-9)
    out = tmp_path / "o"
    summary = rep.write(out, plots=True)
    assert "biped.png" in summary["files"]
    with open(out / "biped.mcap", "rb") as f:
        r = make_reader(f)
        msgs = [(ch.topic, m) for _s, ch, m in r.iter_messages(topics=["/tf"])]
    assert len(msgs) == s["n_frames"] == 6


def test_pose_outside_the_limits_is_reported(other, tmp_path):
    path, _, _ = other
    sc = _scenario(tmp_path, path, """  body: {position: [0, 0, 560]}
  mode: walk
  legs: {right: {beta: 0, branch: knee forward}, left: {beta: 0}}
""")
    rep = run(sc)
    leg = rep.summary["steps"][0]["legs"]["right"]
    assert rep.exit_code == 1 and leg["status"] == STATUS_AT_LIMIT
    assert [v["joint"] for v in leg["limits"]] == ["r_theta4"]
    assert leg["q_outside_limits"]["r_theta4"] > np.deg2rad(10.0)
    assert any("r_theta4" in m and "outside" in m for m in rep.messages), rep.messages
    left = rep.summary["steps"][0]["legs"]["left"]
    assert left["status"] == "ok"


def _types(schema):
    if isinstance(schema, dict):
        if "type" in schema:
            yield schema["type"]
        for v in schema.values():
            yield from _types(v)
    elif isinstance(schema, list):
        for v in schema:
            yield from _types(v)


def test_state_schema_is_explicit_when_a_leg_fails(other, tmp_path):
    path, _, _ = other
    sc = _scenario(tmp_path, path, """  body: {position: [0, 0, 560]}
  sequence:
    - {mode: walk, legs: {right: {beta: 0}, left: {beta: 0}}}
    - {mode: walk, body: {position: [0, 0, 2000]}, legs: {right: {beta: 0}, left: {beta: 0}}}
""")
    rep = run(sc)
    assert rep.summary["steps"][1]["status"] == "unreachable"
    rep.write(tmp_path / "o", plots=False)
    with open(tmp_path / "o" / "biped.mcap", "rb") as f:
        r = make_reader(f)
        summ = r.get_summary()
        ch = next(c for c in summ.channels.values() if c.topic == "/mechkin/state")
        schema = json.loads(summ.schemas[ch.schema_id].data)
        states = [json.loads(m.data) for _s, _c, m in r.iter_messages(topics=["/mechkin/state"])]
    types = list(_types(schema))
    assert types and all(t != "null" and not isinstance(t, list) for t in types), types
    assert schema["properties"]["beta_left_deg"]["type"] == "number"
    assert "beta_left_deg" in states[0] and "beta_left_deg" not in states[1]
    assert states[1]["status"] == "unreachable" and states[1]["failed_legs"] == "right left"
    assert all(v is not None for st in states for v in st.values())


# ---------------------------------------------------------------- a file that is not the topology


@pytest.mark.parametrize(("old", "new", "msg"), [
    ("name: r_theta2, type: revolute, parent: r_link1, child: r_link2, axis: [0, 1, 0]",
     "name: r_theta2, type: revolute, parent: r_link1, child: r_link2, axis: [1, 0, 0]",
     "right leg's joint 2 'r_theta2' turns about (1, 0, 0)"),
    ("name: l_theta6, type: revolute, parent: l_link5, child: l_link6, axis: [0, -1, 0]",
     "name: l_theta6, type: revolute, parent: l_link5, child: l_link6, axis: [0, 1, 0]",
     "left leg's joint 6 'l_theta6' turns about"),
    ("child: r_link4, axis: [1, 0, 0], origin: {xyz: [0, 0, 200.0]}",
     "child: r_link4, axis: [1, 0, 0], origin: {xyz: [7, 0, 200.0]}",
     "right leg's joint 4 'r_theta4' is (0.007, 0, 0) m off the leg's axis"),
    ("child: l_link4, axis: [1, 0, 0], origin: {xyz: [0, 0, 200.0]}",
     "child: l_link4, axis: [1, 0, 0], origin: {xyz: [0, 0, 201.0]}",
     "l3 = 0.201 m on the left, 0.2 m on the right"),
    ("{name: wheel_r, xyz: [0, 0, 100.0]", "{name: wheel_x, xyz: [0, 0, 100.0]",
     "needs a frame 'wheel_r'"),
])
def test_topology_errors_name_the_joint(tmp_path, old, new, msg):
    text = mechanism_yaml()
    assert old in text, old
    p = tmp_path / "m.yaml"
    p.write_text(text.replace(old, new))
    with pytest.raises(ConfigError) as exc:
        geometry_from_mechanism(load_mechanism(p))
    assert msg in str(exc.value)


CUSTOM = sorted((ROOT / "scenarios").glob("custom_biped_*.yaml"))


@pytest.mark.parametrize("path", CUSTOM, ids=lambda p: p.stem)
def test_custom_biped_scenarios_hold_their_expects(path, tmp_path):
    rep = run(load_scenario(path))
    assert rep.summary["status"] == "ok"
    assert rep.checks and all(c["ok"] for c in rep.checks), [c for c in rep.checks
                                                              if not c["ok"]]
    assert rep.exit_code == 0 and rep.summary["geometry"]["estimated"] == []
    summary = rep.write(tmp_path / "o", plots=False)
    with open(tmp_path / "o" / "biped.mcap", "rb") as f:
        r = make_reader(f)
        tf = next(m for _s, _c, m in r.iter_messages(topics=["/tf"]))
    assert b"plane_left" in tf.data  # a second plane under the left leg
    assert "leg_left.csv" in summary["files"]


def test_there_is_a_custom_biped_scenario():
    assert CUSTOM


# ---------------------------------------------------------------- continuous motions, all solutions


ROLL_TO_TILT = """  plane: {lam_x: 5, lam_y: -8, gam_x: 3, origin: [0, 0, 0]}
  body: {position: [0, 10, 560], theta_x: -2, theta_y: 3, theta_z: -6}
  sequence:
    - {name: upright, mode: skate, legs: {right: {beta: 0, beta_z: 4}, left: {beta: 0}}}
    - name: tilt
      mode: roll
      frames: 5
      time_law: smooth
      legs: {right: {beta_end: 12, beta_z: 4}, left: {beta_end: -9}}
    - name: back
      mode: roll
      legs: {right: {beta_end: 0, beta_z: 4}, left: {beta_end: 0}}
"""


def test_roll_to_a_target_tilt_equals_the_rolling_closed_form(other, tmp_path):
    path, mech, _ = other
    rep = run(_scenario(tmp_path, path, ROLL_TO_TILT))
    assert rep.ok, rep.summary["status"]
    theta6 = {}
    for k, tilt in ((1, {"right": 12.0, "left": -9.0}), (2, {"right": 0.0, "left": 0.0})):
        for side in SIDES:
            leg = rep.summary["steps"][k]["legs"][side]
            assert leg["beta_deg"] == pytest.approx(tilt[side], abs=1e-10)
            assert abs(leg["contact_plane_distance_m"]) < 1e-12
            assert leg["normal_angle"] == pytest.approx(np.deg2rad(abs(tilt[side])), abs=1e-9)
            assert leg["model_fk_error_m"] < 1e-9
            theta6[k, side] = leg["q_deg_list"][5]
    # the same rolls posed as §2.4 (theta6 given, tilt unknown: a root search) end there too
    text = ROLL_TO_TILT
    for k, old in ((1, "{right: {beta_end: 12, beta_z: 4}, left: {beta_end: -9}}"),
                   (2, "{right: {beta_end: 0, beta_z: 4}, left: {beta_end: 0}}")):
        text = text.replace(old, f"{{right: {{theta6: {theta6[k, 'right']!r}, beta_z: 4}}, "
                                 f"left: {{theta6: {theta6[k, 'left']!r}}}}}")
    rep2 = run(_scenario(tmp_path, path, text))
    assert rep2.ok
    for k in (1, 2):
        for side in SIDES:
            a = rep.summary["steps"][k]["legs"][side]
            b = rep2.summary["steps"][k]["legs"][side]
            assert b["beta"] == pytest.approx(a["beta"], abs=1e-9)
            np.testing.assert_allclose(b["q_rad_list"], a["q_rad_list"], atol=1e-8)
            np.testing.assert_allclose(b["contact_point_m"], a["contact_point_m"], atol=1e-9)
    assert rep.summary["n_frames"] == 7
    # the animated frames roll monotonically from 0 to 12 deg (right)
    st = rep.data.state
    b = [x["beta_right_deg"] for x in st[1:6]]
    assert np.all(np.diff(b) > 0) and b[-1] == pytest.approx(12.0, abs=1e-9)


MOVE = """  plane: {lam_x: 0, lam_y: 6, gam_x: 0, origin: [0, 0, 0]}
  body: {position: [0, 0, 590]}
  sequence:
    - {name: start, mode: walk, legs: {right: {beta: 0}, left: {beta: 0}}}
    - name: move
      mode: walk
      frames: 8
      time_law: smooth
      duration: 2.0
      body: {position: [20, 40, 570], theta_x: 3, theta_y: -2, theta_z: 10}
      legs:
        right: {beta: 5, beta_z: 8, below_hip: [10, 60]}
        left: {beta: -4, below_hip: [0, -30]}
"""


def _angle(R):
    return float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


def test_continuous_walk_follows_lines_and_slerp_with_a_smooth_time_law(other, tmp_path):
    path, mech, _ = other
    rep = run(_scenario(tmp_path, path, MOVE))
    assert rep.ok, rep.summary["status"]
    rec = rep.data
    assert len(rec.times) == 9 and rep.summary["n_frames"] == 9
    f = np.arange(1, 9) / 8.0
    h = 10 * f**3 - 15 * f**4 + 6 * f**5  # the smooth time law, typed in here
    np.testing.assert_allclose(rec.times[1:], 2.0 * f, atol=1e-12)
    TG = rec.T_0_G
    np.testing.assert_allclose(TG[1:, :3, 3], TG[0, :3, 3] + h[:, None] * (TG[-1, :3, 3]
                                                                          - TG[0, :3, 3]),
                               atol=1e-12)
    total = _angle(TG[0, :3, :3].T @ TG[-1, :3, :3])
    for i in range(1, 9):
        assert _angle(TG[0, :3, :3].T @ TG[i, :3, :3]) == pytest.approx(h[i - 1] * total,
                                                                        abs=1e-9)
    for side in SIDES:
        idx = _leg_idx(mech, side)
        # every frame's foot frame by the general model's forward kinematics
        T = np.stack([_model_contact(mech, side, rec.q[i, idx], TG[i], "foot")
                      for i in range(9)])
        p0, p1 = T[0, :3, 3], T[-1, :3, 3]
        np.testing.assert_allclose(T[1:, :3, 3], p0 + h[:, None] * (p1 - p0), atol=1e-9)
        tot = _angle(T[0, :3, :3].T @ T[-1, :3, :3])
        assert tot > 0.05
        for i in range(1, 9):
            assert _angle(T[0, :3, :3].T @ T[i, :3, :3]) == pytest.approx(h[i - 1] * tot,
                                                                          abs=1e-9)
        # the ends are the steps' solutions
        np.testing.assert_allclose(rec.q[0, idx], rep.summary["steps"][0]["legs"][side]
                                   ["q_rad_list"], atol=1e-12)
        np.testing.assert_allclose(rec.q[-1, idx], rep.summary["steps"][1]["legs"][side]
                                   ["q_rad_list"], atol=1e-12)


def test_solutions_all_lists_every_verified_solution(tmp_path):
    text = (ROOT / "scenarios" / "hwang2023_fig7_a.yaml").read_text().replace(
        "mechanism: ../mechanisms/", f"mechanism: {ROOT / 'mechanisms'}/").replace(
        "biped:\n", "biped:\n  solutions: all\n")
    p = tmp_path / "s.yaml"
    p.write_text(text)
    rep = run(load_scenario(p))
    assert rep.ok
    for side in SIDES:
        leg = rep.summary["steps"][0]["legs"][side]
        sols = leg["solutions"]
        assert len(sols) == leg["n_solutions"] == 2
        assert {s["branch"] for s in sols} == {"knee back", "knee forward"}
        assert all(s["model_fk_error_m"] < 1e-9 and s["position_error_m"] < 1e-9
                   for s in sols)
        assert sols[0]["q_rad_list"] == leg["q_rad_list"]
        assert abs(sols[0]["q_rad_list"][3] - sols[1]["q_rad_list"][3]) > 0.1

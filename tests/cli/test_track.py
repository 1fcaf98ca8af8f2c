"""`mechkin track` end to end on park's scenarios: summaries, CSV, MCAP read back, bad input."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.config.scenario import load_scenario
from mechkin.io.csv_out import read_csv
from mechkin.tasks.track import run
from tests.scenario_copy import local_scenario as _local

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()
PARK = ["park_conveyor_none", "park_conveyor_torque", "park_conveyor_full", "park_grid_study",
        "park_time_optimal_torque", "park_time_optimal_full"]
KEYS = {"status", "message", "t_a_s", "peak_torque", "duration_s", "limits_ok", "active_limits",
        "grid", "solve_time_s", "files", "limit_usage"}


def _mcap(path: Path):
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summ = reader.get_summary()
        topics = {c.topic: summ.schemas[c.schema_id].name for c in summ.channels.values()}
        counts = {summ.channels[cid].topic: n
                  for cid, n in summ.statistics.channel_message_counts.items()}
        decoded: dict[str, list] = {}
        proto = [t for t in topics if t not in ("/mechkin/state", "/robot_description")]
        for _s, ch, _m, msg in reader.iter_decoded_messages(topics=proto):
            decoded.setdefault(ch.topic, []).append(msg)
        for _s, ch, m in reader.iter_messages(topics=["/mechkin/state"]):
            decoded.setdefault(ch.topic, []).append(json.loads(m.data))
        return topics, counts, summ.statistics, decoded


@pytest.mark.parametrize("name", PARK)
def test_park_scenarios_exit_0(tmp_path: Path, name: str) -> None:
    sc = load_scenario(SCEN / f"{name}.yaml")
    rep = run(sc)
    summary, code = rep.write(tmp_path / "out", plots=False), rep.exit_code
    assert code == 0, (summary["message"], summary.get("expect"))
    assert set(summary) >= KEYS
    assert summary["status"] == "ok" and summary["limits_ok"]
    assert all(c["ok"] for c in summary["expect"])
    assert {"track.csv", "track.mcap", "summary.json"} <= set(summary["files"])
    on_disk = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert on_disk["t_a_s"] == summary["t_a_s"]
    if name == "park_grid_study":
        assert [(g["N1"], g["N2"]) for g in summary["grid_study"]] == [(30, 50), (50, 100),
                                                                        (100, 200)]
        assert all(g["t_a_s"] >= 1.0935 and g["limits_ok"] for g in summary["grid_study"])
    if name.startswith("park_time_optimal"):
        assert summary["t_a_s"] is None
        ref = 2.530 if name.endswith("torque") else 3.041
        assert ref <= summary["duration_s"] <= 1.02 * ref


def test_full_case_outputs_csv_and_mcap(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(SCEN / "park_conveyor_full.yaml"), "--out", str(out),
                              "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["t_a_s"] == pytest.approx(1.10, abs=0.005)
    for png in ("phase.png", "hand_part.png", "joint_velocities.png", "torques.png"):
        assert png in summary["files"] and (out / png).stat().st_size > 0
    text = (out / "track.csv").read_text()
    assert "nan" not in text.lower() and ",," not in text
    cols = {k: np.asarray(v, dtype=float) for k, v in read_csv(out / "track.csv").items()}
    for c in ("t_s", "r", "rd_1_s", "q1_rad", "qd2_rad_s", "qdd1_rad_s2", "jerk2_rad_s3",
              "u1_Nm", "u2_Nm", "hand_x_m", "part_x_m", "error_x_m", "error_norm_m"):
        assert c in cols, c
    K = summary["n_samples"]
    assert all(len(v) == K for v in cols.values())
    assert np.all(np.abs(cols["qd1_rad_s"]) <= 0.2 + 1e-9)
    assert np.all(np.abs(cols["qd2_rad_s"]) <= 0.2 + 1e-9)
    after = cols["t_s"] >= summary["t_a_s"] - 1e-12
    assert np.max(cols["error_norm_m"][after]) <= 1e-9  # zero steady-state error (§5.3)
    assert np.min(cols["u1_Nm"]) == pytest.approx(summary["peak_torque"][0], abs=1e-12)

    topics, counts, stats, msgs = _mcap(out / "track.mcap")
    assert topics["/tf"] == "foxglove.FrameTransforms"
    assert topics["/scene"] == "foxglove.SceneUpdate"
    assert topics["/joint_states"] == "foxglove.JointStates"
    assert "/mechkin/state" in topics
    assert counts.pop("/robot_description") == 1  # the URDF, once
    assert all(n == K for n in counts.values()), counts
    assert stats.message_start_time == 0
    assert stats.message_end_time == round(summary["duration_s"] * 1e9)
    assert {t.child_frame_id for t in msgs["/tf"][0].transforms} >= {"link1", "link2", "hand"}
    effort = np.array([list(m.joints[k].effort for k in range(2))
                       for m in msgs["/joint_states"]])
    np.testing.assert_allclose(effort[:, 0], cols["u1_Nm"], atol=1e-12)
    ent = msgs["/scene"][-1].entities[0]
    assert len(ent.cubes) == 2 and len(ent.lines) >= 1  # the part and the belt; the arm
    part_x = [m.entities[0].cubes[0].pose.position.x for m in msgs["/scene"]]
    np.testing.assert_allclose(part_x, cols["part_x_m"], atol=1e-12)
    state = msgs["/mechkin/state"]
    assert {"r", "rd_1_s", "tracking_error_m", "phase"} <= set(state[-1])
    assert state[-1]["phase"] == "tracking" and state[-1]["tracking_error_m"] <= 1e-9


def test_closed_form_dynamics_gives_the_same_plan(tmp_path: Path) -> None:
    p = _local(tmp_path, "park_conveyor_torque", ("dynamics: rnea", "dynamics: closed_form_2link"))
    a = run(load_scenario(p)).write(tmp_path / "a", plots=False)
    b = run(load_scenario(SCEN / "park_conveyor_torque.yaml")).write(tmp_path / "b", plots=False)
    assert a["t_a_s"] == b["t_a_s"]
    np.testing.assert_allclose(a["peak_torque"], b["peak_torque"], atol=1e-9)


def test_infeasible_limits_exit_1_naming_the_limit(tmp_path: Path) -> None:
    p = _local(tmp_path, "park_conveyor_full", ("qd: [0.2, 0.2]", "qd: [0.2, 0.05]"))
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 1, res.output
    assert "infeasible" in res.stderr and "joint velocity limit (joint 2)" in res.stderr
    assert "r = 1" in res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "infeasible" and summary["t_a_s"] is None
    assert summary["blocking_limits"] == ["qd_2"]
    assert summary["files"] == ["summary.json"]


def test_expect_failure_exits_5(tmp_path: Path) -> None:
    p = _local(tmp_path, "park_conveyor_none", ("max: 0.650000001", "max: 0.61"))
    res = runner.invoke(app, ["track", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 5  # an expect failed
    assert "expect t_a_s" in res.stderr


@pytest.mark.parametrize(("edit", "pattern"), [
    (("nt_fraction: 0.8", "nt_fracton: 0.8"), r":\d+: track\.grid\.nt_fracton: unknown key"),
    (("objective: tracking", "objective: fastest"), r":\d+: track\.objective: "),
    (("torque: [0.5, 0.2], qd", "torque: [0.5], qd"),
     r":\d+: track\.limits\.torque: expected 2 values"),
    (("{q2: positive}", "{q2: negative}"), r":\d+: track\.ik\.branch\.q2: q2 is not negative"),
])
def test_bad_track_section_exits_2(tmp_path: Path, edit, pattern) -> None:
    p = _local(tmp_path, "park_conveyor_full", edit)
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    import re

    assert re.search(str(p).replace(".", r"\.") + pattern, res.stderr), res.stderr
    assert not out.exists()


# ---- issue 11: any arm along any path ----------------------------------------------------------


def test_puma560_line_holds_the_tool_orientation(tmp_path: Path) -> None:
    """6-D path IK: the realised plan, checked by forward kinematics, stays on the line with the
    start orientation (was: the tool turned by tens of degrees with a position-only IK)."""
    rep = run(load_scenario(SCEN / "puma560_track_line.yaml"))
    summary = rep.write(tmp_path / "out", plots=False)
    assert rep.exit_code == 0, (summary["message"], summary.get("expect"))
    p = summary["path"]
    assert p["orientation"] == "fixed" and p["mask"] == ["x", "y", "z", "rx", "ry", "rz"]
    assert p["max_orientation_error_rad"] <= 1e-6 and p["max_position_error_m"] <= 1e-6
    assert p["max_rotation_from_start_rad"] <= 1e-6
    cols = {k: np.asarray(v, dtype=float) for k, v in read_csv(tmp_path / "out" / "track.csv")
            .items()}
    from mechkin.model import load_mechanism
    from mechkin.model.kinematics import forward_kinematics

    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q = np.column_stack([cols[f"q{k}_rad"] for k in range(1, 7)])
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    R0 = T[0, :3, :3]
    cosang = (np.einsum("mij,ij->m", T[:, :3, :3], R0) - 1.0) / 2.0
    assert np.min(cosang) >= np.cos(1e-6)
    hand = np.column_stack([cols[f"hand_{a}_m"] for a in "xyz"])
    assert np.max(np.abs(T[:, :3, 3] - hand)) <= 1e-6


def test_planar3r_line_solves_exit_0(tmp_path: Path) -> None:
    """A redundant arm (3 joints, 2 task components) on a line in its plane: exit 0 (was exit 3,
    LinAlgError: Singular matrix in solvers/path.py)."""
    res = runner.invoke(app, ["track", str(SCEN / "planar3r_track_line.yaml"), "--no-plots",
                              "--json", "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["path"]["redundancy"] == 1 and s["path"]["task_rank"] == 2
    assert s["path"]["max_position_error_m"] <= 1e-9
    assert s["status"] == "ok" and s["limits_ok"]


@pytest.mark.parametrize(("edit", "pattern"), [
    (("orientation: fixed}", "orientation: free, mask: [x, y, z, rz]}"),
     r":\d+: track\.path: .*mask names rz but orientation is free"),
    (("orientation: fixed}", "mask: [x, z, rx, ry, rz]}"),
     r":\d+: track\.path: .*the line moves along y, which the mask leaves free"),
    (("orientation: fixed}", "mask: [x, y, y]}"), r":\d+: track\.path: .*named twice"),
    (("orientation: fixed}", "mask: [x, y, z, yaw]}"), r":\d+: track\.path\.mask\[3\]: .*yaw"),
])
def test_bad_path_mask_exits_2(tmp_path: Path, edit, pattern) -> None:
    p = _local(tmp_path, "puma560_track_line", edit)
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    import re

    assert re.search(str(p).replace(".", r"\.") + pattern, res.stderr), res.stderr
    assert not out.exists()


def test_joint_limit_infeasibility_names_the_joint_and_r(tmp_path: Path) -> None:
    """A PUMA 560 line towards the base whose IK drives q3 to about -190 deg (limits +-135):
    infeasible, exit 1, naming the joint and r (was: "ok, limits ok")."""
    p = _local(tmp_path, "puma560_track_line",
               ("end: [0.80574977, 0.24995, 0.86743]", "end: [0.50574977, -0.15005, 0.86743]"),
               ("part_start: [0.80574977, -0.20005, 0.86743], belt_velocity: [0, 0.1, 0]",
                "part_start: [0.85574977, -0.15005, 0.86743], belt_velocity: [-0.1, 0, 0]"))
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 1, res.output
    assert "infeasible: joint position limit (joint 3 = q3)" in res.stderr, res.stderr
    m = re.search(r"at r = ([0-9.]+)", res.stderr)
    assert m is not None
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "infeasible" and summary["blocking_limits"] == ["q_3"]
    assert summary["blocked_at_r"][0] == pytest.approx(float(m.group(1)), abs=1e-4)
    assert 0.0 < summary["blocked_at_r"][0] < 1.0
    assert summary["limits_si"]["q"]["min"][2] == pytest.approx(-135 * np.pi / 180)


def test_line_leaving_the_workspace_names_r_and_the_point(tmp_path: Path) -> None:
    """A PUMA 560 line outwards past the stretched arm: a one-line error at track.path naming
    r and the point (exit 2, nothing written)."""
    p = _local(tmp_path, "puma560_track_line",
               ("end: [0.80574977, 0.24995, 0.86743]", "end: [1.30574977, -0.15005, 0.86743]"),
               ("part_start: [0.80574977, -0.20005, 0.86743], belt_velocity: [0, 0.1, 0]",
                "part_start: [0.75574977, -0.15005, 0.86743], belt_velocity: [0.1, 0, 0]"))
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    m = re.search(str(p).replace(".", r"\.") + r":\d+: track\.path: the hand line leaves the "
                  r"reachable workspace or meets a singularity near r = ([0-9.]+) \(point "
                  r"\[([-0-9., ]+)\] m", res.stderr)
    assert m is not None, res.stderr
    r = float(m.group(1))
    point = np.array([float(v) for v in m.group(2).split(",")])
    assert 0.0 < r < 1.0
    assert_line = np.array([0.80574977, -0.15005, 0.86743]) + r * np.array([0.5, 0.0, 0.0])
    np.testing.assert_allclose(point, assert_line, atol=1e-5)
    assert not out.exists()

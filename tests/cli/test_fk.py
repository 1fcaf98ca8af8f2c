"""`mechkin fk` end to end: outputs, MCAP read back, expect checks, JSON summary."""

import json
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.io.csv_out import read_csv

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def test_fk_puma_outputs_and_mcap(tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["fk", str(ROOT / "scenarios" / "puma560_wave_fk.yaml"),
                              "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["status"] == "ok" and summary["n_steps"] == 201
    assert set(summary["files"]) >= {"fk.csv", "fk.mcap", "joints.png", "stick.png",
                                      "summary.json"}
    cols = read_csv(out / "fk.csv")
    assert {"t_s", "q1_rad", "ee_x_m", "ee_qw", "closure_residual"} <= set(cols)
    # final pose in the CSV equals an independent FK of the final joint values
    from tests.model.test_kinematics import _puma_reference

    q = np.array([cols[f"q{i}_rad"][-1] for i in range(1, 7)], dtype=float)
    T = _puma_reference(q)
    np.testing.assert_allclose([cols["ee_x_m"][-1], cols["ee_y_m"][-1], cols["ee_z_m"][-1]],
                               T[:3, 3], atol=1e-9)
    with open(out / "fk.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summ = reader.get_summary()
        topics = {c.topic: summ.schemas[c.schema_id].name for c in summ.channels.values()}
        assert topics["/tf"] == "foxglove.FrameTransforms"
        assert topics["/scene"] == "foxglove.SceneUpdate"
        assert topics["/joint_states"] == "foxglove.JointStates"
        assert "/mechkin/state" in topics
        counts = {summ.channels[cid].topic: n
                  for cid, n in summ.statistics.channel_message_counts.items()}
        assert counts.pop("/robot_description") == 1  # the URDF, once
        assert all(n == 201 for n in counts.values()), counts
        assert summ.statistics.message_start_time == 0
        assert summ.statistics.message_end_time == 4_000_000_000
        n_tf = 0
        for _schema, _channel, _message, decoded in reader.iter_decoded_messages(topics=["/tf"]):
            # 6 links + the tool frame + link2_dh, link3_dh: the URDF's tree (standard D-H
            # joints with a != 0 move an intermediate link)
            assert len(decoded.transforms) == 9
            n_tf += 1
            last = decoded
        assert n_tf == 201
        tool = [t for t in last.transforms if t.child_frame_id == "tool"][0]
        assert tool.parent_frame_id == "link6"


def test_fk_expect_failure_exits_1_and_still_writes(tmp_path):
    s = (ROOT / "scenarios" / "puma560_wave_fk.yaml").read_text()
    s = s.replace("mechanism: ../mechanisms/puma560.yaml",
                  f"mechanism: {ROOT / 'mechanisms' / 'puma560.yaml'}")
    s = s.replace("{key: n_steps, value: 201, tol: 0}", "{key: n_steps, value: 200, tol: 0}")
    p = tmp_path / "s.yaml"
    p.write_text(s)
    out = tmp_path / "out"
    res = runner.invoke(app, ["fk", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 5  # an expect failed (the solver reached every step)
    assert "expect n_steps" in res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["expect"][0]["ok"] is False


def test_fk_table_motion_closed_chain(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(
        f"name: fb\ntask: fk\nmechanism: {ROOT / 'tests' / 'data' / 'fourbar.yaml'}\n"
        "units: {angle: deg}\n"
        "fk:\n  table: {t: [0, 1, 2, 3], q_crank: [60, 90, 120, 150]}\n"
        "expect:\n  - {key: steps.converged, value: 4, tol: 0}\n"
    )
    out = tmp_path / "o"
    res = runner.invoke(app, ["fk", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 0, res.output
    cols = read_csv(out / "fk.csv")
    assert np.max(np.asarray(cols["closure_residual"], dtype=float)) < 1e-12


def test_info_json_keys():
    res = runner.invoke(app, ["info", str(ROOT / "tests" / "data" / "fourbar.yaml"), "--json"])
    assert res.exit_code == 0
    info = json.loads(res.stdout)
    for k in ("n_coordinates", "n_cuts", "n_equations", "dof", "mobility", "independent",
              "dependent"):
        assert k in info
    assert (info["n_coordinates"], info["n_cuts"], info["n_equations"], info["dof"]) == (3, 1, 2, 1)


def test_joints_without_a_motion_hold_their_home_value(tmp_path):
    """An fk motion that names some joints: the others hold their home values (one note
    names them), equal to giving them as constants at home; `check` accepts the file."""
    root = Path(__file__).resolve().parents[2]
    mech = root / "mechanisms" / "puma560.yaml"
    head = (f"name: part\ntask: fk\nmechanism: {mech}\nunits: {{angle: deg}}\nfk:\n"
            "  time: {start: 0, stop: 1, step: 0.25}\n  motion:\n"
            "    q2: {type: ramp, from: 0, to: 40}\n")
    part = tmp_path / "part.yaml"
    part.write_text(head)
    full = tmp_path / "full.yaml"
    full.write_text(head.replace("name: part", "name: full") + "".join(
        f"    {q}: {{type: constant, value: 0}}\n" for q in ("q1", "q3", "q4", "q5", "q6")))
    res = runner.invoke(app, ["fk", str(part), "--out", str(tmp_path / "p"), "--no-plots"])
    assert res.exit_code == 0, res.output
    notes = [ln for ln in res.stderr.splitlines() if "without a motion" in ln]
    assert runner.invoke(app, ["check", str(part)]).exit_code == 0
    assert len(notes) == 1 and notes[0].startswith(f"{part}:7: fk.motion: note: 5 independent")
    assert "q1, q3, q4, q5, q6" in notes[0]
    res = runner.invoke(app, ["fk", str(full), "--out", str(tmp_path / "f"), "--no-plots"])
    assert res.exit_code == 0, res.output
    a, b = read_csv(tmp_path / "p" / "fk.csv"), read_csv(tmp_path / "f" / "fk.csv")
    for k in ("q1_rad", "q3_rad", "q6_rad", "ee_x_m", "ee_z_m"):
        assert np.array_equal(np.asarray(a[k]), np.asarray(b[k])), k

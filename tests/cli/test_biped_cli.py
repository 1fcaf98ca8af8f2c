"""The biped task (``mechkin.tasks.biped.run``): the hwang2023 Fig. 7 scenarios end to end
(summary, CSV, PNG, MCAP), bad input.

The Table 6 angles in the scenarios' ``expect:`` entries depend on the ESTIMATED geometry and body
heights (see the scenario comments); theta6 of the roll cases and theta1 on plane (a) do not.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from mechkin.config.scenario import load_scenario
from mechkin.errors import ConfigError
from mechkin.io.csv_out import read_csv
from mechkin.tasks.biped import run

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "scenarios").glob("hwang2023_*.yaml"))
MECH = ROOT / "mechanisms" / "hwang2023_biped.yaml"


def run_biped(*, scenario, out_dir: Path, plots: bool = True) -> tuple[dict, int]:
    """The task's report written to ``out_dir``: (summary, exit code)."""
    rep = run(scenario)
    return rep.write(out_dir, plots=plots), rep.exit_code

CASE = """name: t
task: ik
mechanism: {mech}
units: {{length: mm, angle: deg}}
biped:
  plane: {{lam_y: 15}}
  body: {{position: [0, 0, {z}]}}
{body}
"""


def _write(tmp_path: Path, body: str, z: float = 677.205) -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(CASE.format(mech=MECH, z=z, body=body))
    return p


def _mcap(path: Path) -> tuple[dict, dict, list]:
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summ = reader.get_summary()
        topics = {c.topic: summ.schemas[c.schema_id].name for c in summ.channels.values()}
        counts = {summ.channels[cid].topic: n
                  for cid, n in summ.statistics.channel_message_counts.items()}
        times = (summ.statistics.message_start_time, summ.statistics.message_end_time)
        proto = [t for t in topics if t not in ("/mechkin/state", "/robot_description")]
        msgs = [(ch.topic, dec) for _s, ch, _m, dec in reader.iter_decoded_messages(topics=proto)]
        msgs += [(ch.topic, json.loads(m.data)) for _s, ch, m in
                 reader.iter_messages(topics=["/mechkin/state"])]
    return topics, {"counts": counts, "times": times}, msgs


def test_there_are_ten_scenarios():
    names = {p.stem for p in SCENARIOS}
    assert names == ({f"hwang2023_fig7_{c}" for c in "abcdefgh"}
                     | {"hwang2023_walk_to_skate", "hwang2023_walk_skate_roll_unroll"})


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_scenario_exits_0_with_every_output(path: Path, tmp_path: Path):
    sc = load_scenario(path)
    assert sc.section_name == "biped"
    out = tmp_path / "out"
    summary, code = run_biped(scenario=sc, out_dir=out, plots=path.stem.endswith(("_a", "skate")))
    assert code == 0, [c for c in summary.get("expect", []) if not c["ok"]]
    assert summary["status"] == "ok" and summary["expect"]
    assert all(c["ok"] for c in summary["expect"])
    files = {"summary.json", "leg_right.csv", "leg_left.csv", "biped.mcap"}
    assert files <= set(summary["files"])
    for name in summary["files"]:
        assert (out / name).is_file()
    on_disk = json.loads((out / "summary.json").read_text())  # strict JSON: no NaN
    for step in on_disk["steps"]:
        for side in ("right", "left"):
            leg = step["legs"][side]
            assert leg["status"] == "ok"
            assert leg["position_error_m"] < 1e-9 and leg["orientation_error_rad"] < 1e-9
            assert leg["model_fk_error_m"] < 1e-9  # the mechanism file agrees with the closed form
            assert abs(leg["contact_plane_distance_m"]) < 1e-9
            assert set(leg["q_deg"]) == {f"{side[0]}_theta{i}" for i in range(1, 7)}
    cols = read_csv(out / "leg_right.csv")
    assert {"t_s", "r_theta4_rad", "r_theta4_deg", "beta_deg", "contact_z_m", "status"} <= set(cols)
    assert len(cols["t_s"]) == summary["n_steps"]
    np.testing.assert_allclose(np.asarray(cols["r_theta3_rad"], float),
                               [s["legs"]["right"]["q"]["r_theta3"] for s in on_disk["steps"]])


def test_single_case_is_a_one_step_log(tmp_path: Path):
    sc = load_scenario(ROOT / "scenarios" / "hwang2023_fig7_d.yaml")
    summary, code = run_biped(scenario=sc, out_dir=tmp_path / "o", plots=True)
    assert code == 0 and (tmp_path / "o" / "biped.png").stat().st_size > 10_000
    topics, st, msgs = _mcap(tmp_path / "o" / "biped.mcap")
    assert topics == {"/tf": "foxglove.FrameTransforms", "/scene": "foxglove.SceneUpdate",
                      "/joint_states": "foxglove.JointStates", "/mechkin/state": "mechkin.State",
                      "/robot_description": "std_msgs/msg/String"}  # the URDF, once
    assert set(st["counts"].values()) == {1} and st["times"] == (0, 0)


def test_walk_to_skate_mcap_animates_the_sequence(tmp_path: Path):
    sc = load_scenario(ROOT / "scenarios" / "hwang2023_walk_to_skate.yaml")
    summary, code = run_biped(scenario=sc, out_dir=tmp_path / "o", plots=False)
    assert code == 0
    assert [s["mode"] for s in summary["steps"]] == ["walk", "skate", "roll", "roll"]
    assert "biped.png" not in summary["files"]
    topics, st, msgs = _mcap(tmp_path / "o" / "biped.mcap")
    assert set(topics) == {"/tf", "/scene", "/joint_states", "/mechkin/state",
                           "/robot_description"}
    assert st["counts"].pop("/robot_description") == 1  # the URDF, once
    assert all(n == 42 for n in st["counts"].values()), st["counts"]
    assert st["times"] == (0, 5_000_000_000)
    tf = [d for t, d in msgs if t == "/tf"]
    frames = {(x.parent_frame_id, x.child_frame_id) for x in tf[0].transforms}
    assert {("world", "plane"), ("world", "body"), ("body", "hip_r"),
            ("r_link6", "blade_r")} <= frames
    scenes = [d for t, d in msgs if t == "/scene"]
    ent = scenes[0].entities[0]
    assert ent.frame_id == "world" and len(ent.cubes) == 1 and ent.cubes[0].color.a < 1.0
    assert ent.cubes[0].size.z < 0.01  # the plane: a thin translucent box
    phases = [d.entities[0].texts[0].text for d in scenes]
    assert phases[0].startswith("walk (a)") and phases[-1].startswith("roll to (c)")
    js = [d for t, d in msgs if t == "/joint_states"]
    assert len(js[0].joints) == 12
    r6 = [j.position for j in js[-1].joints if j.name == "r_theta6"][0]
    assert r6 == pytest.approx(np.deg2rad(20.0))
    states = [d for t, d in msgs if t == "/mechkin/state"]
    assert all(s["status"] == "ok" for s in states)
    # the animated roll: theta6 of the right leg goes monotonically -19.28 -> 0 -> 20 deg
    t6 = np.array([s["theta6_right_deg"] for s in states[1:]])
    assert np.all(np.diff(t6) > 0) and t6[0] == pytest.approx(-19.28, abs=0.05)


def test_branch_knee_forward_and_skate_with_theta6(tmp_path: Path):
    p = _write(tmp_path, "  mode: skate\n  legs:\n"
                         "    right: {theta6: -10, branch: knee forward}\n"
                         "    left: {beta: 5, branch: knee back}\n")
    summary, code = run_biped(scenario=load_scenario(p), out_dir=tmp_path / "o", plots=False)
    assert code == 0
    right, left = summary["steps"][0]["legs"]["right"], summary["steps"][0]["legs"]["left"]
    assert right["branch"] == "knee forward" and right["q"]["r_theta4"] > 0
    assert right["q_deg"]["r_theta6"] == pytest.approx(-10.0)
    assert right["method"].startswith("hwang2023 §2.3")
    assert left["branch"] == "knee back" and left["beta_deg"] == pytest.approx(5.0)


def test_unreachable_leg_exits_1_and_still_writes_without_nan(tmp_path: Path):
    p = _write(tmp_path, "  mode: walk\n", z=1500.0)
    summary, code = run_biped(scenario=load_scenario(p), out_dir=tmp_path / "o", plots=True)
    assert code == 1 and summary["status"] != "ok"
    on_disk = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert "q" not in on_disk["steps"][0]["legs"]["right"]
    assert (tmp_path / "o" / "biped.mcap").is_file()
    text = (tmp_path / "o" / "leg_right.csv").read_text()
    assert "nan" not in text.lower() and "unreachable" in text


def test_failed_expect_exits_5(tmp_path: Path):
    p = _write(tmp_path, "  mode: walk\nexpect:\n"
                         "  - {key: steps.0.legs.right.q.r_theta3, value: 6.0, tol: 0.05, "
                         "unit: deg}\n")
    summary, code = run_biped(scenario=load_scenario(p), out_dir=tmp_path / "o", plots=False)
    assert code == 5 and summary["expect"][0]["ok"] is False  # 5: an expect failed
    assert summary["expect"][0]["actual"] == pytest.approx(5.63, abs=0.05)


@pytest.mark.parametrize(("body", "where", "msg"), [
    ("  mode: walk\n  legs:\n    right: {beta: 0, tilt: 3}\n", "biped.legs.right.tilt",
     "unknown key"),
    ("  mode: roll\n  legs:\n    right: {beta: 0}\n", "biped", "a roll needs theta6"),
    ("  mode: skate\n  legs:\n    left: {beta: 0, theta6: 3}\n", "biped", "not both"),
    ("  mode: hop\n", "biped.mode", "walk"),
    ("  mode: walk\n  sequence:\n    - {mode: walk}\n", "biped", "not both"),
    ("  sequence:\n    - {mode: walk, frames: 0}\n", "biped.sequence[0].frames", "greater"),
    ("  mode: walk\n  legs:\n    right: {position: [0, 0, 0], below_hip: [0, 0]}\n",
     "biped.legs.right", "either position or below_hip"),
    ("  mode: walk\n  legs:\n    right: {beta_end: 3}\n", "biped", "beta_end is the tilt"),
    ("  mode: roll\n  legs:\n    right: {theta6: 3, beta_end: 0}\n    left: {theta6: 0}\n",
     "biped", "not both"),
    ("  mode: walk\n  legs:\n    right: {plane: {lam_z: 3}}\n", "biped.legs.right.plane.lam_z",
     "unknown key"),
    ("  mode: walk\n  solutions: some\n", "biped.solutions", "one"),
    ("  sequence:\n    - {mode: walk, time_law: cubic}\n", "biped.sequence[0].time_law",
     "linear"),
])
def test_bad_biped_section_is_a_config_error_with_file_line_and_key(tmp_path, body, where, msg):
    p = _write(tmp_path, body)
    with pytest.raises(ConfigError) as exc:
        load_scenario(p)
    lines = exc.value.problems
    assert any(line.startswith(f"{p}:") and f": {where}" in line and msg in line
               for line in lines), lines
    assert all(line.split(":")[1].isdigit() for line in lines)


def test_mechanism_that_differs_from_the_closed_form_is_refused(tmp_path: Path):
    # issue 12: other lengths are read from the file, but the legs must stay mirror images
    mech = tmp_path / "m.yaml"
    mech.write_text(MECH.read_text().replace("origin: {xyz: [0, 0, 175.0]}",
                                             "origin: {xyz: [0, 0, 176.0]}", 1))
    p = tmp_path / "s.yaml"
    p.write_text(CASE.format(mech=mech, z=677.205, body="  mode: walk\n"))
    with pytest.raises(ConfigError, match="differs from the hwang2023 closed-form leg"):
        run_biped(scenario=load_scenario(p), out_dir=tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_other_lengths_are_read_from_the_mechanism_file(tmp_path: Path):
    # issue 12: the bundled biped with l3 = 200 mm and l4 = 190 mm (refused before: "differs from
    # the hwang2023 closed-form leg by 0.0438 m")
    mech = tmp_path / "m.yaml"
    mech.write_text(MECH.read_text().replace("[0, 0, 175.0]", "[0, 0, 200.0]")
                    .replace("[0, 0, 165.0]", "[0, 0, 190.0]"))
    p = tmp_path / "s.yaml"
    p.write_text(CASE.format(mech=mech, z=720.0, body="  mode: walk\n"))
    summary, code = run_biped(scenario=load_scenario(p), out_dir=tmp_path / "o", plots=False)
    assert code == 0, summary["status"]
    g = summary["geometry"]
    assert g["lengths_m"][2:4] == pytest.approx([0.200, 0.190], abs=1e-12)
    assert g["estimated"] == [] and "read from the mechanism file" in g["source"]
    for side in ("right", "left"):
        leg = summary["steps"][0]["legs"][side]
        assert leg["model_fk_error_m"] < 1e-9 and abs(leg["contact_plane_distance_m"]) < 1e-12


def test_bundled_biped_says_its_geometry_is_estimated(tmp_path: Path):
    summary, code = run_biped(scenario=load_scenario(SCENARIOS[0]), out_dir=tmp_path / "o",
                              plots=False)
    assert code == 0
    assert "lengths" in summary["geometry"]["estimated"]
    assert summary["geometry"]["source"].startswith("HWANG2023_ESTIMATED")

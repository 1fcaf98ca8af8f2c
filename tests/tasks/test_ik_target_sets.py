"""``ik:`` target sets (targets that name their frame, solved together; issue 25): the bundled
floating-base biped scenario, verified per frame by forward kinematics; a bad frame name is one
line with the scenario's line and the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "biped_floating_ik.yaml"


def test_bundled_biped_target_sets(tmp_path):
    rep = mechkin.run(SCENARIO)
    s = rep.summary
    assert s["status"] == "ok" and s["n_target_sets"] == 2 and s["floating_base"]
    mech = load_mechanism(ROOT / "mechanisms" / "biped_floating.xml")
    for rec in s["target_sets"]:
        q = np.array([rec["q"][n] for n in mech.joint_names])
        kin = forward_kinematics(mech, q[None])
        for frame, f in rec["frames"].items():
            T = kin.frames(mech, [mech.frame_index(frame)])[0, 0]
            w = np.array(f["weights"])
            d = (T[:3, 3] - f["target"]["xyz_m"])[w[:3] > 0]  # target axes = world here
            assert np.abs(d).max() < 1e-6, (rec["name"], frame)
        # the soles are flat on the ground: their z axes are the world's
        for sole in ("left_sole", "right_sole"):
            T = kin.frames(mech, [mech.frame_index(sole)])[0, 0]
            assert abs(T[2, 3]) < 1e-6 and abs(T[2, 2] - 1.0) < 1e-9
    assert rep.summary["target_sets"][0]["q"]["base_z"] > 0.5


def test_unknown_frame_in_a_target_set(tmp_path):
    text = SCENARIO.read_text().replace("frame: right_sole, xyz: [0.0, -0.12",
                                        "frame: right_foot_typo, xyz: [0.0, -0.12")
    text = text.replace("../mechanisms/", str(ROOT / "mechanisms") + "/")
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError) as exc:
        mechkin.run(p)
    (msg,) = exc.value.problems
    line = text.splitlines().index(next(x for x in text.splitlines() if "typo" in x)) + 1
    assert msg.startswith(f"{p}:{line}: ik.target_sets[0].targets[1].frame: unknown frame "
                          "'right_foot_typo'")

"""A joint sweep of a mechanism with a coupled joint (issue 25: "FK/IK/workspace/track all honour
it"): only the independent joints are swept, the coupled joint follows its master at every
sample, and the swept positions equal the forward kinematics of the same arm written without
the coupling (planar3r.yaml, q3 set to -q2 by hand)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mechkin
from mechkin.model.kinematics import forward_kinematics

ROOT = Path(__file__).resolve().parents[2]


def test_joint_sweep_of_a_coupled_arm(tmp_path):
    base = (ROOT / "mechanisms" / "planar3r.yaml").read_text()
    coupled = base.replace("independent: [q1, q2, q3]", "independent: [q1, q2]\ncouplings:\n"
                           "  - {joint: q3, master: q2, multiplier: -1.0, offset: 0}")
    assert coupled != base
    mp = tmp_path / "coupled.yaml"
    mp.write_text(coupled.replace("name: planar3r", "name: planar3r_coupled"))
    sp = tmp_path / "ws.yaml"
    sp.write_text(f"""name: coupled_ws
task: workspace
mechanism: {mp}
units: {{length: m, angle: deg}}
workspace: {{kind: joint_sweep, method: monte_carlo, samples: 300, seed: 3}}
outputs: {{csv: false, plots: false, mcap: false}}
""")
    rep = mechkin.run(sp)
    s = rep.summary
    assert s["status"] == "ok" and s["swept_joints"] == ["q1", "q2"]
    rec = rep.data.record
    ok = np.asarray(rec.reachable, dtype=bool)
    assert ok.sum() == 300
    q = np.asarray(rec.q)[ok]
    assert np.abs(q[:, 2] + q[:, 1]).max() < 1e-12  # q3 = -q2 at every sample
    assert np.ptp(q[:, 1]) > 1.0  # the master really was swept
    free = mechkin.load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
    q_free = np.column_stack([q[:, 0], q[:, 1], -q[:, 1]])
    hand = forward_kinematics(free, q_free).frames(free, [free.frame_index("hand")])[:, 0]
    assert np.abs(np.asarray(rec.position)[ok] - hand[:, :3, 3]).max() < 1e-12

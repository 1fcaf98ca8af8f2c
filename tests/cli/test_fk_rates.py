"""`mechkin fk` in motion: joint rates and accelerations of every joint and the end-effector
twist in fk.csv, checked against finite differences of the positions the same run wrote;
velocities on /joint_states; singularity classes per step."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from mechkin.io.csv_out import read_csv
from mechkin.records import Report
from mechkin.tasks import run_file

ROOT = Path(__file__).resolve().parents[2]


def _scenario(tmp_path: Path, name: str, fk: dict, mech: str) -> Path:
    d = {"name": name, "task": "fk", "mechanism": str(ROOT / "mechanisms" / mech),
         "units": {"length": "m", "angle": "rad"}, "fk": fk,
         "outputs": {"csv": True, "plots": False, "mcap": True}}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _fd(t, x):
    return np.gradient(x, t, edge_order=2)


def test_sinusoid_on_a_closed_chain_rates_match_differences(tmp_path):
    """Direct-drive arm (a parallelogram loop): analytic motion derivatives; the passive joints'
    rates and the end effector's velocity agree with differences of the written positions."""
    p = _scenario(tmp_path, "dd_wave", {
        "time": {"start": 0.0, "stop": 1.0, "step": 0.001},
        "motion": {"q1": {"type": "sinusoid", "offset": 0.1, "amplitude": 0.3, "frequency": 1.0},
                   "q2": {"type": "ramp", "from": 0.4, "to": 0.9},
                   "q3": {"type": "sinusoid", "offset": 0.5, "amplitude": 0.2,
                          "frequency": 0.5}}}, "kim1995_direct_drive.yaml")
    rep = run_file(p, "fk")
    assert isinstance(rep, Report) and rep.status == "ok"
    rep.write(tmp_path / "o", plots=False)
    c = read_csv(tmp_path / "o" / "fk.csv")
    t = c["t_s"]
    inner = slice(5, -5)
    for j in ("q1", "q2", "q3", "p_C", "p_R", "p_Q"):
        v = _fd(t, c[f"{j}_rad"])
        np.testing.assert_allclose(c[f"{j}_rad_s"][inner], v[inner], atol=2e-5)
        a = _fd(t, c[f"{j}_rad_s"])
        np.testing.assert_allclose(c[f"{j}_rad_s2"][inner], a[inner], atol=2e-3)
    for ax in "xyz":
        np.testing.assert_allclose(c[f"ee_v{ax}_m_s"][inner], _fd(t, c[f"ee_{ax}_m"])[inner],
                                   atol=2e-5)
        np.testing.assert_allclose(c[f"ee_a{ax}_m_s2"][inner],
                                   _fd(t, c[f"ee_v{ax}_m_s"])[inner], atol=2e-3)
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["singularity"]["counts"] == {"regular": len(t)}
    assert s["closure"]["max_condition"] > 1.5  # the true cond, not the old constant 1.0
    with open(tmp_path / "o" / "fk.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        vel = [[j.velocity for j in m.joints] for _, _, _, m in reader.iter_decoded_messages(
            topics=["/joint_states"])]
    np.testing.assert_allclose(np.array(vel)[:, 3], c["p_C_rad_s"], atol=1e-12)


def test_table_input_uses_a_c2_spline(tmp_path):
    """A table of samples of a cubic in time: the not-a-knot spline reproduces the cubic's
    derivatives exactly (PUMA 560, open chain)."""
    t = np.linspace(0.0, 2.0, 21)
    q = 0.1 + 0.2 * t - 0.3 * t**2 + 0.05 * t**3
    tab = {"t": t.tolist()}
    for i in range(1, 7):
        tab[f"q{i}"] = (q * i / 6 + 0.3).tolist()
    p = _scenario(tmp_path, "puma_table", {"table": tab}, "puma560.yaml")
    rep = run_file(p, "fk")
    c = rep.data.columns
    for i in range(1, 7):
        np.testing.assert_allclose(c[f"q{i}_rad_s"], (0.2 - 0.6 * t + 0.15 * t**2) * i / 6,
                                   atol=1e-10)
        np.testing.assert_allclose(c[f"q{i}_rad_s2"], (-0.6 + 0.3 * t) * i / 6, atol=1e-9)


def test_wrist_singularity_is_named(tmp_path):
    """PUMA 560 with q5 crossing 0: an inverse-kinematic singularity, reported per step, in
    the summary and as a warning line."""
    p = _scenario(tmp_path, "puma_wrist", {
        "time": {"start": 0.0, "stop": 1.0, "step": 0.1},
        "motion": {"q1": {"type": "constant", "value": 0.2},
                   "q2": {"type": "constant", "value": -0.5},
                   "q3": {"type": "constant", "value": 0.8},
                   "q4": {"type": "constant", "value": 0.3},
                   "q5": {"type": "ramp", "from": -0.5, "to": 0.5},
                   "q6": {"type": "constant", "value": 0.1}}}, "puma560.yaml")
    rep = run_file(p, "fk")
    labels = rep.data.columns["singularity"]
    assert labels[5] == "inverse-kinematic singularity"  # q5 = 0 at t = 0.5
    assert labels[0] == "regular"
    assert rep.summary["singularity"]["first_singular_step"] == 5
    assert any("inverse-kinematic singularity" in m and "step 5" in m for m in rep.messages)

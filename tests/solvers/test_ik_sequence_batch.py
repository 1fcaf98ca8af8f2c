"""The ik task solves many targets of an open chain that decomposes in one compiled loop
(:func:`mechkin.tasks.ik_analytic.solve_sequence_batched`) without ``batch: true``: the same
answers, statuses, errors, warm-start guesses and ik.csv as one target at a time, with targets
beyond reach and without an analytic solution in the sequence (solved one by one there, the
lm answer of ``auto`` becoming the next guess)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.config.scenario import load_scenario
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.ik import IkOptions
from mechkin.tasks import ik as ik_task
from mechkin.tasks import ik_analytic

ROOT = Path(__file__).resolve().parents[2]


def _scenario(tmp_path: Path, name: str, method: str, warm: bool) -> Path:
    p = tmp_path / f"{name}_{method}_{warm}.yaml"
    p.write_text(f"""name: seq_{name}
task: ik
mechanism: {ROOT / "mechanisms" / f"{name}.yaml"}
units: {{length: m, angle: deg}}
ik:
  method: {method}
  warm_start: {str(warm).lower()}
  restarts: 1
  targets:
    - {{name: far, xyz: [40, 0, 0], rpy: [0, 0, 0]}}
    - {{name: beyond_arm, xyz: [0.2, 0.1, 1.3], rpy: [0, 0, 0]}}
  random_targets: {{count: 240, seed: 4}}
outputs: {{csv: true, plots: false, mcap: false}}
""")
    return p


@pytest.mark.parametrize("name,method,warm", [("ur5", "auto", True), ("puma560", "analytic", True),
                                              ("ur5", "analytic", False)])
def test_batched_sequence_equals_one_by_one(tmp_path, monkeypatch, name, method, warm):
    from mechkin.solvers.ik import accel

    # lm (auto's fallback) pinned to numpy: its automatic back end depends on the work the
    # process has done, and the two back ends agree to round-off, not bit for bit
    monkeypatch.setenv("MECHKIN_JIT", "0")
    accel.reset_job()
    sc = load_scenario(_scenario(tmp_path, name, method, warm))
    calls = []
    real = ik_analytic.solve_sequence_batched

    def spy(*a, **k):
        out = real(*a, **k)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(ik_task, "solve_sequence_batched", spy)
    batched = ik_task.run(sc, progress=False)
    assert calls == [True]  # no batch: true, yet the compiled sequence ran
    monkeypatch.setattr(ik_analytic, "BATCH_MIN", 10**9)
    monkeypatch.setattr(ik_task, "solve_sequence_batched", real)
    single = ik_task.run(sc, progress=False)
    a, b = batched.summary, single.summary
    assert a["counts"] == b["counts"] and a["methods_used"] == b["methods_used"]
    assert a["counts"].get("ok", 0) >= 240 and a["status"] != "ok"  # far, beyond_arm fail
    for ta, tb in zip(a["targets"], b["targets"], strict=True):
        for key in ("status", "q", "q_v", "position_error", "orientation_error", "f",
                    "joints_at_limit", "closure_residual", "end_effector"):
            assert ta[key] == tb[key], (ta["name"], key)
    out_a, out_b = tmp_path / "a", tmp_path / "b"
    batched.write(out_a, plots=False)
    single.write(out_b, plots=False)
    assert (out_a / "ik.csv").read_bytes() == (out_b / "ik.csv").read_bytes()


def test_warm_guesses_follow_the_previous_answer():
    """Along a path of nearby poses the warm sequence stays on the branch of the first answer
    (each target's answer is the solution nearest the previous one) and the guesses it reports
    are those answers; the same targets from the initial guess each (warm off) jump to the
    branch nearest it."""
    mech = load_mechanism(ROOT / "mechanisms" / "ur5.yaml")
    t = np.linspace(0.0, 1.0, 300)[:, None]
    q_path = np.array([0.4, -1.0, 1.2, -1.5, -1.2, 0.3]) + t * np.array([1.5, 0.3, -0.4, 0.5,
                                                                          0.6, 0.8])
    T = frame_poses(mech, q_path, [mech.end_effector])[:, 0]
    W = np.ones((300, 6))
    far = np.zeros(300, dtype=bool)
    res, guesses = ik_analytic.solve_sequence_batched(
        mech, T, W, far, "analytic", IkOptions(), q_path[0] + 0.01, mech.home[mech.dependent],
        True)
    q = np.array([r.q_v for r in res])
    assert all(r.ok for r in res)
    assert np.abs(q - q_path).max() < 1e-9  # the path's own branch, every step
    assert np.array_equal(guesses[0][0], q_path[0] + 0.01)
    assert all(np.array_equal(guesses[i][0], q[i - 1]) for i in range(1, 300))
    from mechkin.solvers.ik.analytic.classify import analytic_chain
    from mechkin.solvers.ik.analytic.solutions import analytic_batch

    other = analytic_batch(mech, analytic_chain(mech), T[:1], q_path[0]).q_v[0, 1]  # 2nd branch
    assert np.abs(other - q_path[0]).max() > 0.1
    cold, _ = ik_analytic.solve_sequence_batched(
        mech, T, W, far, "analytic", IkOptions(), other, mech.home[mech.dependent], False)
    assert np.abs(np.array([r.q_v for r in cold]) - q_path).max() > 0.1  # another branch


def test_few_targets_or_a_zero_weight_go_one_by_one():
    mech = load_mechanism(ROOT / "mechanisms" / "ur5.yaml")
    T = np.repeat(np.eye(4)[None], 300, axis=0)
    far = np.zeros(300, dtype=bool)
    args = (IkOptions(), mech.home[mech.independent], mech.home[mech.dependent], True)
    assert ik_analytic.solve_sequence_batched(mech, T[:10], np.ones((10, 6)), far[:10],
                                              "auto", *args) is None
    W = np.ones((300, 6))
    W[5, 3] = 0.0
    assert ik_analytic.solve_sequence_batched(mech, T, W, far, "auto", *args) is None
    assert ik_analytic.solve_sequence_batched(mech, T, np.ones((300, 6)), far, "lm",
                                              *args) is None


@pytest.mark.parametrize("method,warm", [("auto", True), ("analytic", False)])
def test_stewart_legs_sequence_equals_one_by_one(tmp_path, monkeypatch, method, warm):
    """A Stewart platform (every leg a compiled U-P-S arm): the legs' sequences in compiled
    loops give the same joints (bit for bit), statuses and ik.csv as the per-target legs
    route, with a target beyond reach and one beyond the strokes in the sequence."""
    from mechkin.solvers.ik import accel

    monkeypatch.setenv("MECHKIN_JIT", "0")
    accel.reset_job()
    p = tmp_path / f"stewart_{method}_{warm}.yaml"
    p.write_text(f"""name: seq_stewart
task: ik
mechanism: {ROOT / "mechanisms" / "kim1995_stewart.yaml"}
units: {{length: m, angle: deg}}
ik:
  method: {method}
  warm_start: {str(warm).lower()}
  restarts: 1
  targets:
    - {{name: far, xyz: [400, 0, 0], rpy: [0, 0, 90]}}
    - {{name: beyond_strokes, xyz: [0, 0, 30], rpy: [0, 0, 90]}}
  random_targets: {{count: 220, seed: 5}}
outputs: {{csv: true, plots: false, mcap: false}}
""")
    sc = load_scenario(p)
    calls = []
    real = ik_analytic._legs_sequence_batched

    def spy(*a, **k):
        out = real(*a, **k)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(ik_analytic, "_legs_sequence_batched", spy)
    monkeypatch.setattr(ik_analytic, "BATCH_MIN", 20)  # 39 of the 220 random leg lengths assemble
    batched = ik_task.run(sc, progress=False)
    assert calls == [True]
    monkeypatch.setattr(ik_analytic, "BATCH_MIN", 10**9)
    single = ik_task.run(sc, progress=False)
    a, b = batched.summary, single.summary
    assert a["counts"] == b["counts"] and a["methods_used"] == b["methods_used"]
    assert "analytic legs" in a["methods_used"] and a["counts"].get("ok", 0) >= 35
    assert a["targets"][0]["status"] != "ok" and a["targets"][1]["status"] != "ok"
    for ta, tb in zip(a["targets"], b["targets"], strict=True):
        for key in ("status", "q", "q_v", "position_error", "orientation_error",
                    "closure_residual", "end_effector"):
            assert ta[key] == tb[key], (ta["name"], key)
    out_a, out_b = tmp_path / "a", tmp_path / "b"
    batched.write(out_a, plots=False)
    single.write(out_b, plots=False)
    assert (out_a / "ik.csv").read_bytes() == (out_b / "ik.csv").read_bytes()


def test_warmup_compiles_the_sequence_signature_the_task_uses():
    """``mechkin warmup`` lists the sequence kernel and compiles it with the types the ik task
    calls it with (no second compilation on the first long run)."""
    from mechkin.solvers.ik import warm
    from mechkin.solvers.ik.analytic import sequence

    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    assert "sequence.solve_sequence_into" in [n for n, _ in warm.kernels_for(mech)]
    warm._analytic_runner("sequence.solve_sequence_into")()
    if not hasattr(sequence.solve_sequence_into, "signatures"):
        pytest.skip("compiled kernels off (MECHKIN_JIT=0 at import)")
    sigs = list(sequence.solve_sequence_into.signatures)
    T = np.repeat(frame_poses(mech, mech.home[None], [mech.end_effector])[:, 0], 250, axis=0)
    for warm_start in (True, False):
        ik_analytic.solve_sequence_batched(mech, T, np.ones((250, 6)), np.zeros(250, bool),
                                           "auto", IkOptions(), mech.home[mech.independent],
                                           mech.home[mech.dependent], warm_start)
    assert list(sequence.solve_sequence_into.signatures) == sigs


def test_analytic_all_records_equal_the_branches():
    """``solutions: all`` of an open chain (analytic_all, records built on arrays): each
    target's solutions are its analytic branches (rows [:count]), q the home configuration with
    the independent joints set, errors and distances the batch's."""
    from mechkin.solvers.ik.analytic.classify import analytic_chain
    from mechkin.solvers.ik.analytic.solutions import analytic_batch

    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    iv = mech.independent
    q = np.random.default_rng(6).uniform(mech.lower[iv], mech.upper[iv], (40, 6))
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    refs = q + 0.01
    out = ik_analytic.analytic_all(mech, T, refs)
    b = analytic_batch(mech, analytic_chain(mech), T, refs)
    assert len(out) == 40 and sum(a.count for a in out) > 40
    for i, a in enumerate(out):
        n = int(b.count[i])
        assert a.count == n and a.complete and a.source == "analytic"
        want = np.repeat(np.where(np.isfinite(mech.home), mech.home, 0.0)[None], n, axis=0)
        want[:, iv] = b.q_v[i, :n]
        assert np.array_equal(a.q, want) and np.array_equal(a.q_v, b.q_v[i, :n])
        assert np.array_equal(a.position_error, b.position_error[i, :n])
        assert np.array_equal(a.orientation_error, b.orientation_error[i, :n])
        assert np.array_equal(a.distance, b.distance[i, :n])
        assert min(np.abs((s - q[i] + np.pi) % (2 * np.pi) - np.pi).max() for s in a.q_v) < 1e-9


def test_stewart_batch_true_equals_the_per_target_batch(tmp_path, monkeypatch):
    """``batch: true`` on a Stewart platform with ``method: analytic``: each leg's targets in
    one compiled loop from the initial guess (before, the task fell back to the batched lm),
    the same joints (bit for bit) and statuses as the per-target legs route from the initial
    guess (``batch: false, warm_start: false``, one by one)."""
    p = tmp_path / "stewart_batch.yaml"
    p.write_text(f"""name: batch_stewart
task: ik
mechanism: {ROOT / "mechanisms" / "kim1995_stewart.yaml"}
units: {{length: m, angle: deg}}
ik:
  method: analytic
  batch: true
  random_targets: {{count: 120, seed: 7}}
outputs: {{csv: false, plots: false, mcap: false}}
""")
    sc = load_scenario(p)
    calls = []
    real = ik_analytic._legs_sequence_batched

    def spy(*a, **k):
        out = real(*a, **k)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(ik_analytic, "_legs_sequence_batched", spy)
    new = ik_task.run(sc, progress=False).summary
    assert calls == [True]
    monkeypatch.setattr(ik_analytic, "_legs_sequence_batched", lambda *a, **k: None)
    monkeypatch.setattr(ik_analytic, "BATCH_MIN", 10**9)
    p.write_text(p.read_text().replace("batch: true", "batch: false\n  warm_start: false"))
    old = ik_task.run(load_scenario(p), progress=False).summary
    assert new["counts"] == old["counts"] and new["counts"].get("ok", 0) >= 15
    assert new["methods_used"] == old["methods_used"] == ["analytic legs"]
    for ta, tb in zip(new["targets"], old["targets"], strict=True):
        assert ta["status"] == tb["status"] and ta["q"] == tb["q"], ta["name"]

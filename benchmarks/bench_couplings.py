"""IK of coupled open chains (joint couplings, URDF ``<mimic>``) against the same chains with
the coupling removed: ``python benchmarks/bench_couplings.py [--n 30] [--rounds 3]``.

Mechanisms: example-robot-data's Panda URDF (mimic finger; {E} the hand TCP, and {E} on the
mimic finger ``panda_rightfinger``) and tests/data/gripper_mimic.yaml (a 7R arm, one coupling on
the arm, a parallel gripper whose mimic finger carries {E}). "uncoupled": the same file with the
couplings removed (the coupled joints become independent). Targets: FK of seeded random joints
of the coupled mechanism within its limits (reachable by both).

Modes, each per target: ``single`` = ``solve_ik`` without a guess (codebook start where the
chain has one), ``restarts=50`` (the ``mechkin ik`` default); ``norestart`` = the same without
restarts (the success of the first start alone); ``api`` = ``mechkin.ik`` with its
defaults (method auto, guess home, restarts 50); ``batch`` = ``solve_ik_batch`` of all targets,
restarts 50 (time per target). Success: verified by FK at 1e-6 m and 1e-6 rad. Rounds are
interleaved (coupled, uncoupled, coupled, ...); medians over rounds. One-time costs (codebook,
kernel load) are paid in a warm-up and not counted. Never a timed assertion.

Measured 2026-12-03 (2 busy cores; ``MECHKIN_JIT=1``; three processes per side, before and
after interleaved, ``--n 20 --rounds 1``, medians; "before" = mechkin at eebc0c7, where coupled
chains took the numpy loop-closure lm and no codebook), ms per target, coupled chain:

================== ========= ====== ===== ======== ================= =====================
case               mode      before after speed-up uncoupled (after) success b / a (uncpl)
================== ========= ====== ===== ======== ================= =====================
panda hand_tcp     single     261.0   7.2     36.2               5.9 100 / 100 (100) %
panda hand_tcp     norestart  302.7   4.5     67.0               3.9  65 /  85  (75) %
panda hand_tcp     api        211.5   9.6     22.1               6.5 100 / 100 (100) %
panda hand_tcp     batch      306.4   2.6    118.3               1.7 100 / 100 (100) %
panda rightfinger  single     286.6   7.5     38.3               7.5 100 / 100 (100) %
panda rightfinger  norestart  349.2   7.1     49.0               5.2  80 /  90  (75) %
panda rightfinger  batch      138.7   1.2    111.9               1.8 100 / 100 (100) %
gripper tip        single     564.6   6.2     91.1               5.6 100 / 100 (100) %
gripper tip        norestart  278.3   4.1     68.7               3.0  50 /  75  (80) %
gripper tip        api        413.4   3.2    129.6               2.5 100 / 100 (100) %
gripper tip        batch      204.3   1.1    179.2               1.1 100 / 100 (100) %
================== ========= ====== ===== ======== ================= =====================

``MECHKIN_JIT=0`` (numpy lm; one process per side, not interleaved, ``--n 10 --rounds 2 --modes
single,batch``): coupled before 97-252 ms per target, after 2.4-26 ms (8-61x), 0.7-1.3x the
uncoupled chain's time.
"""

from __future__ import annotations

import argparse
import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import mechkin
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, pose_errors, solve_ik, solve_ik_batch

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-6


def _erd_panda() -> Path:
    import importlib.metadata

    dist = importlib.metadata.distribution("example-robot-data")
    f = next(f for f in dist.files or [] if str(f).endswith("panda_description/urdf/panda.urdf"))
    return Path(dist.locate_file(f))


def variants(tmp: Path) -> list[tuple[str, object, object, str | None]]:
    """(name, coupled mechanism, uncoupled mechanism, {E} frame name or None)."""
    urdf = _erd_panda().read_text()
    a, b = tmp / "panda.urdf", tmp / "panda_nomimic.urdf"
    a.write_text(urdf)
    b.write_text(re.sub(r"<mimic[^>]*/>", "", urdf))
    y = (ROOT / "tests" / "data" / "gripper_mimic.yaml").read_text()
    g1, g2 = tmp / "gripper.yaml", tmp / "gripper_free.yaml"
    g1.write_text(y)
    g2.write_text(re.sub(r"couplings:\n(  - .*\n)+independent: .*\n", "", y))
    pa, pb = load_mechanism(a), load_mechanism(b)
    ga, gb = load_mechanism(g1), load_mechanism(g2)
    return [("panda hand_tcp", pa, pb, None), ("panda rightfinger", pa, pb, "panda_rightfinger"),
            ("gripper tip", ga, gb, None)]


def targets(mech, frame: int, n: int, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    qv = rng.uniform(mech.lower[mech.independent], mech.upper[mech.independent],
                     size=(n, len(mech.independent)))
    res = mechkin.fk(mech, qv, frames=[mech.frame_names[frame]])
    return res.poses[mech.frame_names[frame]]


def ok(mech, frame, q, T) -> np.ndarray:
    T_E = forward_kinematics(mech, np.atleast_2d(q)).frames(mech, [frame])[:, 0]
    pe, oe = pose_errors(T_E, np.asarray(T).reshape(-1, 4, 4))
    return (pe < TOL) & (oe < TOL)


def run_mode(mode, mech, frame, Ts):
    opts = IkOptions(restarts=0 if mode == "norestart" else 50, tol_pos=TOL, tol_ori=TOL)
    t0 = time.perf_counter()
    if mode in ("single", "norestart"):
        qs = [solve_ik(mech, T, options=opts, frame=frame).q for T in Ts]
    elif mode == "api":
        qs = [mechkin.ik(mech, T)[0].q for T in Ts]
    else:
        qs = list(solve_ik_batch(mech, Ts, options=opts, frame=frame).q)
    dt = (time.perf_counter() - t0) / len(Ts)
    succ = float(np.mean([ok(mech, frame, q, T)[0] for q, T in zip(qs, Ts, strict=True)]))
    return dt, succ


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--modes", default="single,norestart,api,batch")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for name, mc, mu, fname in variants(Path(d)):
            fc = mc.end_effector if fname is None else mc.frame_index(fname)
            fu = mu.end_effector if fname is None else mu.frame_index(fname)
            Ts = targets(mc, fc, args.n)
            for mode in args.modes.split(","):
                if mode == "api" and fname is not None:
                    continue  # mechkin.ik solves the mechanism's own end effector
                for m, f in ((mc, fc), (mu, fu)):  # warm-up: codebook, kernels
                    run_mode(mode, m, f, Ts[:2])
                res = {"coupled": [], "uncoupled": []}
                for _ in range(args.rounds):
                    res["coupled"].append(run_mode(mode, mc, fc, Ts))
                    res["uncoupled"].append(run_mode(mode, mu, fu, Ts))
                line = [f"{name:18s} {mode:6s}"]
                for k, v in res.items():
                    t = statistics.median(x[0] for x in v) * 1e3
                    s = statistics.median(x[1] for x in v) * 100
                    line.append(f"{k}: {t:8.2f} ms/target {s:5.1f} %")
                tc = statistics.median(x[0] for x in res["coupled"])
                tu = statistics.median(x[0] for x in res["uncoupled"])
                line.append(f"coupled/uncoupled {tc / tu:5.2f}")
                print("  ".join(line), flush=True)


if __name__ == "__main__":
    main()

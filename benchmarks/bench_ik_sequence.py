"""The ik task's compiled sequence (issue 26 item 4) against one target at a time.

    python benchmarks/bench_ik_sequence.py [--rounds 5] [--targets 10000] [--stewart 1000]

For UR5 and PUMA 560 (``--targets`` seeded random reachable poses, method auto, warm-started
and not) and kim1995's Stewart platform (``--stewart`` poses near home): the time of the ik
task's solve one target at a time (:func:`mechkin.tasks.ik_solve.solve_sequence`) and by the
compiled sequence (:func:`mechkin.tasks.ik_analytic.solve_sequence_batched`), and whether
their answers are identical (joints bit for bit, statuses). Rounds interleave the two; the
table gives the median CPU time (``time.process_time``: on a shared machine wall time mostly
measures the other jobs) and the median of the per-round ratios.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics, frame_poses
from mechkin.solvers.ik import IkOptions
from mechkin.tasks.ik_analytic import solve_sequence_batched
from mechkin.tasks.ik_solve import solve_sequence

ROOT = Path(__file__).resolve().parents[1]


def _poses(name: str, k: int) -> tuple[object, np.ndarray]:
    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    iv = mech.independent
    rng = np.random.default_rng(1)
    if not mech.cuts:
        q = rng.uniform(mech.lower[iv], mech.upper[iv], (k, len(iv)))
        return mech, frame_poses(mech, q, [mech.end_effector])[:, 0]
    qv = mech.home[iv] + rng.uniform(-1.0, 1.0, (k, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (k, len(mech.dependent))).copy())
    return mech, forward_kinematics(mech, res.q[res.ok]).frames(mech, [mech.end_effector])[:, 0]


def row(name: str, k: int, warm: bool, rounds: int) -> str:
    mech, T = _poses(name, k)
    m = len(T)
    W, far, o = np.ones((m, 6)), np.zeros(m, dtype=bool), IkOptions()
    qv0, qw0 = mech.home[mech.independent].copy(), mech.home[mech.dependent].copy()
    solve_sequence_batched(mech, T[:300], W[:300], far[:300], "auto", o, qv0, qw0, warm)
    one, seq, ratio = [], [], []
    for _ in range(rounds):
        t = time.process_time()
        ra, _, _ = solve_sequence(mech, T, W, far, "auto", None, o, qv0, qw0, warm)
        one.append(time.process_time() - t)
        t = time.process_time()
        rb, _ = solve_sequence_batched(mech, T, W, far, "auto", o, qv0, qw0, warm)
        seq.append(time.process_time() - t)
        ratio.append(one[-1] / seq[-1])
    same = all(np.array_equal(a.q, b.q) and a.status == b.status for a, b in zip(ra, rb,
                                                                                 strict=True))
    a, b = statistics.median(one), statistics.median(seq)
    return (f"| {name} | {m} | {warm} | {a:.3f} s ({a / m * 1e6:.1f} us) | {b:.3f} s "
            f"({b / m * 1e6:.1f} us) | {statistics.median(ratio):.2f} "
            f"({min(ratio):.2f}-{max(ratio):.2f}) | {same} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--targets", type=int, default=10000)
    ap.add_argument("--stewart", type=int, default=1000)
    a = ap.parse_args()
    print("| mechanism | targets | warm start | one by one (per target) | compiled sequence "
          "(per target) | speedup (range) | identical |")
    print("|---|---|---|---|---|---|---|")
    for name, k in (("ur5", a.targets), ("puma560", a.targets), ("kim1995_stewart", a.stewart)):
        for warm in (True, False):
            print(row(name, k, warm, a.rounds), flush=True)


if __name__ == "__main__":
    main()

"""Forward-kinematics benchmarks (run on demand: ``python benchmarks/bench_fk.py``).

1. Batched FK of the PUMA 560: poses per second for 10,000 random configurations in one call.
2. Closed-chain FK of the kim1995 Stewart platform along a 1000-step leg-length trajectory:
   time per step with warm starts (continuation), Newton iterations per step.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from mechkin.model import load_mechanism
from mechkin.model.closure import ClosureStatus, solve_trajectory
from mechkin.model.kinematics import forward_kinematics, frame_poses

ROOT = Path(__file__).resolve().parents[1]


def bench_puma(m: int = 10_000, repeat: int = 20) -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    qs = np.random.default_rng(0).uniform(-np.pi, np.pi, size=(m, mech.n))
    frame_poses(mech, qs, [mech.end_effector])
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        frame_poses(mech, qs, [mech.end_effector])
        ts.append(time.perf_counter() - t0)
    best, med = min(ts), float(np.median(ts))
    print(f"PUMA 560 batched FK, {m} configurations: median {med * 1e3:.2f} ms "
          f"({m / med:,.0f} poses/s), best {best * 1e3:.2f} ms ({m / best:,.0f} poses/s)")
    t0 = time.perf_counter()
    for k in range(1000):
        forward_kinematics(mech, qs[k : k + 1])
    per = (time.perf_counter() - t0) / 1000
    print(f"PUMA 560 single-configuration FK (all links): {per * 1e6:.1f} us per call")


def bench_stewart(steps: int = 1000) -> None:
    path = ROOT / "mechanisms" / "kim1995_stewart.yaml"
    if not path.exists():
        print("kim1995_stewart.yaml missing; skipped")
        return
    mech = load_mechanism(path)
    # a smooth leg-length trajectory around home: each leg +-5 % sinusoidally
    q0v = mech.home[mech.independent]
    t = np.linspace(0.0, 1.0, steps)
    phase = np.arange(len(q0v))
    qv = q0v * (1 + 0.05 * np.sin(2 * np.pi * t[:, None] + phase))
    solve_trajectory(mech, qv[:20], mech.home[mech.dependent])
    for chunk in (1, 32):
        t0 = time.perf_counter()
        res = solve_trajectory(mech, qv, mech.home[mech.dependent], chunk=chunk)
        total = time.perf_counter() - t0
        ok = sum(s is ClosureStatus.CONVERGED for s in res.status)
        print(f"Stewart solve_trajectory chunk={chunk}: {ok}/{steps} converged, "
              f"{total / steps * 1e3:.3f} ms per step (amortized), Newton iterations per step "
              f"mean {res.iterations.mean():.2f} max {res.iterations.max()}, max ||phi|| "
              f"{res.residual.max():.2e}")
    # per-step timing
    per = []
    guess = mech.home[mech.dependent][None]
    from mechkin.model.closure import solve_closure

    for k in range(steps):
        t1 = time.perf_counter()
        r = solve_closure(mech, qv[k : k + 1], guess)
        per.append(time.perf_counter() - t1)
        guess = r.q[:, mech.dependent]
    print(f"Stewart single-step solve_closure warm-started from the previous step: median "
          f"{np.median(per) * 1e3:.3f} ms per step")


if __name__ == "__main__":
    bench_puma()
    bench_stewart()

"""Closed-chain inverse dynamics per configuration: python benchmarks/bench_closed_rnea.py [reps].

:class:`mechkin.solvers.dynamics.closed_chain.ClosedChainDynamics` (tree Newton-Euler projected on
the
independent joints, the dependent rates and accelerations from the closure, kim1995 Eq. (3)-(4))
on the kim1995 direct-drive arm (6 joints, 1 cut) and Stewart platform (36 joints, 5 cuts),
against the open-chain recursion :class:`mechkin.solvers.dynamics.open_chain.SerialChainDynamics`
of the
PUMA 560 (6 joints) as the reference, and the same tree recursion on the PUMA (no closure).

Each case is timed as the DP calls it: one batched ``inverse_dynamics(q, qd, qdd)`` over m
configurations (m = 1 and m = 101, the DP's N1 + 1 stages at N1 = 100), a fresh model per
batch so the per-configuration cache does not hide the closure work; the figure is the best of
``reps`` wall times divided by m [us per configuration]. The configurations are assembled
(random independent joints near home, the loops closed) before timing; rates and accelerations
random.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.solvers.dynamics.closed_chain import ClosedChainDynamics
from mechkin.solvers.dynamics.from_mechanism import dynamics_from_mechanism

ROOT = Path(__file__).resolve().parents[1]


def best_of(fn, repeat: int) -> float:
    """Best wall time [s] of ``repeat`` calls (as benchmarks/timing.py)."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def _assembled(mech, m: int, rng: np.random.Generator) -> np.ndarray:
    iv, iw = mech.independent, mech.dependent
    if not len(iw):
        return rng.uniform(-1.0, 1.0, (m, mech.n))
    home = mech.home[None]
    scale = np.where(mech.s[iv] == 1, 0.3, 0.1)
    qv = home[:, iv] + rng.uniform(-1.0, 1.0, (m, len(iv))) * scale
    res = solve_closure(mech, qv, np.broadcast_to(home[:, iw], (m, len(iw))))
    assert res.ok.all()
    return res.q


def main(reps: int = 20) -> None:
    rng = np.random.default_rng(0)
    rows = []
    for name in ("puma560", "kim1995_direct_drive", "kim1995_stewart"):
        mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
        for m in (1, 101):
            q = _assembled(mech, m, rng)
            qd, qdd = rng.normal(size=q.shape), rng.normal(size=q.shape)
            args = (q, qd, qdd)

            def tree(mech=mech, args=args):
                return ClosedChainDynamics(mech).inverse_dynamics(*args)

            cases = [("tree RNEA + projection", tree)]
            if not mech.is_closed:
                serial = dynamics_from_mechanism(mech)

                def ser(s=serial, args=args):
                    return s.inverse_dynamics(*args)

                cases.insert(0, ("serial RNEA", ser))
            for label, fn in cases:
                fn()  # warm-up
                t = best_of(fn, reps)
                rows.append((name, mech.n, len(mech.independent), m, label, 1e6 * t / m))
    print(f"{'mechanism':22s} {'n':>3s} {'n_v':>3s} {'m':>4s}  {'model':24s} {'us/config':>10s}")
    for name, n, nv, m, label, us in rows:
        print(f"{name:22s} {n:3d} {nv:3d} {m:4d}  {label:24s} {us:10.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)

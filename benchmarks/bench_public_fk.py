"""Public single FK vs Pinocchio, interleaved in one process: python benchmarks/bench_public_fk.py

``mechkin.Solver(mech).pose(q)``, ``Solver.fk(q)`` and ``mechkin.fk(mech, q)`` against
Pinocchio's ``forwardKinematics`` (alone, and with the flange pose read out as an array) on the
PUMA 560 (tests/data/puma560.urdf), 7 rounds of 5,000 calls each, tools interleaved within a
round; prints the median time per call and the median of the paired ratios. ``--jit`` loads
the compiled FK kernel first (``Solver(mech, compiled=True)``). Pinocchio is a bench extra.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import mechkin

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    mech = mechkin.load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q = np.full(6, 0.3)
    sol = mechkin.Solver(mech, compiled="--jit" in sys.argv)
    model = pin.buildModelFromUrdf(str(ROOT / "tests" / "data" / "puma560.urdf"))
    data = model.createData()
    calls = {
        "pinocchio forwardKinematics": lambda: pin.forwardKinematics(model, data, q),
        "pinocchio + oMi[6].homogeneous": lambda: (pin.forwardKinematics(model, data, q),
                                                   data.oMi[6].homogeneous),
        "Solver.pose(q)": lambda: sol.pose(q),
        "Solver.fk(q)": lambda: sol.fk(q),
        "mechkin.fk(mech, q)": lambda: mechkin.fk(mech, q),
    }
    times: dict[str, list[float]] = {k: [] for k in calls}
    n = 5000
    for _ in range(7):
        for k, f in calls.items():
            f()
            t0 = time.perf_counter()
            for _ in range(n):
                f()
            times[k].append((time.perf_counter() - t0) / n * 1e6)
    ref = times["pinocchio forwardKinematics"]
    for k, v in times.items():
        r = statistics.median(a / b for a, b in zip(v, ref, strict=True))
        print(f"{k:32s} {statistics.median(v):8.2f} us   / pinocchio FK {r:6.2f}")


if __name__ == "__main__":
    main()

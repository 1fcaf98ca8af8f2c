"""Track end to end, path IK in blocks vs point by point: python benchmarks/bench_path_ik_blocks.py

``mechkin.run`` of the two time-optimal TOPP-RA scenarios (1,001 path points) with
``HandPathIK.BLOCK = 1`` (the point-by-point continuation) and the default blocks, interleaved,
5 paired rounds; prints the medians, the median of the paired ratios and both durations.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import mechkin
from mechkin.solvers.track import path_ik

ROOT = Path(__file__).resolve().parents[1]
BLOCK = path_ik.HandPathIK.BLOCK


def main() -> None:
    for name in ("park_time_optimal_torque_topp", "park_time_optimal_full_topp"):
        sc = mechkin.load_scenario(ROOT / "scenarios" / f"{name}.yaml")
        mechkin.run(sc)
        serial, blocks = [], []
        for _ in range(5):
            path_ik.HandPathIK.BLOCK = 1
            t0 = time.perf_counter()
            a = mechkin.run(sc)
            serial.append(time.perf_counter() - t0)
            path_ik.HandPathIK.BLOCK = BLOCK
            t0 = time.perf_counter()
            b = mechkin.run(sc)
            blocks.append(time.perf_counter() - t0)
        r = statistics.median(x / y for x, y in zip(blocks, serial, strict=True))
        print(f"{name}: point by point {statistics.median(serial):.3f} s, blocks "
              f"{statistics.median(blocks):.3f} s, ratio {r:.3f}; durations "
              f"{a.summary['duration_s']!r} / {b.summary['duration_s']!r} s")


if __name__ == "__main__":
    main()

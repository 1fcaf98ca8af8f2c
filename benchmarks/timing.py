"""Timing helper and scenarios shared by the benchmark scripts (run them as ``python
benchmarks/NAME.py``)."""

from __future__ import annotations

import time
from collections.abc import Callable


def best_of(fn: Callable[[], object], repeat: int) -> float:
    """Best wall time [s] of ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


#: The 100,000-step PUMA 560 fk scenario of the speed table and benchmarks/bench_cli_fk.py
#: (``mech``: the mechanism file, ``stop``: the end time, ``table``: outputs.table).
FK100K = """name: puma_fk_100k
task: fk
mechanism: {mech}
units: {{length: m, angle: deg}}
fk:
  time: {{start: 0, stop: {stop:.3f}, step: 0.001}}
  motion:
    q1: {{type: sinusoid, amplitude: 60, frequency: 0.25}}
    q2: {{type: sinusoid, offset: 90, amplitude: 20, frequency: 0.5}}
    q3: {{type: sinusoid, offset: -90, amplitude: 30, frequency: 0.5, phase: 90}}
    q4: {{type: ramp, from: 0, to: 90}}
    q5: {{type: sinusoid, amplitude: 45, frequency: 1}}
    q6: {{type: constant, value: 0}}
outputs: {{csv: true, plots: false, mcap: false, table: {table}}}
"""

"""Time every track figure: ``python benchmarks/bench_track_plots.py [scenario ...]``.

Builds the figures of each bundled scenario (default ``puma560_track_line`` and
``park_cases_overlay``) with :func:`mechkin.io.track_out.figures` and prints, per figure, the
CPU and wall time of ``savefig`` (best of 3; the CPU time is the steadier number on a shared
machine) and whether anything drawn lies outside the figure.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from mechkin.api import run
from mechkin.io.track_out import figures

ROOT = Path(__file__).resolve().parents[1]


def main(names: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            rec = run(ROOT / "scenarios" / f"{name}.yaml").data
            print(f"{name}:")
            for fname, fig in figures(rec).items():
                cpu, wall = [], []
                for _ in range(3):
                    c0, w0 = time.process_time(), time.perf_counter()
                    fig.savefig(Path(tmp) / fname, dpi=110, format="png")
                    cpu.append(time.process_time() - c0)
                    wall.append(time.perf_counter() - w0)
                box = fig.get_tightbbox(fig.canvas.get_renderer())
                w, h = fig.get_size_inches()
                inside = box.x0 >= -0.01 and box.y0 >= -0.01 and box.x1 <= w + 0.01 \
                    and box.y1 <= h + 0.01
                print(f"  {fname:28s} cpu {min(cpu):.3f} s  wall {min(wall):.3f} s  "
                      f"{'inside' if inside else 'CLIPPED'}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["puma560_track_line", "park_cases_overlay"])

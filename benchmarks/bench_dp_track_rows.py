"""The time-optimal DP track rows of the README speed table alone (issue 29):
python benchmarks/bench_dp_track_rows.py [rounds].

``speed_rows.track_rows`` (``mechkin.run`` of the four time-optimal park scenarios vs toppra end
to end, interleaved per round, medians and paired ratios), without the rest of
benchmarks/speed_table.py.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_topp as bt  # noqa: E402
import speed_rows  # noqa: E402
from speed_table import Row  # noqa: E402


def main() -> None:
    R = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    rows, notes = speed_rows.track_rows(R, bt, Row)
    for r in rows:
        print(r.line())
    for n in notes:
        print(n)


if __name__ == "__main__":
    main()

"""park §5.3 under each reading of the DP stage: ``python benchmarks/park_readings_table.py``.

Runs the bundled ``scenarios/park_cases_overlay.yaml`` (the three cases of park §5.3 on the
50 x 100 grid, as ``mechkin track`` runs it) once per combination of ``track.dp`` (step_time
trapezoid | euler, wait_cost false | true, jerk_ends false | true; the scenario's cases inherit
it) and prints the Markdown table of the README section "park: readings of the DP": t_a, the
start time, the peak torques, the cost J and whether the limits hold, next to the paper's
printed values. Options: ``--grid N1xN2`` (default 50x100), ``--no-jerk-ends`` (4 readings).
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
from pathlib import Path

import yaml

from mechkin.api import run

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "park_cases_overlay.yaml"
#: park §5.3 as printed: t_a [s], peak u1, u2 [N m] (case 3's peaks are not printed).
PAPER = {0: (0.65, -1.342, -0.406), 1: (0.8, -0.499, -0.14), 2: (1.1, None, None)}


def _fmt(v: float | None, digits: int = 3) -> str:
    return "-" if v is None else f"{v:.{digits}f}"


def table(grid: tuple[int, int], jerk_ends: bool = True) -> str:
    doc = yaml.safe_load(SCENARIO.read_text())
    doc["mechanism"] = str((SCENARIO.parent / doc["mechanism"]).resolve())
    doc["track"]["grid"].update(N1=grid[0], N2=grid[1])
    doc.pop("expect", None)
    rows = ["| step_time | wait_cost | jerk_ends | case | t_a [s] | start [s] | peak u1 [N m] | "
            "peak u2 [N m] | J | limits ok |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    names = [c["name"] for c in doc["track"]["cases"]]
    for k, name in enumerate(names):
        t_a, u1, u2 = PAPER[k]
        rows.append(f"| paper | | | {name} | {_fmt(t_a, 2)} | | {_fmt(u1)} | {_fmt(u2)} | | |")
    ends = (False, True) if jerk_ends else (False,)
    with tempfile.TemporaryDirectory() as tmp:
        for st, wc, je in itertools.product(("trapezoid", "euler"), (False, True), ends):
            doc["track"]["dp"] = {"step_time": st, "wait_cost": wc, "jerk_ends": je}
            path = Path(tmp) / f"park_{st}_{wc}_{je}.yaml"
            path.write_text(yaml.safe_dump(doc, sort_keys=False))
            summary = run(path).summary
            for c in summary["cases"]:
                peak = c["peak_torque"] or [None, None]
                rows.append(
                    f"| {st} | {str(wc).lower()} | {str(je).lower()} | {c['name']} | "
                    f"{_fmt(c['t_a_s'], 3)} | {_fmt(c['t_start_s'], 3)} | {_fmt(peak[0])} | "
                    f"{_fmt(peak[1])} | {_fmt(c['cost'], 4)} | "
                    f"{'yes' if c['limits_ok'] else 'no'} |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", default="50x100", help="N1xN2 (default 50x100)")
    ap.add_argument("--no-jerk-ends", action="store_true", help="only jerk_ends: false")
    args = ap.parse_args()
    n1, n2 = (int(v) for v in args.grid.lower().split("x"))
    print(table((n1, n2), jerk_ends=not args.no_jerk_ends))


if __name__ == "__main__":
    main()

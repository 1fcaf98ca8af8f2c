"""A long serial chain (issue 28 item 11): the stick-drawing layout of an n-joint chain and a
whole ``mechkin fk`` run, for n = 250, 500, 1000, 2000. The layout's segment de-duplication is
linear (a hash grid of segment ends); doubling n should roughly double the layout time.

    python benchmarks/bench_long_chain.py [--sizes 250 500 1000 2000] [--cli]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def chain_yaml(n: int) -> str:
    links = ["  - name: l0"] + [f"  - name: l{i}" for i in range(1, n + 1)]
    links[-1] += "\n    frames:\n      - {name: tip, xyz: [0.01, 0, 0]}"
    joints = [f"  - {{name: q{i}, type: revolute, parent: l{i - 1}, child: l{i}, "
              f"origin: {{xyz: [0.01, 0, 0]}}, axis: [0, 0, 1]}}" for i in range(1, n + 1)]
    return (f"name: chain{n}\nunits: {{length: m, angle: deg}}\nlinks:\n" + "\n".join(links)
            + "\njoints:\n" + "\n".join(joints)
            + f"\nindependent: [{', '.join(f'q{i}' for i in range(1, n + 1))}]\n"
            "end_effector: tip\n")


def scenario_yaml(n: int) -> str:
    motion = "".join(f"    q{i}: {{type: ramp, from: 0, to: 1}}\n" for i in range(1, n + 1))
    return (f"name: chain{n}_fk\ntask: fk\nmechanism: m.yaml\nunits: {{angle: deg}}\nfk:\n"
            "  time: {start: 0, stop: 1, step: 0.5}\n  motion:\n" + motion)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=int, nargs="+", default=[250, 500, 1000, 2000])
    ap.add_argument("--cli", action="store_true", help="also time `mechkin fk --no-plots`")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from mechkin.model import load_mechanism
    from mechkin.model.drawing import _layout

    print(f"{'n':>6} {'load s':>8} {'layout s':>9} {'fk CLI s':>9}")
    for n in args.sizes:
        with tempfile.TemporaryDirectory() as d:
            m = Path(d) / "m.yaml"
            m.write_text(chain_yaml(n))
            t0 = time.perf_counter()
            mech = load_mechanism(m)
            t1 = time.perf_counter()
            _layout(mech)
            t2 = time.perf_counter()
            cli = float("nan")
            if args.cli:
                (Path(d) / "s.yaml").write_text(scenario_yaml(n))
                env = dict(os.environ, PYTHONPATH=str(ROOT))
                t3 = time.perf_counter()
                r = subprocess.run([sys.executable, "-m", "mechkin", "fk", "s.yaml", "--out",
                                    "o", "--no-plots"], cwd=d, env=env, capture_output=True,
                                   text=True)
                cli = time.perf_counter() - t3
                if r.returncode not in (0, 1):
                    print(r.stderr.strip().splitlines()[-1][:300])
        print(f"{n:>6} {t1 - t0:>8.2f} {t2 - t1:>9.2f} {cli:>9.2f}")


if __name__ == "__main__":
    main()

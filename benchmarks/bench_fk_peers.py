"""PUMA 560 forward kinematics, mechkin vs Robotics Toolbox for Python (run on demand:
``python benchmarks/bench_fk_peers.py [--rtb-python /tmp/rtbvenv/bin/python]``).

1. Single-configuration FK per call: ``frame_poses(mech, q[None], [ee])`` (and the all-links
   tree ``forward_kinematics(mech, q[None]).frames(...)``) vs rtb ``ETS.eval(q)`` of
   ``rtb.models.DH.Puma560().ets()`` (the same D-H table as mechanisms/puma560.yaml).
2. Batched FK throughput: ``frame_poses(mech, qs, [ee])`` vs rtb ``ETS.eval(qs)`` for m
   configurations in one call.
3. ``mechkin fk`` of 100k PUMA configurations through the CLI (a temporary scenario; wall time
   of the subprocess and the summary's ``solve_time_s``) vs the batched API on the same
   configurations.

rtb runs in its own interpreter (a worker subprocess fed over stdin), on the same random
configurations (a temporary .npy). Rounds are interleaved (mechkin, rtb, mechkin, ...); the
tables show medians over rounds and the ratio rtb / mechkin (> 1: mechkin faster).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.kinematics import forward_kinematics, frame_poses  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
from speed_table import FK100K  # noqa: E402  (the same CLI fk motion as the speed table)

RTB_WORKER = r"""
import sys, time, json
import numpy as np
import roboticstoolbox as rtb
ets = rtb.models.DH.Puma560().ets()
qs = np.load(sys.argv[1])
ets.eval(qs[0]); ets.eval(qs[:10])
print(json.dumps({"check": ets.eval(qs[:3]).tolist()}), flush=True)
for line in sys.stdin:
    cmd, arg = line.split()
    n = int(arg)
    if cmd == "single":
        t0 = time.perf_counter()
        for k in range(n):
            ets.eval(qs[k])
        dt = (time.perf_counter() - t0) / n
    else:
        q = qs[:n]
        t0 = time.perf_counter()
        ets.eval(q)
        dt = time.perf_counter() - t0
    print(json.dumps({"dt": dt}), flush=True)
"""


class Rtb:
    """The rtb worker: one request per line, one JSON answer per line."""

    def __init__(self, python: str, npy: str):
        self.p = subprocess.Popen([python, "-c", RTB_WORKER, npy], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True)
        self.check = np.array(json.loads(self.p.stdout.readline())["check"])

    def ask(self, cmd: str, n: int) -> float:
        self.p.stdin.write(f"{cmd} {n}\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())["dt"]

    def close(self) -> None:
        self.p.stdin.close()
        self.p.wait()


def _single(fn, qs: np.ndarray, n: int) -> float:
    t0 = time.perf_counter()
    for k in range(n):
        fn(qs[k : k + 1])
    return (time.perf_counter() - t0) / n


def _once(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _cli_fk(mech_path: Path, steps: int, tmp: Path) -> tuple[float, dict]:
    sc = tmp / "puma_fk_100k.yaml"
    sc.write_text(FK100K.format(mech=mech_path, stop=(steps - 1) * 0.001))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mechkin", "fk", str(sc), "-o", str(tmp / "out")],
                   env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    return wall, json.loads((tmp / "out" / "summary.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rtb-python", default="/tmp/rtbvenv/bin/python")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--single", type=int, default=2000, help="calls per single-FK round")
    ap.add_argument("--sizes", default="1000,10000,100000")
    ap.add_argument("--cli-steps", type=int, default=100_000)
    args = ap.parse_args()
    mech_path = ROOT / "mechanisms" / "puma560.yaml"
    mech = load_mechanism(mech_path)
    ee = [mech.end_effector]
    sizes = [int(x) for x in args.sizes.split(",")]
    rng = np.random.default_rng(0)
    qs = rng.uniform(-np.pi, np.pi, size=(max(sizes + [args.single]), mech.n))
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        npy = tmp / "q.npy"
        np.save(npy, qs)
        rtb = Rtb(args.rtb_python, str(npy)) if Path(args.rtb_python).exists() else None
        if rtb is not None:
            err = np.abs(frame_poses(mech, qs[:3], ee)[:, 0] - rtb.check).max()
            print(f"check: max |T_mechkin - T_rtb| over 3 configurations = {err:.2e}")
        fp = lambda q: frame_poses(mech, q, ee)  # noqa: E731
        tree = lambda q: forward_kinematics(mech, q).frames(mech, ee)  # noqa: E731
        fp(qs[:1]), tree(qs[:1])
        single: dict[str, list[float]] = {"mechkin frame_poses": [], "mechkin tree FK": [],
                                          "rtb ETS.eval": []}
        batch: dict[tuple[str, int], list[float]] = {}
        for _ in range(args.rounds):
            single["mechkin frame_poses"].append(_single(fp, qs, args.single))
            if rtb is not None:
                single["rtb ETS.eval"].append(rtb.ask("single", args.single))
            single["mechkin tree FK"].append(_single(tree, qs, args.single))
            for m in sizes:
                batch.setdefault(("mechkin frame_poses", m), []).append(
                    _once(lambda m=m: fp(qs[:m])))
                if rtb is not None:
                    batch.setdefault(("rtb ETS.eval", m), []).append(rtb.ask("batch", m))
                batch.setdefault(("mechkin tree FK", m), []).append(
                    _once(lambda m=m: tree(qs[:m])))
        if rtb is not None:
            rtb.close()
        print(f"\nSingle-configuration FK of the PUMA 560 tool frame, {args.single} calls per "
              f"round, median of {args.rounds} interleaved rounds")
        med = {k: float(np.median(v)) for k, v in single.items() if v}
        ref = med.get("rtb ETS.eval")
        for k, v in med.items():
            ratio = f"  rtb/this = {ref / v:5.2f}" if ref else ""
            print(f"  {k:22s} {v * 1e6:8.1f} us/call{ratio}")
        print("\nBatched FK throughput (one call, m configurations), median of rounds")
        for m in sizes:
            r = batch.get(("rtb ETS.eval", m))
            rm = float(np.median(r)) if r else None
            for name in ("mechkin frame_poses", "rtb ETS.eval", "mechkin tree FK"):
                v = batch.get((name, m))
                if not v:
                    continue
                t = float(np.median(v))
                ratio = f"  rtb/this = {rm / t:5.2f}" if rm else ""
                print(f"  m={m:7d} {name:22s} {t * 1e3:9.2f} ms  {m / t:12,.0f} poses/s"
                      f"{ratio}")
        if args.cli_steps:
            wall, summ = _cli_fk(mech_path, args.cli_steps, tmp)
            m = summ["n_steps"]
            from mechkin.config.scenario import load_scenario
            from mechkin.tasks.fk import independent_motion

            sc = load_scenario(tmp / "puma_fk_100k.yaml")
            _, qv = independent_motion(sc, mech)
            q_all = mech.assemble(qv, np.zeros((len(qv), 0)))
            api = float(np.median([_once(lambda: fp(q_all)) for _ in range(3)]))
            print(f"\n`mechkin fk` of {m} PUMA configurations (CSV only): wall {wall:.2f} s "
                  f"(process, loading, rates, singularity classes, CSV), solve_time_s "
                  f"{summ['solve_time_s']:.3f} s, status {summ['status']}, iterations_max "
                  f"{summ['closure']['iterations_max']}")
            print(f"  batched API frame_poses on the same {m} configurations: {api:.3f} s "
                  f"({m / api:,.0f} poses/s)")


if __name__ == "__main__":
    main()

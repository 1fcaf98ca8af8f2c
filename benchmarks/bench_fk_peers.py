"""PUMA 560 forward kinematics, mechkin vs Robotics Toolbox for Python and Pinocchio, side by
side in one run (on demand)::

    python benchmarks/bench_fk_peers.py [--rounds 7] [--sizes 10000,100000,1000000]
        [--rtb-python /tmp/rtbvenv/bin/python] [--cli-steps 100000] [--fresh 10,1000,100000]

1. Single-configuration FK per call: ``frame_poses(mech, q[k:k+1], [ee])`` (as
   benchmarks/speed_table.py calls it; ``MECHKIN_JIT=1``, warmed up) vs rtb ``ETS.eval(q)`` of
   ``rtb.models.DH.Puma560().ets()`` (the same D-H table as mechanisms/puma560.yaml) and
   Pinocchio ``forwardKinematics`` of tests/data/puma560.urdf (all joint placements).
2. Batched FK: ``frame_poses(mech, Q, [ee])`` vs rtb ``ETS.eval(Q)`` for m configurations in
   one call; the cost exponent ``t ~ m^a`` over the sizes (least squares on the medians).
3. The default route (no ``MECHKIN_JIT``: rent or buy, mechkin.model.fk_accel) in a fresh
   process for N single calls each (``--fresh``): mean time per call including whatever the
   process loads, and whether numba was loaded.
4. ``mechkin fk`` of 100k PUMA configurations through the CLI vs the batched API (``--cli-steps
   0`` skips it).

rtb runs in its own interpreter (a worker subprocess fed over stdin) on the same random
configurations (a temporary .npy). Each round runs mechkin, rtb and Pinocchio one after the
other; the ratios mechkin / peer (below 1: mechkin faster) are per round (paired), printed as
median (min-max) over rounds.
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

os.environ.setdefault("MECHKIN_JIT", "1")  # the in-process rows time the compiled kernel

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mechkin.model import fk_accel, load_mechanism  # noqa: E402
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

FRESH = r"""
import json, sys, time
import numpy as np
t_start = time.perf_counter()
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
mech = load_mechanism(sys.argv[1])
n = int(sys.argv[2])
q1 = np.random.default_rng(1).uniform(-3, 3, size=(min(n, 100000), mech.n))
ee = [mech.end_effector]
t0 = time.perf_counter()
for k in range(n):
    j = k % len(q1)
    frame_poses(mech, q1[j:j + 1], ee)
dt = time.perf_counter() - t0
print(json.dumps({"per_call": dt / n, "loop": dt, "numba": "numba" in sys.modules,
                  "import_and_load": t0 - t_start}))
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


def _ratio(a: list[float], b: list[float]) -> str:
    if not a or not b:
        return "not measured"
    r = [x / y for x, y in zip(a, b, strict=False)]
    return f"{np.median(r):6.3g} ({min(r):.3g}-{max(r):.3g}, {len(r)} rounds)"


def _cli_fk(mech_path: Path, steps: int, tmp: Path) -> tuple[float, dict]:
    sc = tmp / "puma_fk_100k.yaml"
    sc.write_text(FK100K.format(mech=mech_path, stop=(steps - 1) * 0.001))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    env.pop("MECHKIN_JIT", None)  # as a user runs it
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mechkin", "fk", str(sc), "-o", str(tmp / "out")],
                   env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    return wall, json.loads((tmp / "out" / "summary.json").read_text())


def _pinocchio():
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.buildModelFromUrdf(str(ROOT / "tests" / "data" / "puma560.urdf"))
    data = model.createData()
    return pin, model, data


def main() -> None:  # noqa: C901 - one linear script
    ap = argparse.ArgumentParser()
    ap.add_argument("--rtb-python", default="/tmp/rtbvenv/bin/python")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--single", type=int, default=2000, help="calls per single-FK round")
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--cli-steps", type=int, default=100_000)
    ap.add_argument("--fresh", default="10,1000,100000",
                    help="single calls per fresh default-route process ('' skips)")
    args = ap.parse_args()
    mech_path = ROOT / "mechanisms" / "puma560.yaml"
    mech = load_mechanism(mech_path)
    ee = [mech.end_effector]
    sizes = [int(x) for x in args.sizes.split(",")]
    rng = np.random.default_rng(0)
    qs = rng.uniform(-np.pi, np.pi, size=(max(sizes + [args.single]), mech.n))
    pin = _pinocchio()
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        npy = tmp / "q.npy"
        np.save(npy, qs)
        rtb = Rtb(args.rtb_python, str(npy)) if Path(args.rtb_python).exists() else None
        fp = lambda q: frame_poses(mech, q, ee)  # noqa: E731
        tree = lambda q: forward_kinematics(mech, q).frames(mech, ee)  # noqa: E731
        fp(qs[:1]), tree(qs[:1])
        print(f"route: MECHKIN_JIT={os.environ.get('MECHKIN_JIT')}, compiled kernel loaded: "
              f"{fk_accel.KERNEL is not None}")
        if rtb is not None:
            err = np.abs(fp(qs[:3])[:, 0] - rtb.check).max()
            print(f"check: max |T_mechkin - T_rtb| over 3 configurations = {err:.2e}")
        single: dict[str, list[float]] = {"frame_poses": [], "tree FK": [], "rtb": [],
                                          "pinocchio": []}
        batch: dict[tuple[str, int], list[float]] = {}
        qp = qs[: args.single, : (pin[1].nq if pin else mech.n)]
        for _ in range(args.rounds):
            single["frame_poses"].append(_single(fp, qs, args.single))
            if rtb is not None:
                single["rtb"].append(rtb.ask("single", args.single))
            if pin is not None:
                p, pm, pd = pin
                t0 = time.perf_counter()
                for x in qp:
                    p.forwardKinematics(pm, pd, x)
                single["pinocchio"].append((time.perf_counter() - t0) / args.single)
            single["tree FK"].append(_single(tree, qs, args.single // 4))
            for m in sizes:
                batch.setdefault(("frame_poses", m), []).append(_once(lambda m=m: fp(qs[:m])))
                if rtb is not None:
                    batch.setdefault(("rtb", m), []).append(rtb.ask("batch", m))
        if rtb is not None:
            rtb.close()
        print(f"\nSingle-configuration FK of the PUMA 560 tool frame, {args.single} calls per "
              f"round, {args.rounds} rounds (median per call; ratio mechkin / peer per round)")
        for k, v in single.items():
            if v:
                print(f"  {k:12s} {np.median(v) * 1e6:8.2f} us/call")
        print(f"  frame_poses / rtb ETS.eval        {_ratio(single['frame_poses'], single['rtb'])}")
        print(f"  frame_poses / Pinocchio           "
              f"{_ratio(single['frame_poses'], single['pinocchio'])}")
        print("\nBatched FK (one call, m configurations; ratio mechkin / rtb time per round)")
        for m in sizes:
            t = float(np.median(batch[("frame_poses", m)]))
            line = f"  m={m:8,d} frame_poses {t * 1e3:9.2f} ms {m / t:12,.0f} /s"
            r = batch.get(("rtb", m))
            if r:
                tr = float(np.median(r))
                line += (f" | rtb {tr * 1e3:9.2f} ms {m / tr:12,.0f} /s | ratio "
                         f"{_ratio(batch[('frame_poses', m)], r)}")
            print(line)
        if len(sizes) > 1:
            for who in ("frame_poses", "rtb"):
                if all((who, m) in batch for m in sizes):
                    t = [float(np.median(batch[(who, m)])) for m in sizes]
                    a = np.polyfit(np.log(sizes), np.log(t), 1)[0]
                    print(f"  cost exponent ({who}, m = {sizes[0]:,}-{sizes[-1]:,}): m^{a:.3f}")
        if args.fresh:
            print("\nDefault route (no MECHKIN_JIT) in a fresh process: frame_poses(mech, "
                  "q[k:k+1], [ee]) N times")
            env = dict(os.environ, PYTHONPATH=str(ROOT))
            env.pop("MECHKIN_JIT", None)
            for n in (int(x) for x in args.fresh.split(",")):
                got = []
                for _ in range(3):
                    out = subprocess.run([sys.executable, "-c", FRESH, str(mech_path), str(n)],
                                         env=env, capture_output=True, text=True, check=True)
                    got.append(json.loads(out.stdout.strip().splitlines()[-1]))
                pc = [g["per_call"] for g in got]
                loop = np.median([g["loop"] for g in got])
                print(f"  N={n:7,d}: {np.median(pc) * 1e6:8.2f} us/call (median of 3 processes, "
                      f"{min(pc) * 1e6:.2f}-{max(pc) * 1e6:.2f}; loop {loop:.3f} s); "
                      f"numba loaded: {got[0]['numba']}")
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
                  f"{summ['solve_time_s']:.3f} s, status {summ['status']}")
            print(f"  batched API frame_poses on the same {m} configurations: {api:.3f} s "
                  f"({m / api:,.0f} poses/s)")


if __name__ == "__main__":
    main()

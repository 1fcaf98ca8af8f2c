"""Analytic IK (issue 26) against EAIK and ssik, PUMA 560 and UR5, in one process.

    python benchmarks/bench_analytic_ik.py [--rounds 7] [--batch 10000] [--quick]

Rows per arm (time per pose; every tool gets the same seeded random reachable poses):

* ``single``: one public call per pose, ``mechkin.ik(mech, T)`` (method auto: the analytic
  branch nearest the guess, verified, an IkResult) vs ``eaik DhRobot.IK(T)`` (every branch) vs
  ``ssik Manipulator.solve(T, max_solutions=1)``;
* ``all, one pose``: every solution within the limits of one pose per call
  (:func:`mechkin.solvers.ik.analytic.solutions.analytic_batch` with m = 1, the route of
  ``solutions: all``) vs ``eaik IK(T)`` vs ``ssik solve(T)``;
* ``batch``: ``--batch`` poses in one call, every solution
  (:func:`analytic_batch`) and the public ``mechkin.ik(..., batch=True)`` (nearest the guess,
  one IkResult each) vs ``eaik IK_batched``;
* ``solutions: all by multi-start`` (the route before issue 26, 256 lm starts): a few poses,
  for the record.

Rounds interleave the tools (mechkin, peer, mechkin, ...); the table gives the median per tool
and the median (and range) of the per-round ratios mechkin / peer (below 1: mechkin faster).
Times are CPU time of this process (``time.process_time``): on a shared machine, wall time
mostly measures the other jobs.
:func:`analytic_rows` returns the rows for ``benchmarks/speed_table.py``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MECHKIN_JIT", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import mechkin  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.kinematics import frame_poses  # noqa: E402
from mechkin.solvers.ik.analytic.classify import classify  # noqa: E402
from mechkin.solvers.ik.analytic.solutions import analytic_batch  # noqa: E402

# standard D-H (a [m], alpha [deg], d [m]) of the bundled mechanisms, for the peers
DH = {
    "puma560": [(0, 90, 0.67183), (0.4318, 0, 0), (0.0203, -90, 0.15005), (0, 90, 0.4318),
                (0, -90, 0), (0, 0, 0)],
    "ur5": [(0, 90, 0.089159), (-0.425, 0, 0), (-0.39225, 0, 0), (0, 90, 0.10915),
            (0, -90, 0.09465), (0, 0, 0.0823)],
}


def _poses(mech, m: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    iv = mech.independent
    q = rng.uniform(np.maximum(mech.lower[iv], -np.pi), np.minimum(mech.upper[iv], np.pi),
                    size=(m, len(iv)))
    return np.ascontiguousarray(frame_poses(mech, q, [mech.end_effector])[:, 0])


CLOCK = time.process_time  # CPU time of this process: other jobs on the machine do not count


def _per_pose(fn, items) -> float:
    t = CLOCK()
    for x in items:
        fn(x)
    return (CLOCK() - t) / len(items)


def _peers(name: str):
    dh = np.array(DH[name], dtype=float)
    out = {}
    try:
        from eaik.IK_DH import DhRobot

        out["eaik"] = DhRobot(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    except ImportError:  # pragma: no cover
        pass
    try:
        import ssik

        out["ssik"] = ssik.Manipulator.from_dh(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    except ImportError:  # pragma: no cover
        pass
    return out


def _row(label: str, ours: list[float], peer: str, theirs: list[float] | None) -> dict:
    row = {"row": label, "mechkin_us": 1e6 * statistics.median(ours), "peer": peer,
           "peer_us": None, "ratio": None, "ratio_min": None, "ratio_max": None}
    if theirs:
        r = [a / b for a, b in zip(ours, theirs, strict=True)]
        row.update(peer_us=1e6 * statistics.median(theirs), ratio=statistics.median(r),
                   ratio_min=min(r), ratio_max=max(r))
    return row


def analytic_rows(rounds: int = 7, batch: int = 10_000, quick: bool = False,
                  arms: tuple[str, ...] = ("puma560", "ur5")) -> list[dict]:
    """The benchmark's rows: dicts with ``row``, ``mechkin_us`` (median per pose), ``peer``,
    ``peer_us``, ``ratio`` (median of per-round mechkin / peer) and its range
    ``ratio_min`` / ``ratio_max``; ``peer_us`` None when the peer is not installed."""
    n_single = 50 if quick else 200
    n_ssik = 5 if quick else 20
    batch = min(batch, 1000) if quick else batch
    rows = []
    for name in arms:
        mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
        chain = classify(mech)
        peers = _peers(name)
        T = _poses(mech, max(batch, n_single))
        Ts = T[:n_single]
        ref = mech.home[mech.independent]
        eaik, ss = peers.get("eaik"), peers.get("ssik")
        # warm up every route (compiled kernels loaded, caches filled)
        mechkin.ik(mech, Ts[:2])
        mechkin.ik(mech, Ts[:2], batch=True)
        analytic_batch(mech, chain, Ts[:2], ref)
        if eaik is not None:
            eaik.IK(Ts[0])
            eaik.IK_batched(list(Ts[:2]))
        t = {k: [] for k in ("single", "single_e", "single_s", "all1", "all1_e", "all1_s",
                             "batch", "batch_api", "batch_e")}
        Tb = T[:batch]
        Tb_list = list(Tb)
        def single(x, mech=mech):
            return mechkin.ik(mech, x)

        def all1(x, mech=mech, chain=chain, ref=ref):
            return analytic_batch(mech, chain, x, ref)

        def ss1(x, ss=ss):
            return ss.solve(x, max_solutions=1)

        for _ in range(rounds):
            t["single"].append(_per_pose(single, Ts))
            if eaik is not None:
                t["single_e"].append(_per_pose(eaik.IK, Ts))
            if ss is not None:
                t["single_s"].append(_per_pose(ss1, Ts[:n_ssik]))
            t["all1"].append(_per_pose(all1, Ts))
            if eaik is not None:
                t["all1_e"].append(_per_pose(eaik.IK, Ts))
            if ss is not None:
                t["all1_s"].append(_per_pose(ss.solve, Ts[:n_ssik]))
            t0 = CLOCK()
            analytic_batch(mech, chain, Tb, ref)
            t["batch"].append((CLOCK() - t0) / batch)
            t0 = CLOCK()
            mechkin.ik(mech, Tb, batch=True)
            t["batch_api"].append((CLOCK() - t0) / batch)
            if eaik is not None:
                t0 = CLOCK()
                eaik.IK_batched(Tb_list)
                t["batch_e"].append((CLOCK() - t0) / batch)
        rows += [
            _row(f"{name}: single IK, public mechkin.ik", t["single"], "EAIK IK",
                 t["single_e"]),
            _row(f"{name}: single IK, public mechkin.ik", t["single"], "ssik solve(1)",
                 t["single_s"]),
            _row(f"{name}: all solutions, one pose per call", t["all1"], "EAIK IK", t["all1_e"]),
            _row(f"{name}: all solutions, one pose per call", t["all1"], "ssik solve",
                 t["all1_s"]),
            _row(f"{name}: all solutions, batch of {batch}", t["batch"], "EAIK IK_batched",
                 t["batch_e"]),
            _row(f"{name}: mechkin.ik(batch=True), batch of {batch}", t["batch_api"],
                 "EAIK IK_batched", t["batch_e"]),
        ]
        if not quick:
            from mechkin.solvers.ik.all_solutions import multistart_all

            def ms1(x, mech=mech, ref=ref):
                return multistart_all(mech, x, q_v0=ref)

            ms = [_per_pose(ms1, Ts[:3]) for _ in range(2)]
            rows.append(_row(f"{name}: solutions: all by multi-start lm (before)", ms,
                             "EAIK IK", [statistics.median(t["all1_e"])] * 2
                             if t["all1_e"] else None))
    return rows


def format_rows(rows: list[dict]) -> str:
    """A markdown table of :func:`analytic_rows`."""
    out = ["| measurement | mechkin [us/pose] | peer | peer [us/pose] | ratio (range) |",
           "|---|---:|---|---:|---|"]
    for r in rows:
        if r["peer_us"] is None:
            out.append(f"| {r['row']} | {r['mechkin_us']:.1f} | {r['peer']} | not measured | |")
        else:
            out.append(f"| {r['row']} | {r['mechkin_us']:.1f} | {r['peer']} | "
                       f"{r['peer_us']:.1f} | {r['ratio']:.2f} ({r['ratio_min']:.2f}-"
                       f"{r['ratio_max']:.2f}) |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--batch", type=int, default=10_000)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    print(format_rows(analytic_rows(a.rounds, a.batch, a.quick)))


if __name__ == "__main__":
    main()

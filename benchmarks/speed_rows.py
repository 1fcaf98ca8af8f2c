"""Rows of the README speed table for the calls users make (issue 29), used by
benchmarks/speed_table.py: the public API (``mechkin.Solver``, ``mechkin.fk``, ``mechkin.ik``)
against Pinocchio and Robotics Toolbox, ``mechkin.run`` of the time-optimal track scenarios
against toppra end to end, and the first run after ``mechkin warmup`` against a warm run.

Each function appends :class:`speed_table.Row` objects (per-round times, paired with the peer
in the same round) and notes; a peer that is missing is never given a number.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def public_fk_rows(R: int, puma, q1: np.ndarray, rtb, pin_pair, Row) -> list:
    """Single FK through the public API, per call: ``Solver(mech).pose(q)`` (the fast path)
    and ``mechkin.fk(mech, q)`` (an FkResult), vs Pinocchio ``forwardKinematics`` (and that
    plus reading the flange pose as a numpy array) and rtb ``ETS.eval(q)``."""
    import mechkin

    n1 = 2000
    qs = [np.ascontiguousarray(q1[k]) for k in range(n1)]
    sol = mechkin.Solver(puma)
    sol.pose(qs[0])
    mechkin.fk(puma, qs[0])
    rows = []
    calls = {"`mechkin.Solver(mech).pose(q)`": lambda: [sol.pose(q) for q in qs],
             "`mechkin.fk(mech, q)` (an FkResult)": lambda: [mechkin.fk(puma, q) for q in qs]}
    pin = pmodel = pdata = None
    if pin_pair is not None:
        pin, pmodel, pdata = pin_pair
        nq = pmodel.nq
        pq = [np.ascontiguousarray(q[:nq]) for q in qs]
        ee = pmodel.njoints - 1
    for what, fn in calls.items():
        r_pin = Row(f"public single FK, PUMA 560, {what}, per call",
                    "Pinocchio `forwardKinematics`", "us", 1e6 / n1)
        r_pinp = Row(f"public single FK, PUMA 560, {what}, per call",
                     "Pinocchio `forwardKinematics` + `data.oMi[6].homogeneous`", "us",
                     1e6 / n1)
        r_rtb = Row(f"public single FK, PUMA 560, {what}, per call", "rtb `ETS.eval(q)`",
                    "us", 1e6 / n1)
        for _ in range(R):
            t = _t(fn)
            for r in (r_pin, r_pinp, r_rtb):
                r.mk.append(t)
            if pin is not None:
                r_pin.pe.append(_t(lambda: [pin.forwardKinematics(pmodel, pdata, x)
                                            for x in pq]))
                r_pinp.pe.append(_t(lambda: [(pin.forwardKinematics(pmodel, pdata, x),
                                              pdata.oMi[ee].homogeneous) for x in pq]))
            if rtb is not None:
                r_rtb.pe.append(rtb.ask("fk1", "puma", n1)["dt"])
        rows += [r_pin, r_pinp, r_rtb]
    return rows


def public_fk_default_row(R: int, q1: np.ndarray, rtb, Row, tmp: Path):
    """``Solver(mech).pose(q)`` with the defaults (no MECHKIN_JIT) in a fresh process."""
    n1 = 2000
    np.save(tmp / "q1s.npy", q1[:n1])
    child = ("import sys, time, numpy as np, mechkin\n"
             f"m = mechkin.load_mechanism({str(ROOT / 'mechanisms' / 'puma560.yaml')!r})\n"
             f"q = np.load({str(tmp / 'q1s.npy')!r}); qs = [np.ascontiguousarray(x) for x in q]\n"
             "s = mechkin.Solver(m); s.pose(qs[0])\n"
             "t0 = time.perf_counter()\n"
             "for x in qs:\n    s.pose(x)\n"
             "print(time.perf_counter() - t0, 'numba' in sys.modules)\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("MECHKIN_JIT", None)
    row = Row("public single FK, PUMA 560, `Solver(mech).pose(q)` with the defaults (no "
              "`MECHKIN_JIT`), fresh process, per call", "rtb `ETS.eval(q)`", "us", 1e6 / n1)
    seen = set()
    for _ in range(R):
        out = subprocess.run([sys.executable, "-c", child], env=env, check=True,
                             capture_output=True, text=True).stdout.split()
        row.mk.append(float(out[0]))
        seen.add(out[1])
        if rtb is not None:
            row.pe.append(rtb.ask("fk1", "puma", n1)["dt"])
    row.note = ("numba not loaded (the generated plain-Python function)" if seen == {"False"}
                else "numba loaded in the child")
    return row


def public_ik_rows(R: int, mechs: dict, qs: dict, rtb, Row, success_note) -> list:
    """Single IK through the public API, per target: ``mechkin.ik(mech, T)`` (home start, the
    default restarts) and ``Solver(mech).ik(T)``, vs rtb ``ik_LM`` (tol 1e-10)."""
    import mechkin
    from mechkin.model.kinematics import frame_poses

    n_ik = 100
    rows = []
    for k, m in mechs.items():
        T = frame_poses(m, qs[k][:n_ik], [m.end_effector])[:, 0]
        sol = mechkin.Solver(m)
        sol.ik(T[0])
        mechkin.ik(m, T[0])
        for what, fn in (("`mechkin.ik(mech, T)`", lambda T=T, m=m: [mechkin.ik(m, t)[0]
                                                                        for t in T]),
                         ("`Solver(mech).ik(T)`", lambda T=T, sol=sol: [sol.ik(t) for t in T])):
            fn()  # warm: the codebook's restart searches
            row = Row(f"public single IK, {k}, {what}, per target", "rtb `ik_LM` (tol 1e-10)",
                      "ms", 1e3 / n_ik)
            oks, okp, flg = [], [], []
            for _ in range(R):
                t0 = time.perf_counter()
                res = fn()
                row.mk.append(time.perf_counter() - t0)
                oks.append(sum(bool(r.ok) for r in res))
                if rtb is not None:
                    ans = rtb.ask("ik", k, n_ik, 1e-6, 1e-6)
                    row.pe.append(ans["dt"])
                    okp.append(ans["ok"])
                    flg.append(ans["flag"])
            row.note = success_note(oks, okp, flg, n_ik)
            rows.append(row)
    return rows


def track_rows(R: int, bt, Row) -> tuple[list, list[str]]:
    """``mechkin.run`` of the time-optimal track scenarios (path IK, dynamics, planner, the
    report; no files) vs toppra end to end (``bench_topp.tp_full``: constraints, ``TOPPRA``,
    ``compute_trajectory`` on the same path handed over as a spline, so toppra does no IK)."""
    import mechkin

    rows, notes = [], []
    if bt is None or bt.toppra is None:
        return rows, ["toppra not installed: the track rows are not measured."]
    for name, va in (("park_time_optimal_torque_topp", False),
                     ("park_time_optimal_full_topp", True),
                     ("park_time_optimal_torque", False), ("park_time_optimal_full", True)):
        sc = mechkin.load_scenario(ROOT / "scenarios" / f"{name}.yaml")
        N = sc.section.grid.N1 if name.endswith("_topp") else 1000
        ref = bt.tp_full(bt.N_CONVERGED, va)
        rep = mechkin.run(sc)
        bt.tp_full(N, va)
        row = Row(f"`mechkin.run(\"scenarios/{name}.yaml\")` (time-optimal track end to end, "
                  f"grid {_grid(sc)})", f"toppra end to end, N = {N} (seidel)", "ms", 1e3)
        for _ in range(R):
            row.mk.append(_t(lambda sc=sc: mechkin.run(sc)))
            row.pe.append(_t(lambda N=N, va=va: bt.tp_full(N, va)))
        d = rep.summary["duration_s"]
        d_tp = bt.tp_full(N, va)
        row.note = (f"duration vs toppra N = {bt.N_CONVERGED}: mechkin {100 * (d - ref) / ref:+.3f}"
                    f" %, toppra N = {N} {100 * (d_tp - ref) / ref:+.3f} %")
        rows.append(row)
    return rows, notes


def _grid(sc) -> str:
    g = sc.section.grid
    return f"N1 = {g.N1}" if sc.section.planner in ("topp", "auto") and \
        sc.section.objective == "time" and sc.section.planner != "dp" else f"{g.N1} x {g.N2}"


def first_run_rows(R: int, Row) -> tuple[list, list[str]]:
    """The first CLI run after ``mechkin warmup`` (a fresh numba cache folder) vs the same
    command warm, with the compiled kernels forced (``MECHKIN_JIT=1``): an open chain (PUMA
    IK) and a closed one (the Stewart platform, kim1995 Table 6)."""
    rows, notes = [], []
    py = sys.executable
    jobs = {"puma560_random_ik": "open chain", "kim1995_table6_stewart_ik": "closed chain"}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MECHKIN_JIT="1",
                   NUMBA_CACHE_DIR=cache)
        t0 = time.perf_counter()
        subprocess.run([py, "-m", "mechkin", "warmup"], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        notes.append(f"`mechkin warmup` into an empty numba cache took "
                     f"{time.perf_counter() - t0:.0f} s.")
        for name, kind in jobs.items():
            with tempfile.TemporaryDirectory() as out:
                cmd = [py, "-m", "mechkin", "ik", str(ROOT / "scenarios" / f"{name}.yaml"),
                       "--no-plots", "-o", out]
                first = _wall(cmd, env)
                row = Row(f"first `mechkin ik scenarios/{name}.yaml --no-plots` after "
                          f"`mechkin warmup` ({kind}, `MECHKIN_JIT=1`), wall",
                          "the same command, warm", "s", 1.0)
                warm = [_wall(cmd, env) for _ in range(R)]
                row.mk = [first] * R
                row.pe = warm
                row.note = ("one first run (the ratio's range is that of the warm runs); "
                            "goal <= 1.5")
                rows.append(row)
    return rows, notes


def _t(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _wall(cmd: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def median(v: list[float]) -> float:
    return statistics.median(v)

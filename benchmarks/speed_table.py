"""The README speed table: mechkin and its peers measured side by side in one run.

    python benchmarks/speed_table.py [--write-readme] [--rounds 5] [--quick]
                                     [--rtb-python /tmp/rtbvenv/bin/python]

Rows (issue 15): single FK (PUMA 560), batched FK (1e4-1e6 configurations), single IK
(Panda, PUMA 560; scenario defaults; verified success), batched IK (m = 1, 100, 5000), the
time-optimal planner vs toppra, one ``mechkin ik`` call vs ``python -c "import numpy, scipy"``,
and ``mechkin fk`` of 100k configurations vs the batched API on the same configurations.
Rows of issue 29 (:mod:`speed_rows`): the public API (``Solver.pose``, ``mechkin.fk``,
``mechkin.ik``, ``Solver.ik``) vs Pinocchio and rtb, ``mechkin.run`` of the time-optimal track
scenarios vs toppra end to end, the first run after ``mechkin warmup`` vs a warm run.

How: every measurement is repeated ``--rounds`` times, the tools interleaved within a round
(mechkin, peer, mechkin, ...), and the table gives the median per tool and the median of the
per-round ratios mechkin / peer (below 1: mechkin faster) with their range. Robotics Toolbox
(``roboticstoolbox-python``) runs in its own interpreter (``--rtb-python``, e.g. a venv made
with ``python -m venv --system-site-packages /tmp/rtbvenv && /tmp/rtbvenv/bin/pip install
roboticstoolbox-python``), fed over stdin; Pinocchio and toppra are imported here when
installed (the ``bench`` extra). A peer that is missing gives "not measured", never a number.
mechkin's compiled kernels are forced on (``MECHKIN_JIT=1``) and warmed up before timing,
except in the CLI rows, which run the command as a user would (warm numba cache).

``--write-readme`` replaces the text between ``<!-- speed-table:begin -->`` and
``<!-- speed-table:end -->`` in README.md with the table, the machine and the date.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MECHKIN_JIT", "1")  # the API rows time the compiled kernels

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import speed_rows  # noqa: E402
from timing import FK100K  # noqa: E402

from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.kinematics import frame_poses  # noqa: E402
from mechkin.solvers.ik import IkOptions, IkStatus, solve_ik, solve_ik_batch  # noqa: E402
from mechkin.solvers.ik.kernel import kernel_for  # noqa: E402

BEGIN, END = "<!-- speed-table:begin -->", "<!-- speed-table:end -->"

RTB_WORKER = r"""
import sys, time, json
import numpy as np
import roboticstoolbox as rtb
robots = {"puma": rtb.models.DH.Puma560().ets(), "panda": rtb.models.Panda().ets()}
data = np.load(sys.argv[1])
qs = {k: data[k] for k in ("puma", "panda")}
tgt = {k: robots[k].eval(qs[k][:20000]) for k in robots}  # targets in rtb's own model
for e in robots.values():
    e.eval(np.zeros(e.n)); e.ik_LM(e.eval(np.zeros(e.n)), tol=1e-10)
print(json.dumps({"check": {k: robots[k].eval(qs[k][:3]).tolist() for k in robots}}), flush=True)
def ik_loop(e, T, tol_pos, tol_ori):
    ok = flag = 0
    for Tk in T:
        r = e.ik_LM(Tk, tol=1e-10)
        flag += bool(r.success)
        if r.success:
            Te = e.eval(r.q)
            dp = np.linalg.norm(Te[:3, 3] - Tk[:3, 3])
            c = (np.trace(Tk[:3, :3].T @ Te[:3, :3]) - 1.0) / 2.0
            ang = np.arccos(min(1.0, max(-1.0, c)))
            ok += bool(dp <= tol_pos and ang <= tol_ori)
    return ok, flag
for line in sys.stdin:
    cmd, robot, arg, tp, to = line.split()
    n, e = int(arg), robots[robot]
    out = {}
    t0 = time.perf_counter()
    if cmd == "fk1":
        q = qs[robot]
        for k in range(n):
            e.eval(q[k])
    elif cmd == "fkb":
        e.eval(qs[robot][:n])
    elif cmd == "ik":
        out["ok"], out["flag"] = ik_loop(e, tgt[robot][:n], float(tp), float(to))
    out["dt"] = time.perf_counter() - t0
    print(json.dumps(out), flush=True)
"""


class Rtb:
    """The Robotics Toolbox worker (one request per line, one JSON answer per line)."""

    def __init__(self, python: str, npy: str) -> None:
        self.p = subprocess.Popen([python, "-c", RTB_WORKER, npy], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True)
        line = self.p.stdout.readline()
        if not line:
            raise RuntimeError("the rtb worker did not start")
        self.check = {k: np.array(v) for k, v in json.loads(line)["check"].items()}
        self.version = subprocess.run(
            [python, "-c", "import roboticstoolbox as r; print(r.__version__)"],
            capture_output=True, text=True).stdout.strip()

    def ask(self, cmd: str, robot: str, n: int, tol_pos: float = 0.0,
            tol_ori: float = 0.0) -> dict:
        self.p.stdin.write(f"{cmd} {robot} {n} {tol_pos} {tol_ori}\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())

    def close(self) -> None:
        self.p.stdin.close()
        self.p.wait()


def _t(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


class Row:
    """One table row: per-round times of mechkin and of the peer (paired by round)."""

    def __init__(self, work: str, peer: str, unit: str, scale: float, per: int = 1) -> None:
        self.work, self.peer, self.unit, self.scale, self.per = work, peer, unit, scale, per
        self.mk: list[float] = []
        self.pe: list[float] = []
        self.note = ""

    def fmt(self, v: list[float]) -> str:
        if not v:
            return "not measured"
        med = statistics.median(v)
        if self.unit == "/s":
            return f"{self.per / med:,.0f} /s"
        return f"{med * self.scale:.3g} {self.unit}"

    def ratio(self) -> str:
        if not self.mk or not self.pe:
            return "-"
        r = [a / b for a, b in zip(self.mk, self.pe, strict=False)]
        return (f"{statistics.median(r):.3g} ({min(r):.3g}-{max(r):.3g})" if len(r) > 1
                else f"{r[0]:.3g}")

    def line(self) -> str:
        return (f"| {self.work} | {self.fmt(self.mk)} | {self.peer}: {self.fmt(self.pe)} | "
                f"{self.ratio()} | {self.note} |")


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                cpu = ln.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numba

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{cpu}, {os.cpu_count()} cores (load average {load:.1f} at the start), "
            f"{platform.system()} {platform.release()}, Python {platform.python_version()}, "
            f"numpy {np.__version__}, numba {numba.__version__}")


def success_note(oks: list[int], okp: list[int], flags: list[int], n: int) -> str:
    """Worst round's success: verified by FK at 1e-6 m / 1e-6 rad for both tools, and rtb's
    own flag (its tol bounds E = 1/2 e^T e, i.e. errors up to ~1.4e-5)."""
    out = f"verified success mechkin {100 * min(oks) / n:.0f} %"
    if okp:
        out += (f", rtb {100 * min(okp) / n:.0f} % (rtb's own success flag "
                f"{100 * min(flags) / n:.0f} %)")
    return out


def rtb_limits(python: str) -> dict[str, np.ndarray]:
    """rtb's joint limits (2, n) of its PUMA 560 and Panda ({} without rtb)."""
    if not Path(python).exists():
        return {}
    code = ("import json, roboticstoolbox as rtb; print(json.dumps({'puma': "
            "rtb.models.DH.Puma560().qlim.tolist(), 'panda': rtb.models.Panda().qlim.tolist()}))")
    out = subprocess.run([python, "-c", code], capture_output=True, text=True)
    try:
        return {k: np.array(v) for k, v in json.loads(out.stdout).items()}
    except ValueError:
        return {}


def cli_wall(args: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    subprocess.run(args, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0




def main() -> None:  # noqa: C901 - one linear script
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rtb-python", default="/tmp/rtbvenv/bin/python")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    ap.add_argument("--write-readme", action="store_true")
    a = ap.parse_args()
    R = a.rounds
    quick = a.quick
    started = _dt.datetime.now(_dt.timezone.utc)
    mach = machine()
    puma = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    panda = load_mechanism(ROOT / "mechanisms" / "panda.yaml")
    mechs = {"puma": puma, "panda": panda}
    rng = np.random.default_rng(15)
    n_cfg = 100_000 if quick else 1_000_000
    qlim = rtb_limits(a.rtb_python)
    qs = {}
    for k, m in mechs.items():
        kern = kernel_for(m)
        lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
        hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
        if k in qlim:  # within both tools' joint limits: reachable for both
            lo, hi = np.maximum(lo, qlim[k][0]), np.minimum(hi, qlim[k][1])
        qs[k] = rng.uniform(lo, hi, size=(n_cfg, m.n))
    rows: list[Row] = []
    notes: list[str] = []
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        np.savez(tmp / "q.npz", **qs)
        rtb = None
        if Path(a.rtb_python).exists():
            try:
                rtb = Rtb(a.rtb_python, str(tmp / "q.npz"))
            except (RuntimeError, OSError) as exc:
                notes.append(f"Robotics Toolbox worker failed to start ({exc}): not measured.")
        else:
            notes.append(f"Robotics Toolbox: no interpreter at {a.rtb_python}: not measured.")
        try:
            import pinocchio as pin

            pmodel = pin.buildModelFromUrdf(str(ROOT / "tests" / "data" / "puma560.urdf"))
            pdata = pmodel.createData()
            pin_version = pin.__version__
        except Exception as exc:  # noqa: BLE001 - an optional peer
            pin = None
            notes.append(f"Pinocchio not available ({type(exc).__name__}): not measured.")
        if rtb is not None:
            for k, m in mechs.items():
                err = np.abs(frame_poses(m, qs[k][:3], [m.end_effector])[:, 0]
                             - rtb.check[k]).max()
                notes.append(f"FK check {k}: max |T_mechkin - T_rtb| over 3 configurations "
                             f"{err:.1e} m" + ("" if err < 1e-9 else
                                               " (the models differ: each tool's IK targets "
                                               "come from its own FK of the same q)"))
            notes.append(f"Robotics Toolbox {rtb.version} (C++ `ETS.eval`, `ik_LM` with tol 1e-10, "
                         "its default random restarts, joint limits on); models "
                         "`DH.Puma560().ets()` and `Panda().ets()` (rtb's Panda ends at the "
                         "hand, mechkin's at the flange). Configurations are drawn within both "
                         "tools' joint limits; each tool's IK targets are its own FK of them; "
                         "success is verified by FK (1e-6 m, 1e-6 rad) for both.")
        if pin is not None:
            notes.append(f"Pinocchio {pin_version}: `forwardKinematics` of "
                         "tests/data/puma560.urdf (all joint placements).")

        # ---- single FK ------------------------------------------------------------------
        n1 = 2000
        ee = [puma.end_effector]
        q1 = qs["puma"]
        frame_poses(puma, q1[:1], ee)
        r_rtb = Row("single FK, PUMA 560, `frame_poses(mech, q[None], [ee])`, per call",
                    "rtb `ETS.eval(q)`", "us", 1e6 / n1)
        r_pin = Row("single FK, PUMA 560, same", "Pinocchio `forwardKinematics`", "us",
                    1e6 / n1)

        def mk_single() -> None:
            for k in range(n1):
                frame_poses(puma, q1[k:k + 1], ee)

        for _ in range(R):
            t = _t(mk_single)
            r_rtb.mk.append(t)
            r_pin.mk.append(t)
            if rtb is not None:
                r_rtb.pe.append(rtb.ask("fk1", "puma", n1)["dt"])
            if pin is not None:
                qp = q1[:n1, : pmodel.nq]
                r_pin.pe.append(_t(lambda qp=qp: [pin.forwardKinematics(pmodel, pdata, x)
                                                   for x in qp]))
        rows += [r_rtb, r_pin]
        # the same calls with the defaults a user gets (no MECHKIN_JIT: the plain-Python
        # route until rent or buy loads the kernel), in a fresh process
        np.save(tmp / "q1.npy", q1[:n1])
        child = ("import sys, time, numpy as np\n"
                 "from mechkin.model import load_mechanism\n"
                 "from mechkin.model.kinematics import frame_poses\n"
                 f"m = load_mechanism({str(ROOT / 'mechanisms' / 'puma560.yaml')!r})\n"
                 f"q = np.load({str(tmp / 'q1.npy')!r}); ee = [m.end_effector]\n"
                 "frame_poses(m, q[:1], ee)\n"
                 "t0 = time.perf_counter()\n"
                 "for k in range(len(q)):\n    frame_poses(m, q[k:k + 1], ee)\n"
                 "print(time.perf_counter() - t0, 'numba' in sys.modules)\n")
        env_def = dict(os.environ, PYTHONPATH=str(ROOT))
        env_def.pop("MECHKIN_JIT", None)
        r_def = Row("single FK, PUMA 560, same calls with the defaults (no `MECHKIN_JIT`), "
                    "fresh process", "rtb `ETS.eval(q)`", "us", 1e6 / n1)
        numba_seen = set()
        for _ in range(R):
            out = subprocess.run([sys.executable, "-c", child], env=env_def, check=True,
                                 capture_output=True, text=True).stdout.split()
            r_def.mk.append(float(out[0]))
            numba_seen.add(out[1])
            if rtb is not None:
                r_def.pe.append(rtb.ask("fk1", "puma", n1)["dt"])
        r_def.note = ("numba not loaded (the plain-Python route)" if numba_seen == {"False"}
                      else "numba loaded in the child")
        rows.append(r_def)
        # ---- the public API (issue 29): Solver.pose, mechkin.fk --------------------------
        rows += speed_rows.public_fk_rows(R, puma, q1, rtb, None if pin is None else
                                          (pin, pmodel, pdata), Row)
        rows.append(speed_rows.public_fk_default_row(R, q1, rtb, Row, tmp))

        # ---- batched FK -----------------------------------------------------------------
        sizes = (10_000, 100_000) if quick else (10_000, 100_000, 1_000_000)
        fkb: dict[int, Row] = {}
        for m in sizes:
            fkb[m] = Row(f"batched FK, PUMA 560, m = {m:,} per call", "rtb `ETS.eval(Q)`",
                         "/s", 1.0, per=m)
        for _ in range(R):
            for m in sizes:
                fkb[m].mk.append(_t(lambda m=m: frame_poses(puma, q1[:m], ee)))
                if rtb is not None:
                    fkb[m].pe.append(rtb.ask("fkb", "puma", m)["dt"])
        for m in sizes:
            rows.append(fkb[m])
        for who, attr in (("mechkin", "mk"), ("rtb", "pe")):
            t = [statistics.median(getattr(fkb[m], attr)) for m in sizes
                 if getattr(fkb[m], attr)]
            if len(t) == len(sizes):
                slope = np.polyfit(np.log(sizes), np.log(t), 1)[0]
                notes.append(f"Batched FK cost ~ m^{slope:.2f} ({who}, m = "
                             f"{sizes[0]:,}-{sizes[-1]:,}).")

        # ---- single IK ------------------------------------------------------------------
        n_ik = 30 if quick else 100
        # the scenario defaults of `mechkin ik` (config/ik_spec.py): restarts 50, 1e-6 m / rad
        opts = IkOptions(restarts=50, tol_pos=1e-6, tol_ori=1e-6)
        for k, m in mechs.items():
            kern = kernel_for(m)
            T = frame_poses(m, qs[k][:n_ik], [m.end_effector])[:, 0]
            solve_ik(m, T[0], kernel=kern)  # compiled kernel and codebook loaded
            row = Row(f"single IK, {k}, `solve_ik` scenario defaults, per solve",
                      "rtb `ik_LM` (tol 1e-10)", "ms", 1e3 / n_ik)
            oks, okp, flg = [], [], []
            for _ in range(R):
                t0 = time.perf_counter()
                res = [solve_ik(m, Tk, kernel=kern, options=opts) for Tk in T]
                row.mk.append(time.perf_counter() - t0)
                oks.append(sum(r.status is IkStatus.OK for r in res))
                if rtb is not None:
                    ans = rtb.ask("ik", k, n_ik, opts.tol_pos, opts.tol_ori)
                    row.pe.append(ans["dt"])
                    okp.append(ans["ok"])
                    flg.append(ans["flag"])
            row.note = success_note(oks, okp, flg, n_ik)
            rows.append(row)

        rows += speed_rows.public_ik_rows(R, mechs, qs, rtb, Row, success_note)

        # ---- batched IK -----------------------------------------------------------------
        b_sizes = (1, 100, 2000) if quick else (1, 100, 5000)
        for k, m in mechs.items():
            for mb in b_sizes:
                T = frame_poses(m, qs[k][:mb], [m.end_effector])[:, 0]
                solve_ik_batch(m, T[:1], options=opts)
                row = Row(f"batched IK, {k}, `solve_ik_batch`, m = {mb:,}",
                          "rtb `ik_LM` loop", "/s", 1.0, per=mb)
                oks, okp, flg = [], [], []
                rr = R if mb <= 100 else max(2, R // 2)
                for _ in range(rr):
                    t0 = time.perf_counter()
                    br = solve_ik_batch(m, T, options=opts)
                    row.mk.append(time.perf_counter() - t0)
                    oks.append(int(sum(s is IkStatus.OK for s in br.status)))
                    if rtb is not None:
                        ans = rtb.ask("ik", k, mb, opts.tol_pos, opts.tol_ori)
                        row.pe.append(ans["dt"])
                        okp.append(ans["ok"])
                        flg.append(ans["flag"])
                row.note = success_note(oks, okp, flg, mb)
                rows.append(row)

        # ---- time-optimal path vs toppra ------------------------------------------------
        try:
            import bench_topp as bt
        except ImportError:
            bt = None
        if bt is None or bt.toppra is None:
            notes.append("toppra not installed (`pip install -e '.[bench]'`): the planner row "
                         "is not measured.")
        else:
            bt.toppra.setup_logging("WARNING")
            for with_va, label in ((False, "torque"), (True, "torque + qd + qdd")):
                ref = bt.tp_full(bt.N_CONVERGED, with_va)
                for N in (500, 1000):
                    row = Row(f"time-optimal path, park line, {label} limits, N = {N}",
                              "toppra (seidel)", "ms", 1e3)
                    bt.mk_full(N, with_va), bt.tp_full(N, with_va)
                    for _ in range(R):
                        t0 = time.perf_counter()
                        d_mk = bt.mk_full(N, with_va)
                        row.mk.append(time.perf_counter() - t0)
                        t0 = time.perf_counter()
                        d_tp = bt.tp_full(N, with_va)
                        row.pe.append(time.perf_counter() - t0)
                    row.note = (f"duration vs toppra N = {bt.N_CONVERGED}: mechkin "
                                f"{100 * (d_mk - ref) / ref:+.3f} %, toppra "
                                f"{100 * (d_tp - ref) / ref:+.3f} %")
                    rows.append(row)

            trows, tnotes = speed_rows.track_rows(R, bt, Row)
            rows += trows
            notes += tnotes

        # ---- one mechkin call; CLI fk 100k ---------------------------------------------
        env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
        env.pop("MECHKIN_JIT", None)  # as a user runs it
        py = sys.executable
        subprocess.run([py, "-m", "mechkin", "warmup"], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        ik_cmd = [py, "-m", "mechkin", "ik", str(ROOT / "scenarios" / "puma560_random_ik.yaml"),
                  "--no-plots", "-o", str(tmp / "ik_out")]
        imp_cmd = [py, "-c", "import numpy, scipy"]
        row = Row("`mechkin ik scenarios/puma560_random_ik.yaml --no-plots`, wall",
                  '`python -c "import numpy, scipy"`', "s", 1.0)
        cli_wall(ik_cmd, env)
        for _ in range(R):
            row.mk.append(cli_wall(ik_cmd, env))
            row.pe.append(cli_wall(imp_cmd, env))
        rows.append(row)
        steps = 20_000 if quick else 100_000
        from mechkin.config.scenario import load_scenario
        from mechkin.tasks.fk import independent_motion

        ver_cmd = [py, "-m", "mechkin", "--version"]
        fk_rows = {}
        for table in ("csv", "npz"):
            sc = tmp / f"fk100k_{table}.yaml"
            sc.write_text(FK100K.format(mech=ROOT / "mechanisms" / "puma560.yaml",
                                        stop=(steps - 1) * 0.001, table=table))
            fk_rows[table] = (sc, [py, "-m", "mechkin", "fk", str(sc), "--no-plots", "-o",
                                   str(tmp / f"fk_out_{table}")])
        _, qv = independent_motion(load_scenario(fk_rows["csv"][0]), puma)
        q_all = puma.assemble(qv, np.zeros((len(qv), 0)))
        rows_fk = {t: Row(f"`mechkin fk` of {steps:,} PUMA configurations "
                          f"(`outputs.table: {t}`), wall",
                          "batched API `frame_poses` on the same configurations", "s", 1.0)
                   for t in fk_rows}
        ver = []
        for _ in range(max(2, R // 2)):
            ver.append(cli_wall(ver_cmd, env))
            for t, (_, cmd) in fk_rows.items():
                rows_fk[t].mk.append(cli_wall(cmd, env))
                rows_fk[t].pe.append(_t(lambda: frame_poses(puma, q_all, ee)))
        for t, row in rows_fk.items():
            summ = json.loads((tmp / f"fk_out_{t}" / "summary.json").read_text())
            row.note = (f"in the CLI run: FK {summ['solve_time_s']:.3g} s, rates and "
                        f"singularity classes {summ['rates_time_s']:.2f} s; the rest is "
                        f"start-up, scenario, records and the table (`mechkin --version` "
                        f"alone: {statistics.median(ver):.2f} s)")
            rows.append(row)
        frows, fnotes = speed_rows.first_run_rows(R, Row)
        rows += frows
        notes += fnotes
        # ---- analytic IK vs EAIK / ssik (issue 26): per pose, its own table ----------------
        import bench_analytic_ik

        analytic = bench_analytic_ik.format_rows(
            bench_analytic_ik.analytic_rows(rounds=R, batch=1000 if quick else 10_000,
                                            quick=quick))
        if rtb is not None:
            rtb.close()
    took = (_dt.datetime.now(_dt.timezone.utc) - started).total_seconds()
    head = ("| work | mechkin (median) | peer (median) | mechkin / peer: median of paired "
            "rounds (range) | same run |\n|---|---|---|---|---|")
    body = "\n".join(r.line() for r in rows)
    text = (f"Measured by `python benchmarks/speed_table.py --write-readme` on "
            f"{started:%Y-%m-%d %H:%M} UTC ({took / 60:.0f} min, {R} interleaved rounds): "
            f"{mach}.\nRatios below 1: mechkin faster.\n\n"
            f"{head}\n{body}\n\n" + "\n".join(f"- {n}" for n in notes) + "\n"
            f"\nAnalytic IK per pose in the same run (`benchmarks/bench_analytic_ik.py`; "
            f"mechkin / peer, median of paired rounds):\n\n{analytic}\n")
    print(text)
    if a.write_readme:
        readme = ROOT / "README.md"
        src = readme.read_text()
        if BEGIN not in src or END not in src:
            sys.exit(f"README.md has no {BEGIN} ... {END} markers")
        pre, rest = src.split(BEGIN, 1)
        _, post = rest.split(END, 1)
        readme.write_text(f"{pre}{BEGIN}\n{text}{END}{post}")
        print(f"wrote the table into {readme}")


if __name__ == "__main__":
    main()

"""The cost of one ``mechkin`` call (issue 15): each command's wall time against
``python -c "import numpy, scipy"`` on the same machine, paired and interleaved.

Run as ``python benchmarks/bench_startup.py [--rounds 7] [--plots] [--baseline DIR]
[--importtime] [--phases]``. Every round runs, for each command, the reference
``python -c "import numpy, scipy"`` and then the command (and, with ``--baseline DIR``, the same
command from another checkout, e.g. ``git worktree add`` / ``git archive`` of the previous
commit), so each ratio pairs runs a second apart; the table gives the median of the paired
ratios and their range. The numba cache is warm (``python -m mechkin warmup`` first) and the
bytecode is compiled (one untimed run per command first; ``PYTHONDONTWRITEBYTECODE`` is
dropped from the children's environment, as an installed package has its ``.pyc`` files).

``--importtime``: a per-module breakdown of one ``mechkin ik`` run (``python -X importtime``),
cumulative milliseconds of the top-level imports, with the helper that owns each mechkin
module. ``--phases``: the same run's wall time by phase (start-up to the command, scenario,
solve, files), measured in the process by wrapping the phase functions.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REF = ["-c", "import numpy, scipy"]

# who owns which mechkin modules this session (tools OWNERS), for the import breakdown
OWNERS = [("mechkin.solvers.ik", "ik"), ("mechkin.tasks.ik", "ik"),
          ("mechkin.model.kinematics", "fk"), ("mechkin.model.closure", "fk"),
          ("mechkin.tasks.fk", "clifk"), ("mechkin.io.motion_out", "clifk"),
          ("mechkin.io.csv_out", "clifk"), ("mechkin.records.motion", "clifk"),
          ("mechkin", "startup")]


def commands(root: Path, out: Path, plots: bool) -> dict[str, list[str]]:
    """name -> arguments of ``python -m mechkin`` (outputs under ``out``)."""
    sc, me = root / "scenarios", root / "mechanisms"
    cmds = {
        "ik --no-plots": ["ik", str(sc / "puma560_random_ik.yaml"), "--no-plots", "-o",
                          str(out / "ik"), "--force"],
        "fk --no-plots": ["fk", str(sc / "kim1995_direct_drive_fk.yaml"), "--no-plots", "-o",
                          str(out / "fk"), "--force"],
        "--help": ["--help"],
        "--version": ["--version"],
        "info": ["info", str(me / "kim1995_direct_drive.yaml")],
        "check": ["check", str(sc / "puma560_random_ik.yaml")],
    }
    if plots:
        cmds["ik (plots)"] = cmds["ik --no-plots"][:2] + ["-o", str(out / "ikp"), "--force"]
        cmds["fk (plots)"] = cmds["fk --no-plots"][:2] + ["-o", str(out / "fkp"), "--force"]
    return cmds


def child_env(root: Path) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(root), MPLBACKEND="Agg")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env.pop("MECHKIN_JIT", None)  # as a user runs it
    return env


def timed(args: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """(wall, cpu) seconds of one child process; cpu = user + system."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(args)}: exit {proc.returncode}\n{proc.stderr[-2000:]}")
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def _fmt(xs: list[float], unit: str = "s") -> str:
    return f"{statistics.median(xs):.3f} {unit} ({min(xs):.3f}-{max(xs):.3f})"


def bench(rounds: int, plots: bool, baseline: Path | None, only: list[str] | None) -> None:
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as td:
        tmp = Path(td)
        trees = {"mechkin": ROOT}
        if baseline is not None:
            trees["baseline"] = baseline
        envs = {k: child_env(v) for k, v in trees.items()}
        cmds = {k: commands(v, tmp / k, plots) for k, v in trees.items()}
        names = [n for n in cmds["mechkin"] if only is None or n in only]
        for k in trees:
            subprocess.run([sys.executable, "-m", "mechkin", "warmup"], env=envs[k],
                           cwd=tmp, check=True, stdout=subprocess.DEVNULL)
            for n in names:  # untimed: bytecode, numba cache index, output folders
                timed(["-m", "mechkin", *cmds[k][n]], envs[k], tmp)
        timed(REF, envs["mechkin"], tmp)
        res: dict[tuple[str, str], list[tuple[float, float]]] = {}
        ref: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
        load0 = os.getloadavg()[0]
        for _ in range(rounds):
            for n in names:
                ref[n].append(timed(REF, envs["mechkin"], tmp))
                for k in trees:
                    res.setdefault((k, n), []).append(
                        timed(["-m", "mechkin", *cmds[k][n]], envs[k], tmp))
        all_ref = [w for n in names for w, _ in ref[n]]
        print(f"bench_startup: {rounds} interleaved rounds, {time.strftime('%Y-%m-%d %H:%M')} "
              f"UTC, load average {load0:.2f} at the start, {os.cpu_count()} CPUs, Python "
              f"{sys.version.split()[0]}")
        print(f'reference `python -c "import numpy, scipy"`: wall {_fmt(all_ref)}')
        print("ratio = command wall / the reference run just before it (median of the "
              "paired rounds, range); cpu = user + system of the command")
        print(f"| command | tree | wall median (range) | cpu median | ratio to import numpy, "
              f"scipy | {'ratio to baseline |' if baseline else ''}")
        print(f"|---|---|---|---|---|{'---|' if baseline else ''}")
        for n in names:
            for k in trees:
                runs = res[(k, n)]
                walls = [w for w, _ in runs]
                ratios = [w / r for (w, _), (r, _) in zip(runs, ref[n], strict=True)]
                extra = ""
                if baseline is not None:
                    if k == "mechkin":
                        b = [w for w, _ in res[("baseline", n)]]
                        rb = [w / x for w, x in zip(walls, b, strict=True)]
                        extra = f" {statistics.median(rb):.2f} ({min(rb):.2f}-{max(rb):.2f}) |"
                    else:
                        extra = " |"
                print(f"| `mechkin {n}` | {k} | {_fmt(walls)} | "
                      f"{statistics.median([c for _, c in runs]):.3f} s | "
                      f"{statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f}) |"
                      f"{extra}")


def owner(mod: str) -> str:
    for prefix, who in OWNERS:
        if mod == prefix or mod.startswith(prefix + "."):
            return who
    return "-"


def importtime(root: Path, top: int) -> None:
    """Per-module import breakdown of one warm ``mechkin ik`` run."""
    env = child_env(root)
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as td:
        args = commands(root, Path(td), False)["ik --no-plots"]
        subprocess.run([sys.executable, "-m", "mechkin", *args], env=env, cwd=td, check=True,
                       capture_output=True)
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "mechkin", *args],
                              env=env, cwd=td, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
    rows = []
    for ln in proc.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", ln)
        if m:
            rows.append((int(m.group(2)) / 1e3, int(m.group(1)) / 1e3,
                         len(m.group(3)) // 2, m.group(4)))
    total = sum(r[1] for r in rows)
    print(f"`python -X importtime -m mechkin ik scenarios/puma560_random_ik.yaml --no-plots`: "
          f"wall {wall:.2f} s (with the -X importtime overhead), imports {total / 1e3:.2f} s "
          f"in {len(rows)} modules")
    print("top-level imports (depth 0: imported first by mechkin code or the interpreter), "
          "cumulative ms, and the helper owning the mechkin module:")
    print("| module | cumulative ms | self ms | owner |")
    print("|---|---|---|---|")
    for cum, self_, _, mod in sorted((r for r in rows if r[2] == 0), reverse=True)[:top]:
        print(f"| {mod} | {cum:.1f} | {self_:.1f} | {owner(mod)} |")
    print("largest nested imports (cumulative ms >= 20, any depth), with their parent:")
    print("| module | cumulative ms | depth | imported by |")
    print("|---|---|---|---|")
    parents = []
    for i, r in enumerate(rows):
        par = next((rows[j][3] for j in range(i + 1, len(rows)) if rows[j][2] < r[2]), "-")
        parents.append(par)
    big = sorted(((r, p) for r, p in zip(rows, parents, strict=True) if r[0] >= 20 and r[2] > 0),
                 key=lambda x: -x[0][0])[:top]
    for (cum, _, depth, mod), par in big:
        print(f"| {mod} | {cum:.1f} | {depth} | {par} |")


PHASES = r'''
import functools, importlib, sys, time
T0 = time.perf_counter()
marks = []
def wrap(modname, attr, label):
    mod = importlib.import_module(modname)
    f = getattr(mod, attr)
    @functools.wraps(f)
    def g(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            marks.append((label, time.perf_counter() - t))
    setattr(mod, attr, g)
import mechkin.cli.shell as shell
orig = shell._execute
def ex(*a, **k):
    marks.append(("CLI and argument reading (to the command)",
                  time.perf_counter() - T0))
    t = time.perf_counter()
    import mechkin.io.report, mechkin.tasks, mechkin.tasks.common, mechkin.tasks.distributed
    marks.append(("imports of the run shell (io.report, tasks)", time.perf_counter() - t))
    wrap("mechkin.tasks.common", "load_task_scenario", "load and validate the scenario")
    wrap("mechkin.model", "load_mechanism", "  load the mechanism (in the task run)")
    wrap("mechkin.tasks", "run", "task run (mechanism, validation, solve, records)")
    import mechkin.records as rec
    f = rec.Report.write
    def w(self, *a, **k):
        t = time.perf_counter()
        try:
            return f(self, *a, **k)
        finally:
            marks.append(("write the files (Report.write)", time.perf_counter() - t))
    rec.Report.write = w
    return orig(*a, **k)
shell._execute = ex
sys.argv = ["mechkin"] + sys.argv[1:]
from mechkin.cli.app import main
try:
    main()
except SystemExit:
    pass
marks.append(("total in the process", time.perf_counter() - T0))
for n, t in marks:
    sys.stderr.write(f"PHASE {t:.3f} {n}\n")
'''


def phases(root: Path, rounds: int) -> None:
    env = dict(child_env(root), MECHKIN_FAST_EXIT="0")  # print the phases before leaving
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as td:
        args = commands(root, Path(td), False)["ik --no-plots"]
        per: dict[str, list[float]] = {}
        for i in range(rounds + 1):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-c", PHASES, *args], env=env, cwd=td,
                                  capture_output=True, text=True, check=True)
            wall = time.perf_counter() - t0
            if i == 0:
                continue
            per.setdefault("process wall (with the interpreter's start and teardown)",
                           []).append(wall)
            for ln in proc.stderr.splitlines():
                if ln.startswith("PHASE "):
                    _, t, name = ln.split(" ", 2)
                    per.setdefault(name, []).append(float(t))
    print(f"phases of `mechkin ik scenarios/puma560_random_ik.yaml --no-plots` "
          f"(median of {rounds} runs, s):")
    for name, ts in per.items():
        print(f"  {statistics.median(ts):7.3f}  {name}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--plots", action="store_true", help="also ik and fk with their plots")
    ap.add_argument("--baseline", type=Path, help="another checkout to time the same way")
    ap.add_argument("--only", help="comma-separated command names (e.g. 'ik --no-plots')")
    ap.add_argument("--importtime", action="store_true", help="import breakdown of the ik run")
    ap.add_argument("--phases", action="store_true", help="phases of the ik run")
    ap.add_argument("--top", type=int, default=25)
    a = ap.parse_args()
    only = [s.strip() for s in a.only.split(",")] if a.only else None
    if a.rounds > 0:
        bench(a.rounds, a.plots, a.baseline, only)
    if a.importtime:
        importtime(ROOT, a.top)
    if a.phases:
        phases(ROOT, max(3, min(a.rounds, 5)))


if __name__ == "__main__":
    main()

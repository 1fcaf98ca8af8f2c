"""`mechkin fk` of a long PUMA run through the CLI against the batched API (issue 15).

Run: ``python benchmarks/bench_cli_fk.py [--steps 100000] [--rounds 3]``.

The scenario is FK100K of benchmarks/speed_table.py (a PUMA 560 motion of ``--steps`` steps,
CSV on, plots and MCAP off), written three times with ``outputs.table`` csv / npz / parquet.
Each round runs, interleaved: the three CLI calls (wall of the whole process), ``python -m
mechkin --version`` (the fixed cost of one call: interpreter, imports, typer), and the batched
API ``frame_poses(puma, q, [ee])`` on the same configurations in this process. Reported:
medians, the ratio CLI / API of the whole wall, of the wall minus the ``--version`` start-up,
and of the wall minus a fresh process that has imported what the fk run imports and loaded the
scenario and mechanism (honestly: the API's time is below the interpreter's start-up).

Then a breakdown of one CLI run, in this process, each part timed alone (medians of the rounds):
scenario load, motion (the independent joints and their rates), FK (all links), rates (joint
rates, twists and accelerations of the end effector), singularity (reduced Jacobian, batched
SVD, classes), records (the rest of ``tasks.fk.run``: summary, columns), and each table writer
(csv / npz / parquet, to a temporary folder, with the atomic write's fsync for csv as the CLI).
"""

from __future__ import annotations

import argparse
import os
import statistics as st
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from timing import FK100K as SCENARIO  # noqa: E402 - the speed table's scenario

from mechkin.config.scenario import load_scenario  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.kinematics import forward_kinematics, frame_poses  # noqa: E402

#: CPU seconds (user + sys) of the last child run by :func:`wall`, per command label
CPU: dict[str, list[float]] = {}


def wall(cmd: list[str], env: dict[str, str], label: str | None = None) -> float:
    """Wall time of one run of ``cmd`` (cwd: a temporary folder, so ``python -m mechkin``
    imports the tree on ``PYTHONPATH``, not the current directory); its CPU time (user + sys,
    less sensitive to other processes on a shared machine) is kept in :data:`CPU`."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=tempfile.gettempdir(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(proc.pid, 0)
    dt = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"{cmd}: exit {proc.returncode}")
    if label is not None:
        CPU.setdefault(label, []).append(ru.ru_utime + ru.ru_stime)
    return dt


def timed(fn) -> tuple[tuple[float, float], object]:
    """(wall, CPU) seconds of one call, and its result."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return (time.perf_counter() - t0, time.process_time() - c0), out


def breakdown(path: Path, tmp: Path) -> dict[str, tuple[float, float]]:
    """One in-process fk run cut into its parts (each timed alone)."""
    from mechkin.io.atomic import atomic_write_text
    from mechkin.io.csv_out import format_csv
    from mechkin.io.table_out import write_table_file
    from mechkin.model.reduced import reduced_jacobian
    from mechkin.model.singularity import _cond_cols, reduced_scaling, resolve_length_scale
    from mechkin.tasks import fk as fk_task
    from mechkin.tasks.fk_batch import open_chain_derivatives

    out: dict[str, tuple[float, float]] = {}
    out["scenario load"], sc = timed(lambda: load_scenario(path))
    mech = load_mechanism(sc.mechanism_path)
    out["motion"], (t, qv, qd, qdd) = timed(lambda: fk_task.independent_motion_rates(sc, mech))
    q = mech.assemble(qv, np.zeros((len(t), 0)))
    out["FK (all links)"], kin = timed(lambda: forward_kinematics(mech, q))
    ee = [int(mech.end_effector)]
    out["rates + singularity"], _ = timed(
        lambda: open_chain_derivatives(mech, kin, qd, qdd, ee))

    def sing() -> None:
        Jr = reduced_jacobian(mech, q, ee[0], kin=kin)
        row, col = reduced_scaling(mech, resolve_length_scale(mech, None))
        _cond_cols(np.linalg.svd(Jr * row[None, :, None] * col[None, None, :],
                                 compute_uv=False), 6)

    out["  of which singularity (J_r, SVD)"], _ = timed(sing)
    out["tasks.fk.run (all of the above)"], rep = timed(lambda: fk_task.run(sc))
    out["records (run - parts)"] = tuple(
        r - a - b - c for r, a, b, c in zip(out["tasks.fk.run (all of the above)"],
                                            out["motion"], out["FK (all links)"],
                                            out["rates + singularity"], strict=True))
    cols = rep.data.columns
    out["csv text (format_csv)"], text = timed(lambda: format_csv(cols))
    out["csv write (encode + fsync)"], _ = timed(
        lambda: atomic_write_text(tmp / "fk.csv", text))
    out["npz writer"], _ = timed(lambda: write_table_file(tmp / "fk.npz", cols, "npz"))
    try:
        import pyarrow  # noqa: F401

        out["parquet writer"], _ = timed(
            lambda: write_table_file(tmp / "fk.parquet", cols, "parquet"))
    except ImportError:
        pass
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another mechkin source tree (e.g. `git archive` of an older commit) "
                    "whose `mechkin fk` (csv) is timed in the same rounds")
    a = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    py = sys.executable
    puma = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    ee = [int(puma.end_effector)]
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        tables = ["csv", "npz"]
        try:
            import pyarrow  # noqa: F401

            tables.append("parquet")
        except ImportError:
            print("pyarrow not installed: no parquet rows")
        paths = {}
        for tab in tables:
            paths[tab] = tmp / f"fk_{tab}.yaml"
            paths[tab].write_text(SCENARIO.format(mech=ROOT / "mechanisms" / "puma560.yaml",
                                                  stop=(a.steps - 1) * 0.001, table=tab))
        from mechkin.tasks.fk import independent_motion

        _, qv = independent_motion(load_scenario(paths["csv"]), puma)
        q_all = puma.assemble(qv, np.zeros((len(qv), 0)))
        frame_poses(puma, q_all, ee)  # warm (path plan)
        cmds = {tab: [py, "-m", "mechkin", "fk", str(p), "--no-plots", "-o",
                      str(tmp / f"out_{tab}")] for tab, p in paths.items()}
        version = [py, "-m", "mechkin", "--version"]
        # a fresh process up to the work: the fk run's imports, scenario and mechanism load
        loaded = [py, "-c", "import mechkin.cli.app, mechkin.tasks.fk, mechkin.io.report, "
                  "mechkin.io.table_out; from mechkin.config.scenario import load_scenario; "
                  "from mechkin.model import load_mechanism; "
                  f"load_mechanism(load_scenario({str(paths['csv'])!r}).mechanism_path)"]
        wall(cmds["csv"], env)  # warm the file cache
        T: dict[str, list[float]] = {k: [] for k in [*tables, "start-up", "loaded", "API"]}
        base_env = None
        if a.baseline is not None:
            base_env = dict(env, PYTHONPATH=str(a.baseline.resolve()))
            T["baseline csv"] = []
            base_cmd = [py, "-m", "mechkin", "fk", str(tmp / "fk_base.yaml"), "--no-plots",
                        "-o", str(tmp / "out_base")]
            (tmp / "fk_base.yaml").write_text(paths["csv"].read_text().replace(
                ", table: csv", ""))
        parts: dict[str, list[tuple[float, float]]] = {}
        for _ in range(a.rounds):
            for tab in tables:
                T[tab].append(wall(cmds[tab], env, tab))
            if base_env is not None:
                T["baseline csv"].append(wall(base_cmd, base_env, "baseline csv"))
            T["start-up"].append(wall(version, env, "start-up"))
            T["loaded"].append(wall(loaded, env, "loaded"))
            T["API"].append(timed(lambda: frame_poses(puma, q_all, ee))[0][0])
            for k, v in breakdown(paths["csv"], tmp).items():
                parts.setdefault(k, []).append(v)
        med = {k: st.median(v) for k, v in T.items()}
        api, start, loaded_s = med["API"], med["start-up"], med["loaded"]
        print(f"mechkin fk of {a.steps:,} PUMA configurations, {a.rounds} interleaved rounds "
              f"(medians; load average at the end {os.getloadavg()[0]:.2f})")
        print(f"  batched API frame_poses: {api:.4f} s; `python -m mechkin --version`: "
              f"{start:.3f} s; a fresh process with the fk run's imports, scenario and "
              f"mechanism loaded: {loaded_s:.3f} s")
        print("  | table | CLI wall [s] | CLI / API | (CLI - start-up) / API | "
              "(CLI - loaded) / API | rounds |")
        print("  |---|---|---|---|---|---|")
        for tab in tables:
            w = med[tab]
            print(f"  | {tab} | {w:.3f} | {w / api:.1f} | {(w - start) / api:.1f} | "
                  f"{(w - loaded_s) / api:.1f} | {', '.join(f'{x:.2f}' for x in T[tab])} |")
        if base_env is not None:
            same = (tmp / "out_base" / "fk.csv").read_bytes() == (
                tmp / "out_csv" / "fk.csv").read_bytes()
            w = med["baseline csv"]
            print(f"  | baseline ({a.baseline}) csv | {w:.3f} | {w / api:.1f} | "
                  f"{(w - start) / api:.1f} | {(w - loaded_s) / api:.1f} | "
                  f"{', '.join(f'{x:.2f}' for x in T['baseline csv'])} |")
            print(f"  fk.csv of the baseline and of this tree byte for byte the same: {same}; "
                  f"csv wall this / baseline: {med['csv'] / w:.2f}")
        print("  CPU time of the child processes (user + sys, medians) [s]: " + ", ".join(
            f"{k} {st.median(v):.3f}" for k, v in CPU.items()))
        print("  breakdown of one run (in process, each part alone, medians) [s]:")
        print(f"    {'':36s} {'wall':>8s} {'CPU':>8s}")
        for k, v in parts.items():
            print(f"    {k:36s} {st.median(x[0] for x in v):8.3f} "
                  f"{st.median(x[1] for x in v):8.3f}")
        sizes = {tab: sum(f.stat().st_size for f in (tmp / f"out_{tab}").iterdir()
                          if f.name.startswith("fk.")) for tab in tables}
        print("  table file sizes: " + ", ".join(f"{k} {v / 1e6:.1f} MB"
                                                 for k, v in sizes.items()))


if __name__ == "__main__":
    main()

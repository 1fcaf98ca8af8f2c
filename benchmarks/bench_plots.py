"""Per-figure plot times of bundled scenarios (issue 15: "plots drawn in well under a second").

Runs each scenario's task once (not timed), then writes its outputs with every plot function of
:mod:`mechkin.io.plots` and :mod:`mechkin.io.workspace_plots` wrapped by a timer, so each PNG is
timed from figure construction to the saved file. Prints one line per figure (best of
``--repeat`` writes: wall time and CPU time of the process; CPU time is steadier on a shared
machine) and the total.

    PYTHONPATH=. MPLBACKEND=Agg python benchmarks/bench_plots.py [SCENARIO.yaml ...]
        [--repeat N]

``--cli``: the plots' share of one CLI call instead: ``python -m mechkin <task> FILE --out DIR``
with and without ``--no-plots``, interleaved, ``--repeat`` times each (default 5), medians of
the wall time and of the children's CPU time (issue 29: the plots' fixed cost per run).

Default scenarios: the kim1995 fk scenarios (Stewart platform, direct-drive arm), the PUMA 560
random ik (50 targets), a joint-sweep workspace (PUMA 560), the task-space reachability and the
lee Fig. 2 / Fig. 4 maps.
"""

from __future__ import annotations

import argparse
import functools
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = [
    "scenarios/kim1995_stewart_fk.yaml",
    "scenarios/kim1995_direct_drive_fk.yaml",
    "scenarios/puma560_random_ik.yaml",
    "scenarios/puma560_workspace.yaml",
    "scenarios/puma560_reachability.yaml",
    "scenarios/lee_fig2_gamma_range_r075.yaml",
    "scenarios/lee_fig4_isotropy_r050.yaml",
]


def _instrument(log: list[tuple[str, float, float]]) -> None:
    """Wrap every public ``plot_*`` function of the two plot modules with a timer."""
    import mechkin.io.plots as plots
    import mechkin.io.workspace_plots as wplots

    for mod in (plots, wplots):
        for name in dir(mod):
            fn = getattr(mod, name)
            if not (name.startswith("plot_") and callable(fn)) or hasattr(fn, "_timed"):
                continue

            def timed(*a, _fn=fn, _name=name, **k):
                t0, c0 = time.perf_counter(), time.process_time()
                out = _fn(*a, **k)
                path = a[0] if a else k.get("path", "")
                log.append((f"{Path(str(path)).name} ({_name})", time.perf_counter() - t0,
                            time.process_time() - c0))
                return out

            timed._timed = True  # type: ignore[attr-defined]
            setattr(mod, name, functools.wraps(fn)(timed))


def _task(path: Path) -> str:
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("task:"):
            return line.split(":", 1)[1].strip()
    raise SystemExit(f"{path}: no 'task:' line")


def cli_share(scenarios: list[str], repeat: int) -> int:
    """Median wall and CPU time of ``python -m mechkin`` with plots and with ``--no-plots``."""
    import os
    import statistics
    import subprocess

    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        for sc in scenarios:
            path = Path(sc) if Path(sc).is_absolute() else ROOT / sc
            times: dict[str, list[tuple[float, float]]] = {"plots": [], "--no-plots": []}
            for r in range(repeat):
                for mode in times:
                    cmd = [sys.executable, "-m", "mechkin", _task(path), str(path), "--out",
                           str(Path(tmp) / f"{path.stem}-{r}-{mode}")]
                    if mode != "plots":
                        cmd.append(mode)
                    c0 = os.times()
                    t0 = time.perf_counter()
                    subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, check=False)
                    wall = time.perf_counter() - t0
                    c1 = os.times()
                    cpu = (c1.children_user - c0.children_user) + (c1.children_system
                                                                   - c0.children_system)
                    times[mode].append((wall, cpu))
            med = {m: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
                   for m, v in times.items()}
            (pw, pc), (nw, nc) = med["plots"], med["--no-plots"]
            print(f"{path.name}: with plots wall {pw:.2f} s cpu {pc:.2f} s; --no-plots wall "
                  f"{nw:.2f} s cpu {nc:.2f} s; plots add wall {pw - nw:.2f} s, cpu {pc - nc:.2f} s"
                  f" (medians of {repeat}, interleaved)")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", default=DEFAULT)
    ap.add_argument("--repeat", type=int, default=None,
                    help="writes per scenario, best shown (default 2); --cli: runs per mode "
                         "(default 5)")
    ap.add_argument("--cli", action="store_true",
                    help="time whole CLI calls with and without --no-plots")
    args = ap.parse_args(argv)
    if args.cli:
        return cli_share(args.scenarios, args.repeat or 5)
    args.repeat = args.repeat or 2

    import matplotlib

    matplotlib.use("Agg")
    import mechkin

    log: list[tuple[str, float, float]] = []
    _instrument(log)
    # matplotlib's first figure pays font-cache and 3-D toolkit imports: pay them once, apart
    from mechkin.io.plots import plot_series

    with tempfile.TemporaryDirectory() as tmp:
        import numpy as np

        t0 = time.perf_counter()
        plot_series(Path(tmp) / "warm.png", np.arange(3.0), np.zeros((3, 1)), ["a"], "x", "y", "t")
        first = "(first figure of the process: imports, fonts)"
        print(f"{first:<58} {time.perf_counter() - t0:7.3f} s")
        log.clear()
        grand = cgrand = 0.0
        for sc in args.scenarios:
            path = Path(sc) if Path(sc).is_absolute() else ROOT / sc
            rep = mechkin.run(path)
            best: dict[str, tuple[float, float]] = {}
            for r in range(args.repeat):
                log.clear()
                rep.write(Path(tmp) / f"{path.stem}-{r}", plots=True)
                for name, dt, dc in log:
                    old = best.get(name, (float("inf"), float("inf")))
                    best[name] = (min(dt, old[0]), min(dc, old[1]))
            total = sum(b[0] for b in best.values())
            ctotal = sum(b[1] for b in best.values())
            grand += total
            cgrand += ctotal
            print(f"{path.name}: {len(best)} figures, wall {total:.3f} s, cpu {ctotal:.3f} s")
            for name, (dt, dc) in best.items():
                print(f"    {name:<54} wall {dt:7.3f} s  cpu {dc:7.3f} s")
        print(f"all figures: wall {grand:.3f} s, cpu {cgrand:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

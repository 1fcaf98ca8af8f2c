"""``mechkin warmup [MECH.yaml ...]``: compile the numba IK and FK kernels ahead of first use.

Without a mechanism the kernels of a tiny open chain, a tiny four-bar and a tiny arm with a
mimic joint are compiled, which covers every mechanism (the kernels are specialised on argument
types, not on a mechanism).
One progress line per kernel names it, then says how long it took and whether it was compiled
or loaded from numba's cache (:func:`mechkin.solvers.ik.accel.configure_numba_cache` picks the
folder).
"""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.common import handle_errors


def warmup_cli(
    mechanisms: list[Path] = typer.Argument(
        None, help="Mechanism files whose IK kernels to compile (default: a tiny open chain, "
                   "a tiny four-bar and a tiny arm with a mimic joint, which cover every "
                   "mechanism)"),
) -> None:
    """Compile the numba IK kernels now (once per machine; later runs load them in ~1 s)."""
    _warmup(mechanisms or [])


@handle_errors
def _warmup(paths: list[Path]) -> None:
    import os
    import sys
    import tempfile
    import time

    from mechkin.model import load_mechanism
    from mechkin.solvers.ik import accel

    given = [load_mechanism(p) for p in paths]  # bad input first, also without numba
    if not accel.compiled_lm_available():
        why = ("MECHKIN_JIT=0" if os.environ.get("MECHKIN_JIT") == "0"
               else 'numba is not installed (pip install "mechkin[fast]")')
        typer.echo(f"mechkin warmup: nothing to compile: {why}; the numpy back end is used")
        return
    folder = accel.configure_numba_cache() or str(accel.PACKAGE_DIR / "__pycache__")
    from mechkin.solvers.ik import warm

    with tempfile.TemporaryDirectory() as td:
        if given:
            mechs = given
        else:
            mechs = []
            for name, text in (("open.yaml", warm.TINY_OPEN), ("closed.yaml", warm.TINY_CLOSED),
                               ("coupled.yaml", warm.TINY_COUPLED)):
                (Path(td) / name).write_text(text)
                mechs.append(load_mechanism(Path(td) / name))
        typer.echo(f"numba cache: {folder}")
        t_all = time.perf_counter()
        for item in warm.warm(mechs):
            if isinstance(item, tuple):
                name, role = item
                sys.stdout.write(f"  {name:30s} {role:28s} ... ")
                sys.stdout.flush()
                continue
            how = ("loaded from cache" if item.was_cached else "compiled"
                   if item.was_cached is False else "ready")
            typer.echo(f"{item.seconds:6.1f} s ({how})")
        from mechkin.model import fk_accel

        sys.stdout.write(f"  {'fk_jit.plan_poses':30s} {'forward kinematics':28s} ... ")
        sys.stdout.flush()
        dt, cached = fk_accel.warm()
        how = "loaded from cache" if cached else "compiled" if cached is False else "ready"
        typer.echo(f"{dt:6.1f} s ({how})")
        from mechkin.solvers.track.dpct import warm_compiled_stage

        sys.stdout.write(f"  {'dp_jit.dp_stage':30s} {'track DP stage':28s} ... ")
        sys.stdout.flush()
        typer.echo(f"{warm_compiled_stage():6.1f} s (ready)")
        typer.echo(f"done in {time.perf_counter() - t_all:.1f} s")

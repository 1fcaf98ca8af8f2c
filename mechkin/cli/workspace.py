"""``mechkin workspace SCENARIO.yaml``: isotropy and workspace maps (lee Figs. 2-5), joint sweeps.

Two kinds of ``workspace:`` section (:mod:`mechkin.config.workspace_spec`):

* ``lee_spherical``: :func:`mechkin.solvers.workspace.run_lee_workspace` with the design taken
  from the mechanism file (R, r, P, stroke) and overridden by ``parameters``; writes the sigma_KI
  contour maps per named gamma set, gamma_min/gamma_max (Fig. 2), CSV grids and summary.json.
* ``joint_sweep``: the independent joints swept on a grid or at random (seeded); for a closed
  chain the loop closure (kim1995 §5.1) is solved for every sample from the home configuration.
  Writes the reachable positions of a frame (``points.csv``), projections and slices
  (``workspace_slices.png``), the bounding box, voxel and convex-hull volumes and the statistics
  of Yoshikawa's manipulability ``w = prod(sigma_i(J))`` and of the isotropy index
  ``sigma_min/sigma_max`` of the (reduced, for closed chains) Jacobian
  ``J = J_v + J_w dq_w/dq_v`` of the frame with respect to the independent joints.
* ``task_space``: a grid (or seeded random set) of task-space poses through the batched ik
  (:func:`mechkin.solvers.sweeps.task_space_sweep`): reachability and dexterity (isotropy,
  condition number, Yoshikawa manipulability) at the solutions (``task_points.csv``,
  ``task_space.png``).

A lee scenario with ``design: {parameter, values}`` computes its maps once per value
(:func:`mechkin.solvers.sweeps.lee_design_sweep`) and writes them side by side with a comparison
table. Design values and task-space chunks run as jobs on ``--workers``/``workers:`` local
processes or, with ``--scheduler ADDRESS`` or ``executor: {kind: dask, address}``, on a Dask
cluster (``pip install 'mechkin[dask]'``). A progress bar is drawn on stderr when it is a
terminal (``--progress/--no-progress`` to force); stdout carries only the result line or JSON.
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import typer

from mechkin.cli.common import (
    JsonOption,
    OutOption,
    PlotsOption,
    default_out_dir,
    evaluate_expect,
    handle_errors,
    load_task_scenario,
    report,
    report_expect,
)
from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError

MAX_SWEEP_SAMPLES = 5_000_000


def workspace_cli(
    scenario: Path = typer.Argument(..., help="Scenario YAML (task: workspace)"),
    out: OutOption = None,
    json_out: JsonOption = False,
    plots: PlotsOption = True,
    workers: int | None = typer.Option(None, "--workers", "-j", min=1, help="Local worker "
                                       "processes for sweeps [default: workers: of the "
                                       "scenario, else min(cpu count, jobs)]"),
    scheduler: str | None = typer.Option(None, "--scheduler", help="Dask scheduler address "
                                         "(tcp://host:port): run the sweep jobs on that "
                                         "cluster (needs mechkin[dask])"),
    progress: bool | None = typer.Option(None, "--progress/--no-progress", help="Progress bar "
                                         "on stderr [default: when stderr is a terminal]"),
) -> None:
    """Workspace and isotropy maps (lee's spherical mechanism), design sweeps, joint and
    task-space sweeps of any mechanism."""
    code = _workspace(scenario, out, json_out, plots, workers, scheduler, progress)
    raise typer.Exit(code)


@handle_errors
def _workspace(scenario: Path, out: Path | None, json_out: bool, plots: bool,
               workers: int | None = None, scheduler: str | None = None,
               progress: bool | None = None) -> int:
    sc = load_task_scenario(scenario, "workspace")
    summary, code = run_workspace(scenario=sc, out_dir=default_out_dir(sc.name, out), plots=plots,
                                  workers=workers, scheduler=scheduler, progress=progress)
    report(summary, json_out, _one_line(sc.name, summary))
    return code


def _one_line(name: str, s: dict[str, Any]) -> str:
    if "design" in s:
        d = s["design"]
        parts = []
        for v in d["per_value"]:
            fr = [f"{k} {e['volume_fraction']:.3f}" for k, e in v.get("isotropy", {}).items()]
            if "gamma_range" in v:
                fr.append(f"gamma range {v['gamma_range']['defined_fraction']:.3f}")
            parts.append(f"{d['parameter']} = {v['value']:g}: {', '.join(fr)}")
        body = "volume fractions " + "; ".join(parts)
    elif s.get("kind") == "task_space":
        body = (f"{s['n_reachable']}/{s['n_poses']} poses reached, isotropy median "
                f"{s['isotropy'].get('median', 0.0):.3f}")
    elif s.get("kind") == "lee_spherical":
        parts = []
        for set_name, e in s.get("isotropy", {}).items():
            parts.append(f"{set_name}: volume fraction {e['volume_fraction']:.3f}")
        if "gamma_range" in s:
            parts.append(f"gamma range defined on {s['gamma_range']['defined_fraction']:.3f}")
        body = "; ".join(parts)
    else:
        body = (f"{s['n_reachable']}/{s['n_samples']} samples reachable, voxel volume "
                f"{s['volume']['voxel_m3']:.4g} m^3")
    failed = [c["key"] for c in s.get("expect", []) if not c["ok"]]
    tail = f"; expect failed: {', '.join(failed)}" if failed else ""
    return f"{name}: {s['status']} ({body}){tail}; wrote {s['out_dir']}"


def run_workspace(
    *,
    scenario: Scenario,
    out_dir: Path,
    plots: bool = True,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
) -> tuple[dict[str, Any], int]:
    """Run a workspace scenario and write every output to ``out_dir``.

    Parameters
    ----------
    scenario : Scenario
    out_dir : Path
    plots : bool
        Write PNG plots.
    workers : int, optional
        Local worker processes of design and task-space sweeps (overrides ``workers:``).
    scheduler : str, optional
        Dask scheduler address (overrides ``executor:``).
    progress : bool, optional
        Progress bar on stderr; None: when stderr is a terminal.

    Returns
    -------
    summary : dict
    code : int
        0 when every expect held, else 1.
    """
    ex = _execution(scenario, workers, scheduler, progress)
    kind = scenario.section.kind
    if kind == "lee_spherical":
        if scenario.section.design is not None:
            return _run_lee_design(scenario, Path(out_dir), plots, ex)
        return _run_lee(scenario, Path(out_dir), plots)
    if kind == "task_space":
        return _run_task_space(scenario, Path(out_dir), plots, ex)
    return _run_joint_sweep(scenario, Path(out_dir), plots)


def _execution(sc: Scenario, workers: int | None, scheduler: str | None,
               progress: bool | None) -> dict[str, Any]:
    """workers / dask address / progress flag from the CLI, else the scenario."""
    spec = sc.section
    address = scheduler
    if address is None and spec.executor is not None and spec.executor.kind == "dask":
        address = spec.executor.address
    if address is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            where = "--scheduler" if scheduler is not None else sc.doc.where(
                ("workspace", "executor"))
            raise ConfigError(f"{where}: running on a Dask cluster needs the optional extra "
                              "(pip install 'mechkin[dask]')") from None
    show = sys.stderr.isatty() if progress is None else bool(progress)
    return {"workers": workers if workers is not None else spec.workers, "address": address,
            "progress": show, "force_terminal": progress is True}


@contextlib.contextmanager
def _progress_bar(ex: dict[str, Any], description: str
                  ) -> Iterator[Callable[[int, int], None] | None]:
    """A rich progress bar on stderr (never stdout) when enabled, as a progress callback."""
    if not ex["progress"]:
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True, force_terminal=ex["force_terminal"] or None)
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=console, transient=False) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


def _finish(scenario: Scenario, summary: dict[str, Any]) -> tuple[list[dict[str, Any]], bool]:
    checks = evaluate_expect(summary, scenario.spec.expect)
    ok = all(c["ok"] for c in checks)
    return checks, ok


# --------------------------------------------------------------------------- lee


def lee_design(scenario: Scenario) -> dict[str, Any]:
    """R, r, center, stroke (SI) of lee's mechanism: lee §3.2 defaults < mechanism file <
    the section's ``parameters``; also where each value came from."""
    design: dict[str, Any] = {"R": 1.0, "r": 0.5, "center": (0.0, 0.0, 1.0), "stroke": (0.5, 2.0)}
    source = dict.fromkeys(design, "lee §3.2")
    if scenario.mechanism_path is not None:
        from mechkin.model import load_mechanism

        mech = load_mechanism(scenario.mechanism_path)
        fr = set(mech.frame_names)
        if {"base_u1", "base_u2", "base_u3"} <= fr:
            p = mech.frame_offset[mech.frame_index("base_u1")][:3, 3]
            design["R"], source["R"] = float(np.hypot(p[0], p[1])), "mechanism"
        if "plate_s1" in fr:
            p = mech.frame_offset[mech.frame_index("plate_s1")][:3, 3]
            design["r"], source["r"] = float(np.hypot(p[0], p[1])), "mechanism"
        if "center" in fr:
            p = mech.frame_offset[mech.frame_index("center")][:3, 3]
            design["center"], source["center"] = tuple(float(v) for v in p), "mechanism"
        if "l1" in mech.joint_names:
            j = mech.joint_index("l1")
            lo, hi = float(mech.lower[j]), float(mech.upper[j])
            if math.isfinite(lo) and math.isfinite(hi):
                design["stroke"], source["stroke"] = (lo, hi), "mechanism"
    par = scenario.section.parameters
    if par is not None:
        L = length_factor(scenario.spec.units.length)
        for key in ("r", "R", "center", "stroke"):
            v = getattr(par, key)
            if v is None:
                continue
            design[key] = float(v) * L if key in ("r", "R") else tuple(float(x) * L for x in v)
            source[key] = "scenario"
    design["source"] = source
    return design


def _lee_params(sc: Scenario, design: dict[str, Any]) -> dict[str, Any]:
    """Keyword arguments of :func:`mechkin.solvers.workspace.lee_workspace` (SI)."""
    spec = sc.section
    A = angle_factor(sc.spec.units.angle)
    full = (-90.0 * math.pi / 180.0, 90.0 * math.pi / 180.0)
    params: dict[str, Any] = {
        "r": design["r"],
        "R": design["R"],
        "center": design["center"],
        "stroke": design["stroke"],
        "threshold": spec.threshold,
        "method": spec.method or "closed_form",
    }
    for ax in ("alpha", "beta"):
        g = getattr(spec, ax)
        params[f"{ax}_range"] = full if g is None else (g.range[0] * A, g.range[1] * A)
        params[f"n_{ax}"] = 181 if g is None else g.n
    if spec.isotropy_maps:
        params["gamma_sets"] = {k: [v * A for v in vs] for k, vs in spec.isotropy_maps.items()}
    gr = spec.gamma_range
    if gr is not None:
        params.update(
            gamma_sweep=(gr.range[0] * A, gr.range[1] * A),
            n_gamma_sweep=gr.n,
            n_alpha_sweep=gr.n_alpha,
            n_beta_sweep=gr.n_beta,
            gamma_mode=gr.mode,
            gamma_ref=None if gr.ref is None else gr.ref * A,
        )
    return params


def _head(sc: Scenario, kind: str) -> dict[str, Any]:
    return {"scenario": sc.name, "task": "workspace", "kind": kind, "status": "ok"}


def _complete(sc: Scenario, summary: dict[str, Any], out_dir: Path,
              write: Callable[[dict[str, Any]], Any]) -> tuple[dict[str, Any], int]:
    """Evaluate the expects on the complete summary, then write the outputs (``write(summary)``
    returns the files written) and report the expects; returns (summary, exit code)."""
    checks, ok = _finish(sc, summary)
    if checks:
        summary["expect"] = checks
    summary["out_dir"] = str(out_dir)
    summary["files"] = [*write(summary)]
    report_expect(checks, sc.path)
    return summary, 0 if ok else 1


def _run_lee(sc: Scenario, out_dir: Path, plots: bool) -> tuple[dict[str, Any], int]:
    from mechkin.io.workspace_plots import write_lee_workspace
    from mechkin.solvers.workspace import lee_workspace

    design = lee_design(sc)
    params = _lee_params(sc, design)
    t0 = time.perf_counter()
    try:
        rec = lee_workspace(**params)
    except ValueError as exc:  # a grid the solver refuses (should not pass the schema)
        raise ConfigError(f"{sc.doc.where(('workspace',))}: {exc}") from None
    summary: dict[str, Any] = {
        **_head(sc, "lee_spherical"),
        "design_source": design["source"],
        **rec.summary,
        "compute_time_s": time.perf_counter() - t0,
    }
    return _complete(sc, summary, out_dir, lambda sm: write_lee_workspace(
        rec, out_dir, plots=plots, csv=sc.spec.outputs.csv, extra_summary=sm))


def _run_lee_design(sc: Scenario, out_dir: Path, plots: bool, ex: dict[str, Any]
                    ) -> tuple[dict[str, Any], int]:
    from mechkin.io.workspace_plots import design_summary, write_lee_design_sweep
    from mechkin.solvers.sweeps import default_workers, lee_design_sweep

    spec = sc.section
    dspec = spec.design
    design = lee_design(sc)
    params = _lee_params(sc, design)
    L = length_factor(sc.spec.units.length)
    values = [v * L for v in dspec.values]
    if dspec.parameter in ("l_min", "l_max"):
        lo, hi = design["stroke"]
        bad = [v for v in values if (v >= hi if dspec.parameter == "l_min" else v <= lo)]
        if bad:
            raise ConfigError(f"{sc.doc.where(('workspace', 'design', 'values'))}: "
                              f"{dspec.parameter} values {bad} do not leave l_min < l_max "
                              f"(stroke {lo:g}..{hi:g})")
    params.pop(dspec.parameter, None)
    workers = ex["workers"] if ex["workers"] is not None else default_workers(len(values))
    t0 = time.perf_counter()
    with _progress_bar(ex, f"{sc.name}: {dspec.parameter} sweep") as cb:
        try:
            sweep = lee_design_sweep(dspec.parameter, values, workers=workers,
                                     address=ex["address"], progress=cb, **params)
        except ValueError as exc:
            raise ConfigError(f"{sc.doc.where(('workspace',))}: {exc}") from None
    design["source"][dspec.parameter if dspec.parameter in ("r", "R") else "stroke"] = "design"
    summary: dict[str, Any] = {
        **_head(sc, "lee_spherical"),
        "design_source": design["source"],
        **design_summary(sweep),
        "execution": {"executor": "dask" if ex["address"] else "process",
                      "workers": None if ex["address"] else min(workers, len(values)),
                      "jobs": len(values)},
        "compute_time_s": time.perf_counter() - t0,
    }
    return _complete(sc, summary, out_dir, lambda sm: write_lee_design_sweep(
        sweep, out_dir, plots=plots, csv=sc.spec.outputs.csv, extra_summary=sm))


# --------------------------------------------------------------------------- task space


def _task_poses(sc: Scenario) -> np.ndarray:
    """Target poses (m, 4, 4), SI, of a task_space section."""
    from mechkin.solvers.sweeps import task_space_grid, task_space_random
    from mechkin.spatial.euler_conventions import euler_matrix
    from mechkin.spatial.rotations import matrix_from_quat

    spec = sc.section
    L = length_factor(sc.spec.units.length)
    A = angle_factor(sc.spec.units.angle)
    o = spec.orientation
    R0: np.ndarray | None = np.eye(3)
    if o is not None and o.euler is not None:
        R0 = euler_matrix(o.euler.convention, np.asarray(o.euler.angles, dtype=float) * A)
    elif o is not None and o.quaternion is not None:
        R0 = matrix_from_quat(np.asarray(o.quaternion, dtype=float))
    elif o is not None and o.random:
        R0 = None
    axes = [spec.positions[k] for k in "xyz"]
    if spec.method == "grid":
        vals = []
        for a in axes:
            if a.value is not None:
                vals.append(np.array([a.value * L]))
            elif a.n == 1:
                vals.append(np.array([0.5 * (a.range[0] + a.range[1]) * L]))
            else:
                vals.append(np.linspace(a.range[0] * L, a.range[1] * L, a.n))
        total = int(np.prod([v.size for v in vals]))
        if total > MAX_SWEEP_SAMPLES:
            raise ConfigError(f"{sc.doc.where(('workspace', 'positions'))}: the grid has "
                              f"{total} poses, more than {MAX_SWEEP_SAMPLES}")
        assert R0 is not None
        return task_space_grid(vals, R0)
    box = [(a.value * L, a.value * L) if a.value is not None else
           (a.range[0] * L, a.range[1] * L) for a in axes]
    return task_space_random(box, spec.samples, spec.seed, R0)


def _sweep_frame(sc: Scenario, mech: Any) -> int:
    """The frame a sweep maps: ``workspace.frame`` or the mechanism's end effector."""
    spec = sc.section
    if spec.frame is not None:
        if spec.frame not in mech.frame_names:
            raise ConfigError(f"{sc.doc.where(('workspace', 'frame'))}: unknown frame "
                              f"{spec.frame!r}")
        return mech.frame_index(spec.frame)
    if mech.end_effector is not None:
        return int(mech.end_effector)
    raise ConfigError(f"{sc.doc.where(('workspace',))}: the mechanism has no end_effector; "
                      "give frame")


def _run_task_space(sc: Scenario, out_dir: Path, plots: bool, ex: dict[str, Any]
                    ) -> tuple[dict[str, Any], int]:
    from mechkin.io.workspace_plots import write_task_space
    from mechkin.model import load_mechanism
    from mechkin.solvers.sweeps import task_space_summary, task_space_sweep

    spec = sc.section
    if sc.mechanism_path is None:
        raise ConfigError(f"{sc.doc.where(('mechanism',))}: a task_space sweep needs a mechanism")
    mech = load_mechanism(sc.mechanism_path)
    f = _sweep_frame(sc, mech)
    T_P = _task_poses(sc)
    t0 = time.perf_counter()
    n_jobs = max(1, -(-T_P.shape[0] // spec.chunk))
    with _progress_bar(ex, f"{sc.name}: ik chunks") as cb:
        rec = task_space_sweep(sc.mechanism_path, T_P, frame=f, weights=spec.weights,
                               restarts=spec.restarts, seed=spec.seed, max_iter=spec.max_iter,
                               chunk=spec.chunk, workers=ex["workers"], address=ex["address"],
                               progress=cb)
    names = mech.independent_names
    joint_cols = [f"{n}_{'m' if mech.s[mech.independent[i]] == 1 else 'rad'}"
                  for i, n in enumerate(names)]
    summary: dict[str, Any] = {
        **_head(sc, "task_space"),
        "mechanism": mech.name,
        "method": spec.method,
        "seed": spec.seed,
        "frame": mech.frame_names[f],
        "restarts": spec.restarts,
        **task_space_summary(rec),
        "definition": {
            "reachable": "the batched lm ik (with seeded random restarts) reaches the pose: "
                         "verified errors below 1e-6 m / 1e-6 rad with the joints within "
                         "limits; a lower bound of the reachable set",
            "isotropy": "sigma_min / sigma_max of the frame Jacobian (rows omega, v; SI) "
                        "w.r.t. the independent joints at the solution (closed chains: "
                        "J_v + J_w dq_w/dq_v); 0 at singular or unreached poses",
            "isotropy_position": "the same for the position rows",
            "condition_number": "sigma_max / sigma_min (1/isotropy), capped at 1e16",
            "manipulability": "Yoshikawa w = product of the singular values of that Jacobian",
        },
        "execution": {"executor": "dask" if ex["address"] else "process", "jobs": n_jobs,
                      "chunk": spec.chunk},
        "compute_time_s": time.perf_counter() - t0,
    }
    title = (f"{mech.name}: task-space sweep of {mech.frame_names[f]} "
             f"({int(rec.reachable.sum())}/{rec.reachable.size} poses reached, {spec.method})")
    return _complete(sc, summary, out_dir, lambda sm: write_task_space(
        rec, out_dir, sm, joint_columns=joint_cols, plots=plots, csv=sc.spec.outputs.csv,
        title=title))


# --------------------------------------------------------------------------- joint sweep


def _sweep_values(sc: Scenario, mech: Any) -> tuple[np.ndarray, list[str]]:
    """Independent joint values (m, n_v) in SI and the names of the swept joints."""
    spec = sc.section
    doc = sc.doc
    names = mech.independent_names
    given = spec.joints or {}
    problems = [f"{doc.where(('workspace', 'joints', k))}: not an independent joint "
                f"(independent: {', '.join(names)})" for k in given if k not in names]
    if problems:
        raise ConfigError(problems)
    swept = [n for n in names if n in given] if (given or spec.method == "grid") else list(names)
    if not swept:
        raise ConfigError(f"{doc.where(('workspace', 'joints'))}: method grid needs at least "
                          "one joint with n")
    home = mech.home[mech.independent]
    ranges: dict[str, tuple[float, float]] = {}
    for name in swept:
        j = mech.joint_index(name)
        f = length_factor(sc.spec.units.length) if mech.s[j] == 1 else angle_factor(
            sc.spec.units.angle)
        js = given.get(name)
        if js is not None and js.range is not None:
            lo, hi = js.range[0] * f, js.range[1] * f
        else:
            lo, hi = float(mech.lower[j]), float(mech.upper[j])
            if not (math.isfinite(lo) and math.isfinite(hi)):
                problems.append(f"{doc.where(('workspace', 'joints', name))}: joint {name!r} has "
                                "no limits; give a range")
        ranges[name] = (lo, hi)
        if spec.method == "grid" and (js is None or js.n is None):
            problems.append(f"{doc.where(('workspace', 'joints', name))}: method grid needs n")
    if problems:
        raise ConfigError(problems)
    if spec.method == "grid":
        counts = [given[n].n for n in swept]
        total = int(np.prod(counts, dtype=np.float64))
        if total > MAX_SWEEP_SAMPLES:
            raise ConfigError(f"{doc.where(('workspace', 'joints'))}: the grid has {total} "
                              f"samples, more than {MAX_SWEEP_SAMPLES}")
        axes = [np.linspace(*ranges[n], c) for n, c in zip(swept, counts, strict=True)]
        mesh = np.meshgrid(*axes, indexing="ij")
        qv = np.tile(home, (total, 1))
        for n, g in zip(swept, mesh, strict=True):
            qv[:, names.index(n)] = g.ravel()
    else:
        rng = np.random.default_rng(spec.seed)
        qv = np.tile(home, (spec.samples, 1))
        for n in swept:
            qv[:, names.index(n)] = rng.uniform(*ranges[n], size=spec.samples)
    return qv, swept


def _singular_values(J: np.ndarray) -> np.ndarray:
    """Singular values (m, k), descending, of a batch of matrices; finite (0 where NaN)."""
    J = np.where(np.isfinite(J), J, 0.0)
    return np.linalg.svd(J, compute_uv=False)


def _stats(x: np.ndarray) -> dict[str, float | int]:
    from mechkin.solvers.workspace import sigma_statistics

    return sigma_statistics(x)


def _run_joint_sweep(sc: Scenario, out_dir: Path, plots: bool) -> tuple[dict[str, Any], int]:
    from mechkin.io.output_dir import OutputDir
    from mechkin.model import load_mechanism
    from mechkin.model.closure import ClosureStatus, dependent_sensitivity, solve_closure
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian

    spec = sc.section
    if sc.mechanism_path is None:
        raise ConfigError(f"{sc.doc.where(('mechanism',))}: a joint_sweep needs a mechanism")
    mech = load_mechanism(sc.mechanism_path)
    f = _sweep_frame(sc, mech)
    qv, swept = _sweep_values(sc, mech)
    m = qv.shape[0]
    L = length_factor(sc.spec.units.length)
    t0 = time.perf_counter()
    closed = mech.is_closed and len(mech.dependent) > 0
    q = np.empty((m, mech.n))
    status = np.empty(m, dtype=object)
    pos = np.empty((m, 3))
    w_full = np.zeros(m)
    iso_full = np.zeros(m)
    iso_pos = np.zeros(m)
    q_w0 = mech.home[mech.dependent]
    for a in range(0, m, spec.chunk):
        b = min(m, a + spec.chunk)
        if closed:
            res = solve_closure(mech, qv[a:b], q_w0)
            q[a:b] = res.q
            status[a:b] = [s.value for s in res.status]
        else:
            q[a:b] = mech.assemble(qv[a:b], np.zeros((b - a, 0)))
            status[a:b] = ClosureStatus.CONVERGED.value
        kin = forward_kinematics(mech, q[a:b])
        pos[a:b] = kin.frames(mech, [f])[:, 0, :3, 3]
        if spec.manipulability:
            J = frame_jacobian(mech, kin, f)
            Jr = J[:, :, mech.independent]
            if closed:
                Jr = Jr + J[:, :, mech.dependent] @ dependent_sensitivity(mech, q[a:b])
            s = _singular_values(Jr)
            sp = _singular_values(Jr[:, 3:6, :])
            w_full[a:b] = np.prod(s, axis=1)
            iso_full[a:b] = np.where(s[:, 0] > 0, s[:, -1] / np.maximum(s[:, 0], 1e-300), 0.0)
            iso_pos[a:b] = np.where(sp[:, 0] > 0, sp[:, -1] / np.maximum(sp[:, 0], 1e-300), 0.0)
    converged = status == ClosureStatus.CONVERGED.value
    within = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
    finite = np.all(np.isfinite(pos), axis=1) & np.all(np.isfinite(q), axis=1)
    reach = converged & within & finite
    pos = np.where(np.isfinite(pos), pos, 0.0)
    q = np.where(np.isfinite(q), q, 0.0)
    for arr in (w_full, iso_full, iso_pos):
        arr[~reach] = 0.0  # not a pose of the mechanism: reported 0, marked by reachable = 0
    elapsed = time.perf_counter() - t0
    P = pos[reach]
    volume: dict[str, Any] = {"voxel_m3": 0.0, "voxel_edge_m": None, "convex_hull_m3": 0.0}
    bbox: dict[str, Any] = {}
    if P.shape[0]:
        lo, hi = P.min(axis=0), P.max(axis=0)
        bbox = {"min_m": lo.tolist(), "max_m": hi.tolist(), "size_m": (hi - lo).tolist()}
        edge = spec.voxel * L if spec.voxel is not None else max(float((hi - lo).max()) / 40.0,
                                                                 1e-6)
        cells = np.unique(np.floor((P - lo) / edge).astype(np.int64), axis=0)
        volume = {"voxel_m3": float(cells.shape[0] * edge**3), "voxel_edge_m": edge,
                  "occupied_voxels": int(cells.shape[0]), "convex_hull_m3": 0.0}
        try:
            from scipy.spatial import ConvexHull

            if P.shape[0] >= 4:
                volume["convex_hull_m3"] = float(ConvexHull(P).volume)
        except Exception:  # noqa: BLE001 - degenerate (planar) clouds have no hull volume
            volume["convex_hull_m3"] = 0.0
    names = mech.independent_names
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "task": "workspace",
        "kind": "joint_sweep",
        "mechanism": mech.name,
        "status": "ok",
        "method": spec.method,
        "seed": spec.seed if spec.method == "monte_carlo" else None,
        "swept_joints": swept,
        "frame": mech.frame_names[f],
        "closed_chain": bool(closed),
        "n_samples": int(m),
        "n_reachable": int(reach.sum()),
        "reachable_fraction": float(reach.mean()) if m else 0.0,
        "n_not_converged": int((~converged).sum()),
        "n_outside_limits": int((converged & ~within).sum()),
        "bounding_box": bbox,
        "volume": volume,
        "definition": {
            "reachable": "loop closure converged (closed chains) and every joint within limits",
            "manipulability": "Yoshikawa w = product of the singular values of the frame "
                              "Jacobian (rows omega, v; SI) w.r.t. the independent joints "
                              "(closed chains: J_v + J_w dq_w/dq_v)",
            "isotropy": "sigma_min / sigma_max of that Jacobian (position rows only for "
                        "isotropy_position); 0 at singular poses",
            "volume": "voxel_m3: occupied cubes of edge voxel_edge_m; convex_hull_m3: hull of "
                      "the reachable points (an upper bound for non-convex workspaces)",
        },
        "compute_time_s": elapsed,
    }
    if spec.manipulability:
        summary["manipulability"] = _stats(w_full[reach])
        summary["isotropy"] = _stats(iso_full[reach])
        summary["isotropy_position"] = _stats(iso_pos[reach])
    checks, ok = _finish(sc, summary)
    if checks:
        summary["expect"] = checks
    summary["out_dir"] = str(out_dir)
    with OutputDir(out_dir) as od:
        if sc.spec.outputs.csv:
            cols: dict[str, Any] = {"sample": np.arange(m)}
            for i, n in enumerate(names):
                unit = "m" if mech.s[mech.independent[i]] == 1 else "rad"
                cols[f"{n}_{unit}"] = qv[:, i]
            cols.update(x_m=pos[:, 0], y_m=pos[:, 1], z_m=pos[:, 2], status=status,
                        within_limits=within, reachable=reach)
            if spec.manipulability:
                cols.update(manipulability=w_full, isotropy=iso_full, isotropy_position=iso_pos)
            od.write_csv("points.csv", cols)
        if plots and P.shape[0]:
            _plot_cloud(od.path_for("workspace_slices.png"), P,
                        iso_pos[reach] if spec.manipulability else None, spec.slices, L,
                        title=f"{mech.name}: reachable positions of {mech.frame_names[f]} "
                              f"({reach.sum()}/{m} samples, {spec.method})")
        summary["files"] = [*od.files, "summary.json"]
        od.write_json("summary.json", summary)
    report_expect(checks, sc.path)
    return summary, 0 if ok else 1


def _plot_cloud(path: Path, P: np.ndarray, colour: np.ndarray | None, slices: Any, L: float,
                *, title: str) -> None:
    """Three projections of the point cloud and up to three slabs normal to one axis."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    axis_names = "xyz"
    k = axis_names.index(slices.axis) if slices is not None else 2
    extent = float(np.ptp(P, axis=0).max()) or 1.0
    if slices is not None and slices.at:
        planes = [v * L for v in slices.at][:3]
    else:
        planes = [float(np.quantile(P[:, k], qq)) for qq in (0.25, 0.5, 0.75)]
    thick = slices.thickness * L if (slices is not None and slices.thickness) else extent / 25.0
    others = [i for i in range(3) if i != k]
    fig = Figure(figsize=(14, 9), layout="constrained")
    FigureCanvasAgg(fig)
    c = colour if colour is not None else "tab:blue"
    kw = {"s": 2, "c": c, "cmap": "viridis", "vmin": 0.0, "vmax": 1.0} if colour is not None \
        else {"s": 2, "c": c}
    sc_ = None
    for p, (i, j) in enumerate([(0, 1), (0, 2), (1, 2)]):
        ax = fig.add_subplot(2, 3, p + 1)
        sc_ = ax.scatter(P[:, i], P[:, j], **kw)
        ax.set_xlabel(f"{axis_names[i]} [m]")
        ax.set_ylabel(f"{axis_names[j]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"projection on {axis_names[i]}{axis_names[j]}")
    for p, z in enumerate(planes):
        ax = fig.add_subplot(2, 3, 4 + p)
        sel = np.abs(P[:, k] - z) <= thick / 2
        ckw = dict(kw)
        if colour is not None:
            ckw["c"] = colour[sel]
        ax.scatter(P[sel, others[0]], P[sel, others[1]], **ckw)
        ax.set_xlabel(f"{axis_names[others[0]]} [m]")
        ax.set_ylabel(f"{axis_names[others[1]]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"slice {axis_names[k]} = {z:.3g} m ± {thick / 2:.2g}\n"
                     f"({int(sel.sum())} points)", fontsize=9)
    if colour is not None and sc_ is not None:
        fig.colorbar(sc_, ax=fig.axes, shrink=0.6, label="isotropy (position rows)")
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=100, format="png")

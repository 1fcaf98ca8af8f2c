"""The workspace task: isotropy and workspace maps (lee Figs. 2-5), design, joint and task-space
sweeps. A validated ``workspace:`` scenario -> :class:`mechkin.records.Report`; writes nothing.

Kinds of section (:mod:`mechkin.config.workspace_spec`):

* ``lee_spherical``: :func:`mechkin.solvers.workspace.maps.lee_workspace` with the design taken
  from the mechanism file (R, r, P, stroke) and overridden by ``parameters``: sigma_KI maps
  per named gamma set and gamma_min/gamma_max (Fig. 2). With ``design: {parameter, values}``
  the maps are computed once per value (:func:`mechkin.solvers.workspace.sweeps.lee_design_sweep`)
  with a comparison table.
* ``joint_sweep``: the independent joints on a grid or at random (seeded); for a closed chain
  the loop closure (kim1995 §5.1) is solved for every sample, continued from a solved
  neighbour so the sweep keeps one assembly mode (:func:`mechkin.solvers.workspace.joint_sweep.joint_sweep`;
  mode changes and closure failures are counted): reachable positions of a frame, bounding
  box, voxel and convex-hull volumes, statistics of Yoshikawa's manipulability and of the
  isotropy of the reduced frame Jacobian.
* ``task_space``: a grid (or seeded random set) of task-space poses through the batched ik
  (:func:`mechkin.solvers.workspace.sweeps.task_space_sweep`): reachability and dexterity.

Every kind runs as jobs on ``workers`` local processes or on a Dask cluster (``scheduler`` /
``executor: {kind: dask, address}``, or the run's :mod:`mechkin.tasks.distributed` options):
design values, task-space chunks, joint-sweep subtrees and blocks, the maps of a single lee
scenario; the record is the one of a single process. A progress bar (jobs, map sets or samples)
is drawn on stderr when asked (``progress=True``; None: when stderr is a terminal).

Imports: config, model, solvers, spatial, records, tasks.common (never io/ or cli/).
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.records import Report
from mechkin.records.workspace import WorkspaceOutput
from mechkin.tasks.common import expect_messages, output_flags, with_expect

MAX_SWEEP_SAMPLES = 5_000_000


def run(scenario: Scenario, workers: int | None = None, scheduler: str | None = None,
        progress: bool | None = False) -> Report:
    """Run a workspace scenario.

    Parameters
    ----------
    scenario : Scenario
    workers : int, optional
        Local worker processes (overrides ``workers:`` and the run's --workers).
    scheduler : str, optional
        Dask scheduler address (overrides ``executor:``).
    progress : bool, optional
        Progress bar on stderr; None: when stderr is a terminal.

    Returns
    -------
    Report
        Writer ``workspace`` (:mod:`mechkin.io.workspace_out`); exit code 1 when an expect
        failed.
    """
    ex = _execution(scenario, workers, scheduler, progress)
    check_workspace_budget(scenario, ex)
    kind = scenario.section.kind
    if kind == "lee_spherical":
        if scenario.section.design is not None:
            return _run_lee_design(scenario, ex)
        return _run_lee(scenario, ex)
    if kind == "task_space":
        return _run_task_space(scenario, ex)
    return _run_joint_sweep(scenario, ex)


def check_budget(scenario: Scenario) -> None:
    """The run's budget checks (memory, worker count) with the scenario's own execution
    settings, without solving."""
    check_workspace_budget(scenario, _execution(scenario, None, None, False))


def _grid_size(axes: list[Any]) -> int:
    n = 1
    for a in axes:
        n *= max(int(getattr(a, "n", None) or 1), 1)
    return n


def check_workspace_budget(sc: Scenario, ex: dict[str, Any]) -> None:
    """Estimate the sweep's peak memory from the scenario (grid sizes x joints and frames,
    samples, poses) and refuse it beyond the budget, before any work (mechkin.tasks.budget)."""
    from mechkin.tasks import budget

    spec = sc.section
    doc = sc.doc
    if ex.get("workers") is not None and not ex.get("address"):
        budget.check_workers(doc.where(("workspace", "workers")), int(ex["workers"]))
    if spec.kind == "lee_spherical":
        cells = (_grid_size([spec.alpha, spec.beta]) if spec.alpha and spec.beta else 91 * 91)
        gammas = sum(len(v) for v in (spec.isotropy_maps or {}).values())
        est = 8.0 * 60 * cells * max(gammas, 1)
        if spec.gamma_range is not None:
            g = spec.gamma_range
            est += 8.0 * 30 * g.n * g.n_alpha * g.n_beta
        est += 8.0 * 20 * len(spec.poses or [])
        budget.check(doc.where(("workspace",)), est, f"a lee map of {cells} alpha-beta cells "
                     f"x {max(gammas, 1)} gammas")
        return
    from mechkin.model import load_mechanism

    mech = load_mechanism(sc.mechanism_path)
    per = 8.0 * (6 * mech.n + 16 * (mech.n_links + len(mech.frame_names)) + 6 * mech.n * 4)
    if spec.kind == "joint_sweep":
        if spec.method == "monte_carlo" or spec.samples is not None:
            m = int(spec.samples or 0)
        else:
            m = _grid_size(list((spec.joints or {}).values()))
        budget.check(doc.where(("workspace",)), 2.0 * per * m,
                     f"a joint sweep of {m} samples of {mech.name} ({mech.n} joints)")
    else:
        axes = [a for a in (getattr(spec, "positions", None) or {}).values()] if isinstance(
            getattr(spec, "positions", None), dict) else []
        m = int(spec.samples or 0) or _grid_size(axes) + len(spec.poses or [])
        budget.check(doc.where(("workspace",)), 3.0 * per * m,
                     f"a task-space sweep of {m} poses of {mech.name} ({mech.n} joints)")


def _execution(sc: Scenario, workers: int | None, scheduler: str | None,
               progress: bool | None) -> dict[str, Any]:
    """workers / dask address / progress flag from the options, else the scenario."""
    from mechkin.tasks.distributed import Execution, resolve

    spec = sc.section
    ctx = resolve(workers, scheduler, None)
    address = ctx.address
    from_file = False
    if address is None and spec.executor is not None and spec.executor.kind == "dask":
        address, from_file = spec.executor.address, True
    if address is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            where = sc.doc.where(("workspace", "executor")) if from_file else "--scheduler"
            raise ConfigError(f"{where}: running on a Dask cluster needs the optional extra "
                              "(pip install 'mechkin[dask]')") from None
    n = ctx.workers if ctx.workers is not None else spec.workers
    if progress is None:
        progress = ctx.progress
    ex = Execution(workers=n, address=address, progress=progress,
                   where="--workers" if ctx.workers is not None else
                   sc.doc.where(("workspace", "workers")))
    show = sys.stderr.isatty() if progress is None else bool(progress)
    return {"workers": n, "address": address, "progress": show,
            "force_terminal": progress is True, "ex": ex}


def _progress_bar(ex: dict[str, Any], description: str) -> Any:
    """The shared progress bar (:mod:`mechkin.tasks.progress`) for the resolved options."""
    from mechkin.tasks.progress import progress_bar

    flag = False if not ex["progress"] else (True if ex["force_terminal"] else None)
    return progress_bar(flag, description)


def _head(sc: Scenario, kind: str) -> dict[str, Any]:
    return {"scenario": sc.name, "task": "workspace", "kind": kind, "status": "ok"}


def _report(sc: Scenario, summary: dict[str, Any], out: WorkspaceOutput,
            first: dict[str, Any] | None = None) -> Report:
    """The report: expects evaluated on ``summary``; ``first`` (the solver's own summary)
    leads the written summary.json, in its key order."""
    checks = with_expect(summary, sc)
    full = {**first, **summary} if first is not None else summary
    return Report(task="workspace", scenario=sc.name, summary=full, checks=checks,
                  solver_ok=True, writer="workspace", data=out, outputs=output_flags(sc),
                  scenario_path=sc.path, messages=expect_messages(checks, sc.path))


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
    """Keyword arguments of :func:`mechkin.solvers.workspace.maps.lee_workspace` (SI)."""
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


def _listed_poses(sc: Scenario, columns: tuple[str, ...], optional: tuple[str, ...] = ()
                  ) -> np.ndarray | None:
    """The section's ``poses`` (inline rows) or ``poses_csv`` (columns ``columns`` and, all
    or none, ``optional``) as an array (m, k) in the file's units; None when neither is given."""
    import csv

    spec = sc.section
    if spec.poses is not None:
        return np.asarray(spec.poses, dtype=np.float64)
    if spec.poses_csv is None:
        return None
    path = (sc.doc.path.parent / spec.poses_csv).resolve()
    if not path.is_file():
        raise ConfigError(f"{sc.doc.where(('workspace', 'poses_csv'))}: file not found: "
                          f"{spec.poses_csv} (resolved to {path})")
    with path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    if len(rows) < 2:
        raise ConfigError(f"{path}:1: expected a header row and at least one pose")
    head = [h.strip() for h in rows[0]]
    missing = [c for c in columns if c not in head]
    if missing:
        extra = f" [{', '.join(optional)}]" if optional else ""
        raise ConfigError(f"{path}:1: missing column(s) {', '.join(missing)} (expected "
                          f"{', '.join(columns)}{extra})")
    given_opt = [c for c in optional if c in head]
    if given_opt and len(given_opt) != len(optional):
        raise ConfigError(f"{path}:1: give all of {', '.join(optional)} or none")
    cols = [head.index(c) for c in (*columns, *given_opt)]
    out = np.empty((len(rows) - 1, len(cols)))
    for i, r in enumerate(rows[1:], start=2):
        try:
            out[i - 2] = [float(r[c]) for c in cols]
        except (ValueError, IndexError):
            raise ConfigError(f"{path}:{i}: expected numbers in {', '.join(head[c] for c in cols)}"
                              ) from None
    if not np.all(np.isfinite(out)):
        raise ConfigError(f"{path}:1: non-finite numbers in the poses")
    if given_opt and np.any(np.sum(out[:, len(columns):] ** 2, axis=1) < 1e-18):
        raise ConfigError(f"{path}:1: expected non-zero quaternions (qw, qx, qy, qz)")
    if out.shape[0] > MAX_SWEEP_SAMPLES:
        raise ConfigError(f"{path}:1: {out.shape[0]} poses, more than {MAX_SWEEP_SAMPLES}")
    return out


def _run_lee(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.solvers.workspace.maps import lee_workspace

    design = lee_design(sc)
    params = _lee_params(sc, design)
    listed = _listed_poses(sc, ("alpha", "beta", "gamma"))
    if listed is not None:
        params["poses"] = listed * angle_factor(sc.spec.units.angle)
    t0 = time.perf_counter()
    split = ex["ex"].split
    try:
        with _progress_bar(ex, f"{sc.name}: maps") as cb:
            if split:  # one job per map (mechkin.solvers.workspace.sweeps.lee_workspace_jobs)
                from mechkin.solvers.workspace.sweeps import lee_map_jobs, lee_workspace_jobs

                n_jobs = len(lee_map_jobs(params))
                rec = lee_workspace_jobs(**params, workers=ex["workers"],
                                         address=ex["address"], progress=cb)
            else:
                rec = lee_workspace(**params, progress=cb)
    except ValueError as exc:  # a grid the solver refuses (should not pass the schema)
        raise ConfigError(f"{sc.doc.where(('workspace',))}: {exc}") from None
    summary: dict[str, Any] = {
        **_head(sc, "lee_spherical"),
        "design_source": design["source"],
        **rec.summary,
        "compute_time_s": time.perf_counter() - t0,
    }
    if split:
        summary["execution"] = ex["ex"].describe(n_jobs)
    return _report(sc, summary, WorkspaceOutput("lee_spherical", rec), first=rec.summary)


def _run_lee_design(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.solvers.workspace.sweeps import default_workers, design_summary, lee_design_sweep

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
    ds = design_summary(sweep)
    summary: dict[str, Any] = {
        **_head(sc, "lee_spherical"),
        "design_source": design["source"],
        **ds,
        "execution": {"executor": "dask" if ex["address"] else "process",
                      "workers": None if ex["address"] else min(workers, len(values)),
                      "jobs": len(values)},
        "compute_time_s": time.perf_counter() - t0,
    }
    return _report(sc, summary, WorkspaceOutput("design", sweep), first=ds)


# --------------------------------------------------------------------------- task space


def _task_poses(sc: Scenario) -> np.ndarray:
    """Target poses (m, 4, 4), SI, of a task_space section."""
    from mechkin.solvers.workspace.sweeps import task_space_grid, task_space_random
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
    listed = _listed_poses(sc, ("x", "y", "z"), ("qw", "qx", "qy", "qz"))
    if listed is not None:
        T = np.tile(np.eye(4), (listed.shape[0], 1, 1))
        T[:, :3, 3] = listed[:, :3] * L
        if listed.shape[1] == 7:
            T[:, :3, :3] = matrix_from_quat(listed[:, 3:7])
        else:
            assert R0 is not None
            T[:, :3, :3] = R0
        return T
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


NORMALIZED_DEFINITION = (
    "sigma_min / sigma_max of the Jacobian with its translational rows divided by the "
    "characteristic length L (prismatic columns multiplied by L): dimensionless, so invariant "
    "under a change of length unit (the raw isotropy is not); unlike lee's sigma_KI, which "
    "uses Euler-angle rates of a purely rotational mechanism, it uses the angular velocity")


def _char_length(sc: Scenario) -> float | None:
    L = sc.section.characteristic_length
    return None if L is None else float(L) * length_factor(sc.spec.units.length)


def _char_length_entry(sc: Scenario, value: float | None) -> dict[str, Any]:
    given = sc.section.characteristic_length is not None
    return {"value_m": value, "source": "scenario" if given else
            "minimised: the L maximising the mean normalized isotropy (global conditioning "
            "index) over the reachable samples"}


def _joint_columns(mech: Any) -> list[str]:
    return [f"{n}_{'m' if mech.s[mech.independent[i]] == 1 else 'rad'}"
            for i, n in enumerate(mech.independent_names)]


def _run_task_space(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.model import load_mechanism
    from mechkin.solvers.workspace.sweeps import task_space_summary, task_space_sweep

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
                               progress=cb, length=_char_length(sc))
    summary: dict[str, Any] = {
        **_head(sc, "task_space"),
        "mechanism": mech.name,
        "method": spec.method or "poses",
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
            "isotropy_normalized": NORMALIZED_DEFINITION,
        },
        "characteristic_length": _char_length_entry(sc, rec.characteristic_length),
        "execution": {"executor": "dask" if ex["address"] else "process", "jobs": n_jobs,
                      "chunk": spec.chunk},
        "compute_time_s": time.perf_counter() - t0,
    }
    title = (f"{mech.name}: task-space sweep of {mech.frame_names[f]} "
             f"({int(rec.reachable.sum())}/{rec.reachable.size} poses reached, "
             f"{spec.method or 'listed poses'})")
    return _report(sc, summary, WorkspaceOutput("task_space", rec, title=title,
                                                joint_columns=_joint_columns(mech)))


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
    # a grid sweeps the joints given with n; monte_carlo sweeps every independent joint (a range
    # given for some keeps the others at their limits, or a full turn if they have none)
    swept = [n for n in names if n in given] if spec.method == "grid" else list(names)
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
            if not (math.isfinite(lo) and math.isfinite(hi)) and mech.s[j] == 0:
                lo, hi = -math.pi, math.pi  # a revolute joint without limits: a full turn
            elif not (math.isfinite(lo) and math.isfinite(hi)):
                problems.append(f"{doc.where(('workspace', 'joints', name))}: joint {name!r} "
                                "has no limits; give a range, e.g. "
                                f"'{name}: {{range: [0, 100]}}' (file length unit)")
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


def _run_joint_sweep(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.model import load_mechanism
    from mechkin.solvers.workspace.joint_sweep import joint_sweep, point_cloud_volume
    from mechkin.solvers.workspace.maps import sigma_statistics

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
    grid_shape = tuple(spec.joints[n].n for n in swept) if spec.method == "grid" else None
    split = ex["ex"].split
    jobs_kw: dict[str, Any] = {}
    if split:  # jobs of samples / continuation subtrees (mechkin.solvers.workspace.joint_sweep)
        from mechkin.solvers.workspace.sweeps import mechanism_spec, run_jobs

        n_w = ex["workers"] if ex["address"] is None else None
        jobs_kw = {"run_jobs": lambda fn, jobs, prog: run_jobs(
                       fn, jobs, workers=n_w, address=ex["address"], progress=prog),
                   "n_jobs": 4 * (n_w or 4), "mechanism": mechanism_spec(sc.mechanism_path)}
    with _progress_bar(ex, f"{sc.name}: {'jobs' if split else 'samples'}") as cb:
        rec = joint_sweep(mech, qv, f, chunk=spec.chunk, manipulability=spec.manipulability,
                          grid_shape=grid_shape, seed_from=spec.seed_from,
                          mode_jump=spec.mode_jump, progress=cb, length=_char_length(sc),
                          **jobs_kw)
    reach = rec.reachable
    elapsed = time.perf_counter() - t0
    bbox, volume = point_cloud_volume(rec.position[reach],
                                      spec.voxel * L if spec.voxel is not None else None)
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "task": "workspace",
        "kind": "joint_sweep",
        "mechanism": mech.name,
        "status": "ok",
        "method": spec.method,
        "seed": spec.seed if spec.method == "monte_carlo" else None,
        "swept_joints": swept,
        "full_turn_joints": [n for n in swept if mech.s[mech.joint_index(n)] == 0 and not (
            spec.joints and n in spec.joints and spec.joints[n].range is not None) and not (
            np.isfinite(mech.lower[mech.joint_index(n)])
            and np.isfinite(mech.upper[mech.joint_index(n)]))],
        "frame": mech.frame_names[f],
        "closed_chain": bool(closed),
        "n_samples": int(m),
        "n_reachable": int(reach.sum()),
        "reachable_fraction": float(reach.mean()) if m else 0.0,
        "n_not_converged": int((~rec.converged).sum()),
        "n_outside_limits": int((rec.converged & ~rec.within_limits).sum()),
        "continuation": {
            "seed_from": spec.seed_from if closed else None,
            "mode_jump": spec.mode_jump,
            "n_roots": int((rec.seed < 0).sum()) if closed else 0,
            "n_mode_changes": int(rec.mode_change.sum()),
            "n_closure_failures": int((~rec.converged).sum()),
            "n_reseeded_from_home": int(rec.reseeded.sum()),
        },
        "bounding_box": bbox,
        "volume": volume,
        "definition": {
            "reachable": "loop closure converged (closed chains) and every joint within limits",
            "full_turn_joints": "revolute joints without limits (and no range given), swept "
                                "over a full turn [-pi, pi]",
            "continuation": "closed chains: each sample's loop closure starts from a solved "
                            "neighbour (grid step / nearest neighbour, first-order predictor), "
                            "else from home; mode_change: the dependent joints left that "
                            "predictor by more than mode_jump x the step of the independent "
                            "joints (max norms, SI), i.e. another assembly mode",
            "manipulability": "Yoshikawa w = product of the singular values of the frame "
                              "Jacobian (rows omega, v; SI) w.r.t. the independent joints "
                              "(closed chains: J_v + J_w dq_w/dq_v)",
            "isotropy": "sigma_min / sigma_max of that Jacobian (position rows only for "
                        "isotropy_position); 0 at singular poses",
            "isotropy_normalized": NORMALIZED_DEFINITION,
            "volume": "voxel_m3: occupied cubes of edge voxel_edge_m; convex_hull_m3: hull of "
                      "the reachable points (an upper bound for non-convex workspaces)",
        },
        "compute_time_s": elapsed,
    }
    if split:
        summary["execution"] = ex["ex"].describe(jobs_kw["n_jobs"])
    if spec.manipulability:
        summary["manipulability"] = sigma_statistics(rec.manipulability[reach])
        summary["isotropy"] = sigma_statistics(rec.isotropy[reach])
        summary["isotropy_position"] = sigma_statistics(rec.isotropy_position[reach])
        summary["isotropy_normalized"] = sigma_statistics(rec.isotropy_normalized[reach])
        summary["characteristic_length"] = _char_length_entry(sc, rec.characteristic_length)
    sl = spec.slices
    slices = None if sl is None else {
        "axis": sl.axis, "at": [v * L for v in sl.at] if sl.at else None,
        "thickness": sl.thickness * L if sl.thickness else None}
    title = (f"{mech.name}: reachable positions of {mech.frame_names[f]} "
             f"({reach.sum()}/{m} samples, {spec.method})")
    return _report(sc, summary, WorkspaceOutput("joint_sweep", rec, title=title,
                                                joint_columns=_joint_columns(mech),
                                                slices=slices))

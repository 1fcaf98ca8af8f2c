"""The workspace task's ``lee_spherical`` kind: isotropy and workspace maps (lee Figs. 2-5).

:func:`mechkin.solvers.workspace.maps.lee_workspace` with the design taken from the mechanism
file (R, r, P, stroke) and overridden by ``parameters`` (:func:`lee_design`); with
``design: {parameter, values}`` the maps once per value
(:func:`mechkin.solvers.workspace.sweeps.lee_design_sweep`). Split out of ``workspace.py``
(issue 23: modules that fit in a head).

Imports: config, solvers, records, tasks.workspace_common (never io/ or cli/).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.records import Report
from mechkin.records.workspace import WorkspaceOutput
from mechkin.solvers.result import Stopped
from mechkin.tasks import budget
from mechkin.tasks.workspace_common import (
    _head,
    _listed_poses,
    _progress_bar,
    _report,
)

_NONE_FINISHED = ("--max-time: stopped before the first {what} finished (on the cluster); no "
                  "output was changed")


def _stop() -> Any:
    """The stop hook under ``--max-time`` (keep the finished maps or values), else None."""
    return budget.overrun if budget.time_limit() is not None else None


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


def _run_lee(sc: Scenario, ex: dict[str, Any]) -> Report:
    from mechkin.solvers.workspace.maps import lee_workspace

    design = lee_design(sc)
    params = _lee_params(sc, design)
    listed = _listed_poses(sc, ("alpha", "beta", "gamma"))
    if listed is not None:
        params["poses"] = listed * angle_factor(sc.spec.units.angle)
    t0 = time.perf_counter()
    split = ex["ex"].split
    from mechkin.solvers.workspace.sweeps import lee_map_jobs

    n_jobs = len(lee_map_jobs(params))
    try:  # --max-time: stop between two maps, keep the maps finished (each whole)
        with _progress_bar(ex, f"{sc.name}: maps", deadline=False) as cb:
            if split:  # one job per map (mechkin.solvers.workspace.sweeps.lee_workspace_jobs)
                from mechkin.solvers.workspace.sweeps import lee_workspace_jobs

                rec = lee_workspace_jobs(**params, workers=ex["workers"],
                                         address=ex["address"], progress=cb, stop=_stop())
            else:
                rec = lee_workspace(**params, progress=cb, stop=_stop())
    except ValueError as exc:  # a grid the solver refuses (should not pass the schema)
        raise ConfigError(f"{sc.doc.where(('workspace',))}: {exc}") from None
    except Stopped:  # on a cluster, before the first map finished
        raise budget.TimeLimitExceeded(_NONE_FINISHED.format(what="map")) from None
    done = len(rec.isotropy) + (rec.gamma_range is not None) + (rec.poses is not None)
    if done < n_jobs:
        budget.note_done(done, n_jobs, "maps")
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
    with _progress_bar(ex, f"{sc.name}: {dspec.parameter} sweep", deadline=False) as cb:
        try:  # --max-time: stop between two values, keep the values finished in a row
            sweep = lee_design_sweep(dspec.parameter, values, workers=workers,
                                     address=ex["address"], progress=cb, stop=_stop(),
                                     **params)
        except ValueError as exc:
            raise ConfigError(f"{sc.doc.where(('workspace',))}: {exc}") from None
        except Stopped:
            raise budget.TimeLimitExceeded(_NONE_FINISHED.format(what="design value")
                                           ) from None
    if len(sweep.values) < len(values):
        budget.note_done(len(sweep.values), len(values), "design values")
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

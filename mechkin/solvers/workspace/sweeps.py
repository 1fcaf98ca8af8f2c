r"""Sweeps: design sweeps of lee's mechanism, task-space reachability/dexterity, job execution.

Three pieces, all independent of the CLI and of io/ (records: :mod:`mechkin.records.workspace`);
the job execution lives in :mod:`~mechkin.solvers.workspace.jobs`, the task-space sweeps in
:mod:`~mechkin.solvers.workspace.task_space` (their names are re-exported here):

* :func:`run_jobs` runs a list of independent jobs (a picklable top-level function and one
  argument per job) in order, sequentially (``workers=1``), on local processes
  (:class:`concurrent.futures.ProcessPoolExecutor`) or on a Dask cluster (``address`` of a
  scheduler; needs the optional extra ``mechkin[dask]``). Results come back in job order and a
  job never depends on how many workers there are, so every executor gives identical results.
  A ``progress(done, total)`` callback reports completed jobs (the CLI draws a bar from it).
* :func:`lee_design_sweep`: :func:`mechkin.solvers.workspace.maps.lee_workspace` once per value of a
  design parameter (``r``, ``R``, ``l_min``, ``l_max``), one job per value, and a comparison
  table (:func:`design_comparison`).
* :func:`task_space_sweep`: task-space poses of a frame through the batched Levenberg-Marquardt
  inverse kinematics (:func:`mechkin.solvers.ik.solve_ik_batch`), chunks of poses as
  jobs, and at every solution the dexterity of the frame Jacobian ``J`` (rows omega, v; SI) with
  respect to the independent joints (closed chains: ``J_v + J_w dq_w/dq_v``, kim1995 Eq. (10)):

  - isotropy ``sigma_min / sigma_max`` (the inverse condition number; 0 at singular poses),
    of the full Jacobian and of its position rows,
  - condition number ``sigma_max / sigma_min``, capped at :data:`COND_CAP` (never inf),
  - Yoshikawa's manipulability ``w = sqrt(det(J J^T)) = prod sigma_i``.

  A pose is **reachable** when the solver reaches it (status ok: verified position and
  orientation errors below the tolerances, joints within their limits). With seeded random
  restarts this is a lower bound of the true reachable set: a reachable pose the solver misses
  is reported unreachable, never the opposite. Dexterity is 0 at poses not reached.

References
----------
lee_spherical_3dof_parallel §3.2, Eq. (21); kim1995_complex_chain_ik Eq. (7)-(10);
Yoshikawa (1985), Manipulability of robotic mechanisms, IJRR 4(2).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from mechkin.records.workspace import DesignSweepRecord, LeeWorkspaceRecord, TaskSpaceRecord
from mechkin.solvers.result import Stopped
from mechkin.solvers.workspace.dexterity import (
    COND_CAP,
    dexterity,
)
from mechkin.solvers.workspace.jobs import (
    ProgressCallback,
    connect_cluster,
    default_workers,
    run_jobs,
)
from mechkin.solvers.workspace.maps import lee_workspace
from mechkin.solvers.workspace.task_space import (
    job_mechanism,
    mechanism_spec,
    task_space_grid,
    task_space_random,
    task_space_summary,
    task_space_sweep,
)

__all__ = [
    "COND_CAP",
    "DESIGN_PARAMETERS",
    "connect_cluster",
    "DesignSweepRecord",
    "ProgressCallback",
    "TaskSpaceRecord",
    "default_workers",
    "design_comparison",
    "design_summary",
    "dexterity",
    "job_mechanism",
    "lee_design_sweep",
    "lee_map_jobs",
    "lee_workspace_jobs",
    "mechanism_spec",
    "run_jobs",
    "task_space_grid",
    "task_space_random",
    "task_space_summary",
    "task_space_sweep",
]

DESIGN_PARAMETERS = ("r", "R", "l_min", "l_max")
"""Design parameters of lee's mechanism a sweep may vary (lengths, SI)."""

# --------------------------------------------------------------------------- lee design sweeps


def _lee_job(params: dict[str, Any]) -> LeeWorkspaceRecord:
    """One design value: :func:`lee_workspace` (module level, so it pickles)."""
    return lee_workspace(**params)


def _with_value(base: Mapping[str, Any], parameter: str, value: float) -> dict[str, Any]:
    p = dict(base)
    if parameter in ("r", "R"):
        p[parameter] = float(value)
    elif parameter in ("l_min", "l_max"):
        lo, hi = p.get("stroke", (0.5, 2.0))
        p["stroke"] = (float(value), float(hi)) if parameter == "l_min" else (float(lo),
                                                                               float(value))
        if not p["stroke"][0] < p["stroke"][1]:
            raise ValueError(f"{parameter} = {value}: expected l_min < l_max, got stroke "
                             f"{p['stroke']}")
    else:
        raise ValueError(f"parameter: expected one of {', '.join(DESIGN_PARAMETERS)}, got "
                         f"{parameter!r}")
    return p


def lee_design_sweep(
    parameter: str,
    values: Sequence[float],
    *,
    workers: int | None = None,
    address: str | None = None,
    progress: ProgressCallback | None = None,
    stop: Callable[[], bool] | None = None,
    **params: Any,
) -> DesignSweepRecord:
    """:func:`mechkin.solvers.workspace.maps.lee_workspace` for every value of one design parameter.

    Parameters
    ----------
    parameter : {"r", "R", "l_min", "l_max"}
        The design parameter varied (lee §3.2 varies r: Figs. 3-5).
    values : sequence of float
        Its values (SI); one job each.
    workers, address, progress, stop
        See :func:`run_jobs` (after a stop: the values finished in a row, at least one).
    **params
        The other keyword arguments of :func:`lee_workspace` (``r`` is required unless it is the
        swept parameter).

    Returns
    -------
    DesignSweepRecord
        Of the values finished (all of them unless ``stop`` said so).

    Raises
    ------
    Stopped
        ``stop`` said so before the first value finished (on a Dask cluster).
    """
    vals = tuple(float(v) for v in values)
    if not vals:
        raise ValueError("values: expected at least one value")
    base = dict(params)
    base.setdefault("r", vals[0])
    jobs = [_with_value(base, parameter, v) for v in vals]
    recs = run_jobs(_lee_job, jobs, workers=workers, address=address, progress=progress,
                    stop=stop)
    if not recs:
        raise Stopped
    vals = vals[: len(recs)]
    return DesignSweepRecord(parameter, vals, tuple(recs), design_comparison(parameter, vals,
                                                                             recs))


def lee_map_jobs(params: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The independent maps of one :func:`lee_workspace` call as jobs: one per gamma set, one
    for the gamma range, one for the pose list (each the same call with only that map)."""
    base = {k: v for k, v in params.items()
            if k not in ("gamma_sets", "gamma_sweep", "poses", "progress")}
    jobs = [{**base, "gamma_sets": {name: g}} for name, g in
            (params.get("gamma_sets") or {}).items()]
    if params.get("gamma_sweep") is not None:
        jobs.append({**base, "gamma_sweep": params["gamma_sweep"]})
    if params.get("poses") is not None:
        jobs.append({**base, "poses": params["poses"]})
    return jobs or [base]


def lee_workspace_jobs(
    *,
    workers: int | None = None,
    address: str | None = None,
    progress: ProgressCallback | None = None,
    stop: Callable[[], bool] | None = None,
    **params: Any,
) -> LeeWorkspaceRecord:
    """:func:`lee_workspace` with its maps (:func:`lee_map_jobs`) run as jobs
    (:func:`run_jobs`) and merged: the same functions on the same grids, so the record equals
    the single call's bitwise (summary keys in the same order).

    Parameters
    ----------
    workers, address, progress, stop
        See :func:`run_jobs` (``progress`` counts maps; after a stop the record holds the
        maps finished in a row, as :func:`lee_workspace` with ``stop``; :class:`Stopped` when
        none finished).
    **params
        Keyword arguments of :func:`lee_workspace`.
    """
    jobs = lee_map_jobs(params)
    recs = run_jobs(_lee_job, jobs, workers=workers, address=address, progress=progress,
                    stop=stop)
    if not recs:
        raise Stopped
    head = {k: v for k, v in recs[0].summary.items()
            if k not in ("isotropy", "gamma_range", "poses")}
    summary: dict[str, Any] = dict(head)
    isotropy: dict[str, Any] = {}
    gr = None
    plist = None
    for rec in recs:
        isotropy.update(rec.isotropy)
        if "isotropy" in rec.summary:
            summary.setdefault("isotropy", {}).update(rec.summary["isotropy"])
    for rec in recs:
        if rec.gamma_range is not None:
            gr = rec.gamma_range
            summary["gamma_range"] = rec.summary["gamma_range"]
    for rec in recs:
        if rec.poses is not None:
            plist = rec.poses
            summary["poses"] = rec.summary["poses"]
    return LeeWorkspaceRecord(recs[0].geometry, isotropy, gr, summary, plist)


def design_comparison(parameter: str, values: Sequence[float],
                      records: Sequence[LeeWorkspaceRecord]) -> list[dict[str, Any]]:
    """Comparison table of a design sweep: one row per (value, gamma set, gamma).

    Columns: the parameter value, gamma set, gamma [deg], the set's volume fraction, the area
    fraction at that gamma, sigma_KI at alpha = beta = 0, and the sigma_KI statistics (mean,
    median, min, max, count) over the in-workspace poses of that gamma. Values without maps
    (only a gamma range) give one row with the gamma-range volume and defined fractions.
    """
    rows: list[dict[str, Any]] = []
    for v, rec in zip(values, records, strict=True):
        s = rec.summary
        gr = s.get("gamma_range", {})
        gr_cols = {
            "gamma_range_volume_fraction": gr.get("volume_fraction"),
            "gamma_range_defined_fraction": gr.get("defined_fraction"),
        }
        sets = s.get("isotropy", {})
        if not sets:
            rows.append({parameter: float(v), "gamma_set": "", **gr_cols})
            continue
        for name, e in sets.items():
            for pg in e["per_gamma"]:
                st = pg["sigma_ki_in_workspace"]
                rows.append({
                    parameter: float(v),
                    "gamma_set": name,
                    "gamma_deg": pg["gamma_deg"],
                    "volume_fraction": e["volume_fraction"],
                    "area_fraction": pg["area_fraction"],
                    "sigma_ki_at_origin": pg["sigma_ki_at_origin"],
                    "sigma_ki_mean": st.get("mean", 0.0),
                    "sigma_ki_median": st.get("median", 0.0),
                    "sigma_ki_min": st.get("min", 0.0),
                    "sigma_ki_max": st.get("max", 0.0),
                    "sigma_ki_count": st["count"],
                    **gr_cols,
                })
    return rows


def design_summary(sweep: DesignSweepRecord) -> dict[str, Any]:
    """JSON-ready summary of a design sweep: ``design`` (parameter, values, per value the lee
    summary: fractions, sigma_KI statistics, sigma_KI at the origin per gamma, gamma range) and
    the ``comparison`` table."""
    per_value = []
    for v, rec in zip(sweep.values, sweep.records, strict=True):
        s = dict(rec.summary)
        s.pop("definition", None)
        per_value.append({"value": float(v), **s})
    first = sweep.records[0].summary
    return {
        "mechanism": first.get("mechanism"),
        "threshold": first.get("threshold"),
        "definition": first.get("definition"),
        "design": {"parameter": sweep.parameter, "values": list(sweep.values),
                   "per_value": per_value},
        "comparison": sweep.comparison,
    }

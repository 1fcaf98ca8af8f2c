r"""Sweeps: design sweeps of lee's mechanism, task-space reachability/dexterity, job execution.

Three pieces, all independent of the CLI and of io/ (records: :mod:`mechkin.records.workspace`):

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

import multiprocessing
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from mechkin.records.workspace import DesignSweepRecord, LeeWorkspaceRecord, TaskSpaceRecord
from mechkin.solvers.workspace.dexterity import (
    COND_CAP,
    characteristic_length,
    dexterity,
    length_bounds,
    normalized_isotropy,
)
from mechkin.solvers.workspace.maps import lee_workspace, sigma_statistics

__all__ = [
    "COND_CAP",
    "DESIGN_PARAMETERS",
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

T = TypeVar("T")
R = TypeVar("R")

ProgressCallback = Callable[[int, int], None]
"""``progress(done, total)``: called once with ``done = 0`` and after every completed job."""

DESIGN_PARAMETERS = ("r", "R", "l_min", "l_max")
"""Design parameters of lee's mechanism a sweep may vary (lengths, SI)."""

# --------------------------------------------------------------------------- execution


def default_workers(n_jobs: int) -> int:
    """min(cpu count, number of jobs), at least 1."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(cpus or 1, n_jobs))


def _mp_context() -> multiprocessing.context.BaseContext:
    """forkserver on POSIX (no fork of a threaded parent, e.g. a progress-bar thread), else
    spawn; the server preloads this module so workers start without re-importing numpy."""
    if sys.platform != "win32" and "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["mechkin.solvers.workspace.sweeps"])
        return ctx
    return multiprocessing.get_context("spawn")


def run_jobs(
    fn: Callable[[T], R],
    jobs: Sequence[T],
    *,
    workers: int | None = None,
    address: str | None = None,
    progress: ProgressCallback | None = None,
) -> list[R]:
    """Run ``fn(job)`` for every job and return the results in job order.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function.
    jobs : sequence
        One picklable argument per job.
    workers : int, optional
        Local processes (default :func:`default_workers`); 1 runs in this process. Ignored
        when ``address`` is given.
    address : str, optional
        Address of a Dask scheduler (``tcp://host:port``): the jobs run on that cluster
        (``pip install mechkin[dask]``).
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    list
        ``[fn(job) for job in jobs]``, whatever the executor.

    Raises
    ------
    ImportError
        ``address`` given but dask.distributed is not installed.
    """
    total = len(jobs)
    if progress is not None:
        progress(0, total)
    if total == 0:
        return []
    if address is not None:
        return _run_dask(fn, jobs, address, progress)
    n = default_workers(total) if workers is None else max(1, min(int(workers), total))
    if n == 1:
        out: list[R] = []
        for i, job in enumerate(jobs):
            out.append(fn(job))
            if progress is not None:
                progress(i + 1, total)
        return out
    results: list[Any] = [None] * total
    with ProcessPoolExecutor(max_workers=n, mp_context=_mp_context()) as pool:
        futures: dict[Future[R], int] = {pool.submit(fn, job): i for i, job in enumerate(jobs)}
        _collect(as_completed(futures), futures, results, total, progress)
    return results


def _collect(done_iter: Iterable[Any], index: Mapping[Any, int], results: list[Any], total: int,
             progress: ProgressCallback | None) -> None:
    for k, fut in enumerate(done_iter, start=1):
        results[index[fut]] = fut.result()
        if progress is not None:
            progress(k, total)


#: Seconds to reach a scheduler and to see a worker (``MECHKIN_DASK_TIMEOUT`` overrides).
DASK_TIMEOUT_S = 10.0
_PROBE = "__import__('mechkin').__version__"


def _dask_timeout() -> float:
    import os

    try:
        return float(os.environ.get("MECHKIN_DASK_TIMEOUT", DASK_TIMEOUT_S))
    except ValueError:
        return DASK_TIMEOUT_S


def _probe_scheduler(address: str, shown: str, timeout: float) -> None:
    """Ask ``address`` who it is (the comm handshake and the ``identity`` op, both under one
    timeout): a port that accepts but never answers (not a Dask scheduler) must not hang."""
    import asyncio

    from distributed.core import rpc

    from mechkin.errors import ClusterError

    async def ask() -> Any:
        r = rpc(address, timeout=timeout)
        try:
            return await asyncio.wait_for(r.identity(), timeout)
        finally:
            await r.close_rpc()

    try:
        info = asyncio.run(asyncio.wait_for(ask(), timeout + 1.0))
    except (OSError, TimeoutError, asyncio.TimeoutError, ValueError, EOFError) as exc:
        raise ClusterError(f"--scheduler {shown}: no Dask scheduler answered within "
                           f"{timeout:g} s ({type(exc).__name__}); is it running at that "
                           "address?") from None
    except Exception as exc:  # noqa: BLE001 - any protocol failure means: not a scheduler
        raise ClusterError(f"--scheduler {shown}: not a Dask scheduler ({type(exc).__name__})"
                           ) from None
    if not isinstance(info, dict) or info.get("type") != "Scheduler":
        raise ClusterError(f"--scheduler {shown}: answered, but is not a Dask scheduler")


def connect_cluster(address: str) -> Any:
    """A ``distributed.Client`` on ``address`` whose workers run this mechkin version.

    Fails fast, each with one line (ClusterError, exit 2): an address that is not
    ``tcp://host:port`` (or ``tls://``), nothing listening or no Dask scheduler answering
    within the timeout, no worker within the timeout, workers that cannot import mechkin or run
    another version of it.
    """
    from mechkin import __version__
    from mechkin.errors import ClusterError

    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise ClusterError("--scheduler: running on a Dask cluster needs the optional extra: "
                           "pip install 'mechkin[dask]'") from exc
    shown = address if len(address) <= 80 else address[:77] + "..."
    if "://" not in address or address.split("://", 1)[0] not in ("tcp", "tls", "inproc"):
        raise ClusterError(f"--scheduler {shown}: expected an address like tcp://HOST:8786")
    timeout = _dask_timeout()
    _probe_scheduler(address, shown, timeout)
    try:
        client = Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {shown}: no Dask scheduler answered within "
                           f"{timeout:g} s ({type(exc).__name__}); is it running at that "
                           "address?") from None
    try:
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (TimeoutError, OSError):
            raise ClusterError(f"--scheduler {shown}: the scheduler has no workers (none "
                               f"joined within {timeout:g} s)") from None
        versions = client.run(eval, _PROBE, on_error="return")
        bad = {w: v for w, v in versions.items() if v != __version__}
        if bad:
            w, v = next(iter(bad.items()))
            why = (f"cannot import mechkin ({type(v).__name__}: {str(v)[:60]})"
                   if isinstance(v, BaseException) else f"runs mechkin {str(v)[:20]}")
            raise ClusterError(f"--scheduler {shown}: {len(bad)} of {len(versions)} workers "
                               f"cannot run this job: worker {w} {why}, this is mechkin "
                               f"{__version__}; install the same mechkin on every worker")
    except BaseException:
        client.close()
        raise
    return client


def _run_dask(fn: Callable[[T], R], jobs: Sequence[T], address: str,
              progress: ProgressCallback | None) -> list[R]:
    from distributed import as_completed as dask_as_completed

    from mechkin.errors import ClusterError

    results: list[Any] = [None] * len(jobs)
    client = connect_cluster(address)
    try:
        futures = [client.submit(fn, job, pure=False) for job in jobs]
        index = {f.key: i for i, f in enumerate(futures)}
        for k, fut in enumerate(dask_as_completed(futures), start=1):
            try:
                results[index[fut.key]] = fut.result()
            except (ImportError, ModuleNotFoundError, AttributeError) as exc:
                raise ClusterError(f"--scheduler {address[:80]}: a worker could not run the "
                                   f"job ({type(exc).__name__}: {str(exc)[:80]})") from None
            if progress is not None:
                progress(k, len(jobs))
    finally:
        client.close()
    return results


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
    **params: Any,
) -> DesignSweepRecord:
    """:func:`mechkin.solvers.workspace.maps.lee_workspace` for every value of one design parameter.

    Parameters
    ----------
    parameter : {"r", "R", "l_min", "l_max"}
        The design parameter varied (lee §3.2 varies r: Figs. 3-5).
    values : sequence of float
        Its values (SI); one job each.
    workers, address, progress
        See :func:`run_jobs`.
    **params
        The other keyword arguments of :func:`lee_workspace` (``r`` is required unless it is the
        swept parameter).

    Returns
    -------
    DesignSweepRecord
    """
    vals = tuple(float(v) for v in values)
    if not vals:
        raise ValueError("values: expected at least one value")
    base = dict(params)
    base.setdefault("r", vals[0])
    jobs = [_with_value(base, parameter, v) for v in vals]
    recs = run_jobs(_lee_job, jobs, workers=workers, address=address, progress=progress)
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
    **params: Any,
) -> LeeWorkspaceRecord:
    """:func:`lee_workspace` with its maps (:func:`lee_map_jobs`) run as jobs
    (:func:`run_jobs`) and merged: the same functions on the same grids, so the record equals
    the single call's bitwise (summary keys in the same order).

    Parameters
    ----------
    workers, address, progress
        See :func:`run_jobs` (``progress`` counts maps).
    **params
        Keyword arguments of :func:`lee_workspace`.
    """
    jobs = lee_map_jobs(params)
    recs = run_jobs(_lee_job, jobs, workers=workers, address=address, progress=progress)
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


# --------------------------------------------------------------------------- task-space sweeps


def task_space_grid(axes: Sequence[np.ndarray], R0: np.ndarray) -> np.ndarray:
    """Poses (m, 4, 4) on the grid ``axes`` = (x, y, z) values [m] (C order: z fastest),
    all with the rotation ``R0`` (3, 3)."""
    X, Y, Z = np.meshgrid(*[np.atleast_1d(np.asarray(a, dtype=np.float64)) for a in axes],
                          indexing="ij")
    T = np.tile(np.eye(4), (X.size, 1, 1))
    T[:, :3, :3] = R0
    T[:, 0, 3], T[:, 1, 3], T[:, 2, 3] = X.ravel(), Y.ravel(), Z.ravel()
    return T


def task_space_random(box: Sequence[tuple[float, float]], samples: int, seed: int,
                      R0: np.ndarray | None) -> np.ndarray:
    """Seeded random poses (samples, 4, 4): positions uniform in ``box`` ((lo, hi) per axis,
    lo == hi for a fixed coordinate) and rotation ``R0``, or uniform random rotations (Shoemake
    quaternions) when ``R0`` is None."""
    from mechkin.spatial.rotations import matrix_from_quat

    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (samples, 1, 1))
    for k, (lo, hi) in enumerate(box):
        T[:, k, 3] = rng.uniform(lo, hi, size=samples) if hi > lo else lo
    if R0 is None:
        u1, u2, u3 = rng.random((3, samples))
        a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
        quat = np.column_stack([a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2),
                                b * np.sin(2 * np.pi * u3), b * np.cos(2 * np.pi * u3)])
        T[:, :3, :3] = matrix_from_quat(quat)
    else:
        T[:, :3, :3] = R0
    return T


def _mechanism_spec(mechanism: Any) -> Any:
    """The validated contents (:class:`mechkin.config.schema.MechanismSpec`) of a mechanism
    file path, or the spec itself: what a job carries, so a worker needs no shared files."""
    if isinstance(mechanism, (str, Path)):
        from mechkin.config.mechanism_file import read_mechanism_spec

        return read_mechanism_spec(mechanism)[0]
    return mechanism


mechanism_spec = _mechanism_spec


_BUILT: dict[str, Any] = {}


def _job_mechanism(spec: Any) -> Any:
    """Build the mechanism of a job's spec (once per worker process and spec)."""
    from mechkin.model.build import build_mechanism

    key = spec.model_dump_json()
    if key not in _BUILT:
        if len(_BUILT) > 8:
            _BUILT.clear()
        _BUILT[key] = build_mechanism(spec)
    return _BUILT[key]


job_mechanism = _job_mechanism


def _task_job(job: dict[str, Any]) -> dict[str, np.ndarray]:
    """One chunk of task-space poses: batched lm, then the Jacobian at the solutions."""
    from mechkin.model.closure import dependent_sensitivity
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian
    from mechkin.solvers.ik import IkOptions, solve_ik_batch

    mech = _job_mechanism(job["mechanism"])
    f = job["frame"]
    opts = IkOptions(restarts=job["restarts"], seed=job["seed"], max_iter=job["max_iter"],
                     tol_pos=job["tol_pos"], tol_ori=job["tol_ori"])
    res = solve_ik_batch(mech, job["T_P"], weights=job["weights"], options=opts, frame=f)
    q = np.where(np.isfinite(res.q), res.q, mech.home)
    kin = forward_kinematics(mech, q)
    J = frame_jacobian(mech, kin, f)
    Jr = J[:, :, mech.independent]
    if mech.is_closed and len(mech.dependent) > 0:
        Jr = Jr + J[:, :, mech.dependent] @ dependent_sensitivity(mech, q)
    dex = dexterity(Jr)
    ok = res.ok
    out = {k: np.where(ok, v, 0.0) for k, v in dex.items()}
    out.update(q_v=q[:, mech.independent], status=np.array([s.value for s in res.status]),
               reachable=ok, position_error=np.nan_to_num(res.position_error, nan=0.0),
               orientation_error=np.nan_to_num(res.orientation_error, nan=0.0),
               iterations=np.asarray(res.iterations, dtype=np.int64), J=Jr,
               prismatic=np.asarray(mech.s[mech.independent] == 1))
    return out


def task_space_sweep(
    mechanism: str | Path,
    T_P: np.ndarray,
    *,
    frame: int | None = None,
    weights: Sequence[float] | None = None,
    restarts: int = 8,
    seed: int = 0,
    max_iter: int | None = None,
    tol_pos: float = 1e-6,
    tol_ori: float = 1e-6,
    chunk: int = 2000,
    workers: int | None = None,
    address: str | None = None,
    progress: ProgressCallback | None = None,
    length: float | None = None,
) -> TaskSpaceRecord:
    """Reachability and dexterity of task-space poses through the batched inverse kinematics.

    Parameters
    ----------
    mechanism : path or MechanismSpec
        Mechanism file or its validated contents. Jobs carry the contents (the
        :class:`~mechkin.config.schema.MechanismSpec`), never the path, so workers on another
        machine (a Dask cluster) need no copy of the file.
    T_P : array, shape (m, 4, 4)
        Target poses of ``frame`` in the base frame (SI).
    frame : int, optional
        Frame index (default: the end effector).
    weights : sequence of 6 floats, optional
        Diagonal of W (kim1995 Eq. (9)): position, then orientation.
    restarts, seed, max_iter, tol_pos, tol_ori
        :class:`mechkin.solvers.ik.IkOptions`; every chunk uses the same seed, so the
        result depends on ``chunk`` but not on the executor or the number of workers.
    chunk : int
        Poses per job.
    workers, address, progress
        See :func:`run_jobs`.
    length : float, optional
        Characteristic length [m] of ``isotropy_normalized``; None: the one that best
        conditions the reached poses (:func:`mechkin.solvers.workspace.dexterity.characteristic_length`).

    Returns
    -------
    TaskSpaceRecord
    """
    spec = _mechanism_spec(mechanism)
    mech = _job_mechanism(spec)
    f = int(mech.end_effector) if frame is None else int(frame)
    T_P = np.asarray(T_P, dtype=np.float64).reshape(-1, 4, 4)
    m = T_P.shape[0]
    w = np.ones(6) if weights is None else np.asarray(weights, dtype=np.float64)
    jobs = [
        {"mechanism": spec, "frame": f, "T_P": T_P[a : a + chunk], "weights": w,
         "restarts": int(restarts), "seed": int(seed), "max_iter": max_iter,
         "tol_pos": float(tol_pos), "tol_ori": float(tol_ori)}
        for a in range(0, m, max(1, int(chunk)))
    ]
    parts = run_jobs(_task_job, jobs, workers=workers, address=address, progress=progress)
    cat = {k: np.concatenate([p[k] for p in parts]) if parts else np.empty(0)
           for k in (parts[0] if parts else {})}
    if not parts:
        nv = len(mech.independent)
        z = np.zeros(0)
        return TaskSpaceRecord(T_P, np.zeros((0, nv)), np.zeros(0, dtype=str),
                               np.zeros(0, dtype=bool), z, z, np.zeros(0, dtype=np.int64), z, z,
                               z, z)
    prismatic = parts[0]["prismatic"]
    ok = cat["reachable"]
    L = float(length) if length is not None else characteristic_length(
        cat["J"][ok], prismatic, bounds=length_bounds(mech))
    iso_n = np.where(ok, normalized_isotropy(cat["J"], L, prismatic), 0.0)
    return TaskSpaceRecord(T_P, cat["q_v"], cat["status"], cat["reachable"],
                           cat["position_error"], cat["orientation_error"], cat["iterations"],
                           cat["isotropy"], cat["isotropy_position"], cat["condition_number"],
                           cat["manipulability"], iso_n, L)


def task_space_summary(rec: TaskSpaceRecord) -> dict[str, Any]:
    """JSON-ready counts and dexterity statistics (over the reached poses) of a sweep."""
    m = int(rec.reachable.size)
    ok = rec.reachable
    statuses, counts = np.unique(rec.status, return_counts=True)
    out: dict[str, Any] = {
        "n_poses": m,
        "n_reachable": int(ok.sum()),
        "reachable_fraction": float(ok.mean()) if m else 0.0,
        "status_counts": {str(s): int(c) for s, c in zip(statuses, counts, strict=True)},
        "isotropy": sigma_statistics(rec.isotropy, ok),
        "isotropy_position": sigma_statistics(rec.isotropy_position, ok),
        "condition_number": sigma_statistics(rec.condition_number, ok),
        "manipulability": sigma_statistics(rec.manipulability, ok),
        "isotropy_normalized": sigma_statistics(rec.isotropy_normalized, ok)
        if rec.isotropy_normalized is not None else {"count": 0},
        "iterations": sigma_statistics(rec.iterations.astype(float)),
    }
    if ok.any():
        out["max_position_error_m"] = float(rec.position_error[ok].max())
        out["max_orientation_error_rad"] = float(rec.orientation_error[ok].max())
        P = rec.T_P[ok, :3, 3]
        out["reachable_bounding_box"] = {"min_m": P.min(axis=0).tolist(),
                                         "max_m": P.max(axis=0).tolist()}
    return out

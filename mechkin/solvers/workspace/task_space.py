r"""Task-space sweeps: reachability and dexterity of a frame over a grid or random set of poses.

:func:`task_space_sweep`: task-space poses of a frame through the batched Levenberg-Marquardt
inverse kinematics (:func:`mechkin.solvers.ik.solve_ik_batch`), chunks of poses as jobs
(:func:`mechkin.solvers.workspace.jobs.run_jobs`), and at every solution the dexterity of the
frame Jacobian (isotropy, condition number capped at ``COND_CAP``, Yoshikawa's
manipulability; :mod:`mechkin.solvers.workspace.sweeps` states the definitions and what
"reachable" means). Split out of ``sweeps.py`` (issue 23: modules that fit in a head); the names
stay importable from :mod:`mechkin.solvers.workspace.sweeps`.

References
----------
kim1995_complex_chain_ik Eq. (7)-(10); Yoshikawa (1985), Manipulability of robotic mechanisms,
IJRR 4(2).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.records.workspace import TaskSpaceRecord
from mechkin.solvers.workspace.dexterity import (
    characteristic_length,
    dexterity,
    length_bounds,
    normalized_isotropy,
)
from mechkin.solvers.workspace.jobs import ProgressCallback, run_jobs
from mechkin.solvers.workspace.maps import sigma_statistics

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
    stop: Callable[[], bool] | None = None,
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
        conditions the reached poses
        (:func:`mechkin.solvers.workspace.dexterity.characteristic_length`).
    stop : callable, optional
        See :func:`run_jobs`: after a stop the record holds the poses of the finished
        chunks (a prefix of ``T_P``).

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
    parts = run_jobs(_task_job, jobs, workers=workers, address=address, progress=progress,
                     stop=stop)
    T_P = T_P[: sum(len(p["reachable"]) for p in parts)]  # a prefix after a stop
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

r"""Joint-space sweeps: where a frame goes when the independent joints sweep a set of samples.

:func:`joint_sweep` takes samples of the independent joints ``q_v`` (m, n_v), closes the loops
of a closed chain (kim1995 §5.1, Newton on ``phi(q_v, q_w) = 0``), and returns per sample the
position of a frame, whether the sample is **reachable** (loop closure converged, every joint
within its limits, everything finite) and, when asked, the dexterity of the reduced frame
Jacobian ``J = J_v + J_w dq_w/dq_v`` (kim1995 Eq. (10); :mod:`mechkin.solvers.dexterity`).

:func:`point_cloud_volume` measures the reachable positions: the bounding box, the volume of
the occupied voxels (cubes of a given edge) and of the convex hull (an upper bound for
non-convex workspaces).

References
----------
kim1995_complex_chain_ik §5.1, Eq. (10); Yoshikawa (1985), IJRR 4(2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.records.workspace import JointSweepRecord
from mechkin.solvers.dexterity import dexterity

__all__ = ["joint_sweep", "point_cloud_volume"]


def joint_sweep(mech: Any, q_v: np.ndarray, frame: int, *, chunk: int = 2000,
                manipulability: bool = True) -> JointSweepRecord:
    """Positions, reachability and dexterity of ``frame`` at the samples ``q_v``.

    Parameters
    ----------
    mech : Mechanism
    q_v : array, shape (m, n_v)
        Independent joint values [rad | m].
    frame : int
        Frame index.
    chunk : int
        Samples per vectorized block.
    manipulability : bool
        Compute the dexterity (Yoshikawa manipulability, isotropy of the full Jacobian and of
        its position rows).

    Returns
    -------
    JointSweepRecord
        Dexterity is 0 at samples that are not reachable.
    """
    from mechkin.model.closure import ClosureStatus, dependent_sensitivity, solve_closure
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian

    qv = np.asarray(q_v, dtype=np.float64)
    m = qv.shape[0]
    closed = mech.is_closed and len(mech.dependent) > 0
    q = np.empty((m, mech.n))
    status = np.empty(m, dtype=object)
    pos = np.empty((m, 3))
    w_full = np.zeros(m)
    iso_full = np.zeros(m)
    iso_pos = np.zeros(m)
    q_w0 = mech.home[mech.dependent]
    for a in range(0, m, chunk):
        b = min(m, a + chunk)
        if closed:
            res = solve_closure(mech, qv[a:b], q_w0)
            q[a:b] = res.q
            status[a:b] = [s.value for s in res.status]
        else:
            q[a:b] = mech.assemble(qv[a:b], np.zeros((b - a, 0)))
            status[a:b] = ClosureStatus.CONVERGED.value
        kin = forward_kinematics(mech, q[a:b])
        pos[a:b] = kin.frames(mech, [frame])[:, 0, :3, 3]
        if manipulability:
            J = frame_jacobian(mech, kin, frame)
            Jr = J[:, :, mech.independent]
            if closed:
                Jr = Jr + J[:, :, mech.dependent] @ dependent_sensitivity(mech, q[a:b])
            dex = dexterity(Jr)
            w_full[a:b] = dex["manipulability"]
            iso_full[a:b] = dex["isotropy"]
            iso_pos[a:b] = dex["isotropy_position"]
    converged = status == ClosureStatus.CONVERGED.value
    within = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
    finite = np.all(np.isfinite(pos), axis=1) & np.all(np.isfinite(q), axis=1)
    reach = converged & within & finite
    pos = np.where(np.isfinite(pos), pos, 0.0)
    q = np.where(np.isfinite(q), q, 0.0)
    for arr in (w_full, iso_full, iso_pos):
        arr[~reach] = 0.0  # not a pose of the mechanism: reported 0, marked by reachable = 0
    dex_out: dict[str, Any] = {}
    if manipulability:
        dex_out = {"manipulability": w_full, "isotropy": iso_full, "isotropy_position": iso_pos}
    return JointSweepRecord(q_v=qv, q=q, position=pos, status=status, converged=converged,
                            within_limits=within, reachable=reach, **dex_out)


def point_cloud_volume(P: np.ndarray, voxel: float | None = None
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Bounding box and volumes of a point cloud ``P`` (k, 3) [m].

    Parameters
    ----------
    P : array, shape (k, 3)
    voxel : float, optional
        Voxel edge [m]; default: the largest bounding-box side / 40 (at least 1e-6 m).

    Returns
    -------
    bbox : dict
        ``min_m``, ``max_m``, ``size_m`` ({} for an empty cloud).
    volume : dict
        ``voxel_m3`` (occupied cubes x edge^3), ``voxel_edge_m``, ``occupied_voxels``,
        ``convex_hull_m3`` (0 for degenerate, e.g. planar, clouds).
    """
    volume: dict[str, Any] = {"voxel_m3": 0.0, "voxel_edge_m": None, "convex_hull_m3": 0.0}
    bbox: dict[str, Any] = {}
    if not P.shape[0]:
        return bbox, volume
    lo, hi = P.min(axis=0), P.max(axis=0)
    bbox = {"min_m": lo.tolist(), "max_m": hi.tolist(), "size_m": (hi - lo).tolist()}
    edge = voxel if voxel is not None else max(float((hi - lo).max()) / 40.0, 1e-6)
    cells = np.unique(np.floor((P - lo) / edge).astype(np.int64), axis=0)
    volume = {"voxel_m3": float(cells.shape[0] * edge**3), "voxel_edge_m": edge,
              "occupied_voxels": int(cells.shape[0]), "convex_hull_m3": 0.0}
    try:
        from scipy.spatial import ConvexHull

        if P.shape[0] >= 4:
            volume["convex_hull_m3"] = float(ConvexHull(P).volume)
    except Exception:  # noqa: BLE001 - degenerate (planar) clouds have no hull volume
        volume["convex_hull_m3"] = 0.0
    return bbox, volume

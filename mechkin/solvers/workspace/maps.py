r"""Workspace and isotropy maps over orientation grids (lee Figs. 2-5).

The maps are built from a *pose evaluator*: a callable that takes a batch of poses
``(m, d)`` and returns a :class:`PoseEvaluation` (isotropy index, actuator values and whether
every actuator is within its limits). :func:`lee_evaluator` wraps the closed-form solver of lee's
spherical mechanism; any other mechanism plugs in by supplying its own evaluator (for example
one built on the batched ik/FK of :mod:`mechkin.model`), and every map, range and statistic below
works unchanged.

Definitions used throughout (lee §3.2):

* A pose is **within limits** when every leg obeys ``l_min <= l_i <= l_max``.
* A pose is **in the workspace** when it is within limits *and* ``sigma_KI >= threshold``
  (0.01 in the paper). Poses outside the strokes are kept in every array and marked, never
  dropped.
* **gamma_min(alpha, beta) / gamma_max(alpha, beta)** (Fig. 2): over a grid of gamma values,

  - ``mode="extent"`` (default): the smallest / largest grid gamma at which
    ``(alpha, beta, gamma)`` is in the workspace; NaN when no grid gamma is.
  - ``mode="component"``: the ends of the run of consecutive in-workspace grid gammas that
    contains ``gamma_ref`` (the grid point nearest to it); NaN when that point is not in the
    workspace. A run is also cut between two in-workspace neighbours whose Jacobian
    determinants differ in sign (a singular surface thinner than the grid step lies between
    them). The grid is not treated as periodic.

  The resolution is the grid step. :class:`GammaRange` also gives the number of in-workspace
  grid gammas and the number of separate runs, so a workspace split in gamma (e.g. by the
  singular line gamma = 0 at alpha = beta = 0) is visible rather than hidden.
* **Area fraction** at one gamma: in-workspace grid points / all grid points of the
  alpha-beta grid. **Volume fraction**: the same over the whole alpha-beta-gamma grid. Both are
  fractions of the *grid* (uniform in the Euler angles), not of the Haar measure on SO(3).

The result types (:class:`~mechkin.records.workspace.OrientationMaps`,
:class:`~mechkin.records.workspace.GammaRange`,
:class:`~mechkin.records.workspace.LeeWorkspaceRecord`) live in :mod:`mechkin.records.workspace`
(re-exported here); :mod:`mechkin.io.workspace_out` writes them. Nothing here writes files.

References
----------
lee_spherical_3dof_parallel §3.2, Eq. (21), Figs. 2-5.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from mechkin.records.workspace import (
    GammaRange,
    LeePoseList,
    LeeWorkspaceRecord,
    OrientationMaps,
)
from mechkin.solvers.closed_form.lee_spherical import (
    DEFAULT_CHUNK,
    LeeGeometry,
    evaluate_poses,
    within_stroke,
)

__all__ = [
    "DEFAULT_THRESHOLD",
    "GammaRange",
    "LeeWorkspaceRecord",
    "OrientationMaps",
    "PoseEvaluation",
    "PoseEvaluator",
    "area_fractions",
    "gamma_range",
    "gamma_range_from_mask",
    "lee_evaluator",
    "lee_workspace",
    "orientation_maps",
    "sigma_statistics",
    "volume_fraction",
]

DEFAULT_THRESHOLD = 0.01
"""sigma_KI below which a pose is not counted as workspace (lee §3.2)."""


@dataclass(frozen=True)
class PoseEvaluation:
    """What a pose evaluator returns for ``m`` poses.

    Attributes
    ----------
    sigma : ndarray, shape (m,)
        Isotropy index in [0, 1]; 0 (never NaN) at singular poses.
    within_limits : ndarray of bool, shape (m,)
        Every actuator within its limits (leg strokes).
    actuators : ndarray, shape (m, k)
        Actuator values (leg lengths) of each pose.
    branch : ndarray of int8, shape (m,), optional
        Sign of the determinant of the (square) rate Jacobian. Where it differs between two
        neighbouring grid poses a singular surface lies between them, even if neither sample
        has sigma below the threshold; runs of workspace are cut there.
    """

    sigma: np.ndarray
    within_limits: np.ndarray
    actuators: np.ndarray
    branch: np.ndarray | None = None


PoseEvaluator = Callable[[np.ndarray], PoseEvaluation]
"""``evaluate(poses (m, d)) -> PoseEvaluation``; for lee, poses are (alpha, beta, gamma) [rad]."""


def lee_evaluator(
    geom: LeeGeometry, *, method: str = "closed_form", chunk: int = DEFAULT_CHUNK
) -> PoseEvaluator:
    """Pose evaluator of lee's mechanism: Eq. (9) leg lengths and Eq. (21) sigma_KI.

    Parameters
    ----------
    geom : LeeGeometry
    method : {"closed_form", "svd"}
        Singular-value method, see
        :func:`mechkin.solvers.closed_form.lee_spherical.isotropy_from_jacobian`.
    chunk : int
        Poses per vectorized block.
    """

    def evaluate(poses: np.ndarray) -> PoseEvaluation:
        ev = evaluate_poses(geom, poses, method=method, chunk=chunk)
        return PoseEvaluation(
            ev.sigma, within_stroke(geom, ev.lengths), ev.lengths, np.sign(ev.det_G).astype(np.int8)
        )

    return evaluate


# --------------------------------------------------------------------------- maps


def _grid_poses(alpha: np.ndarray, beta: np.ndarray, gamma: float) -> np.ndarray:
    A, B = np.meshgrid(alpha, beta, indexing="ij")
    return np.stack([A, B, np.full_like(A, gamma)], axis=-1).reshape(-1, 3)


def _axis(x: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    a = np.atleast_1d(np.asarray(x, dtype=np.float64))
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected a non-empty 1-D array of finite numbers, got {x!r}")
    return a


def orientation_maps(
    evaluate: PoseEvaluator,
    alpha: Sequence[float] | np.ndarray,
    beta: Sequence[float] | np.ndarray,
    gamma: Sequence[float] | np.ndarray,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    keep_actuators: bool = True,
    block: int = 4 * DEFAULT_CHUNK,
) -> OrientationMaps:
    """Evaluate every ``(alpha_i, beta_j, gamma_g)`` of a grid (lee Figs. 3-5).

    Parameters
    ----------
    evaluate : PoseEvaluator
        E.g. :func:`lee_evaluator`.
    alpha, beta, gamma : array, shapes (n_a,), (n_b,), (n_g,)
        Grid axes [rad].
    threshold : float
        Workspace threshold on sigma_KI (0.01 in lee §3.2).
    keep_actuators : bool
        Keep the actuator values (n_g, n_a, n_b, k); set False for large sweeps.
    block : int
        Approximate number of poses per call of ``evaluate`` (whole gamma slices).

    Returns
    -------
    OrientationMaps
    """
    alpha, beta, gamma = _axis(alpha, "alpha"), _axis(beta, "beta"), _axis(gamma, "gamma")
    shape = (gamma.size, alpha.size, beta.size)
    sigma = np.empty(shape)
    within = np.empty(shape, dtype=bool)
    act: np.ndarray | None = None
    branch: np.ndarray | None = None
    per = max(1, block // (alpha.size * beta.size))  # gamma slices per evaluator call
    for g0 in range(0, gamma.size, per):
        gs = gamma[g0 : g0 + per]
        ev = evaluate(np.concatenate([_grid_poses(alpha, beta, float(gv)) for gv in gs]))
        blk = (gs.size,) + shape[1:]
        sigma[g0 : g0 + gs.size] = ev.sigma.reshape(blk)
        within[g0 : g0 + gs.size] = ev.within_limits.reshape(blk)
        if ev.branch is not None:
            if branch is None:
                branch = np.zeros(shape, dtype=np.int8)
            branch[g0 : g0 + gs.size] = ev.branch.reshape(blk)
        if keep_actuators:
            if act is None:
                act = np.empty(shape + (ev.actuators.shape[-1],))
            act[g0 : g0 + gs.size] = ev.actuators.reshape(blk + (-1,))
    return OrientationMaps(
        alpha,
        beta,
        gamma,
        sigma,
        within,
        within & (sigma >= threshold),
        act,
        float(threshold),
        branch,
    )


# --------------------------------------------------------------------------- gamma range (Fig. 2)


def gamma_range_from_mask(
    in_workspace: np.ndarray,
    gamma_grid: np.ndarray,
    *,
    mode: Literal["extent", "component"] = "extent",
    gamma_ref: float | None = None,
    branch: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """gamma_min, gamma_max, n_in, n_runs from an in-workspace mask ``(n_g, ...)``.

    ``gamma_grid`` (n_g,) must be increasing. See the module docstring for the two modes.
    ``branch`` (n_g, ...), the sign of det of the rate Jacobian, cuts a run between two
    in-workspace neighbours whose signs differ (a singularity between grid points).
    """
    W = np.asarray(in_workspace, dtype=bool)
    g = np.asarray(gamma_grid, dtype=np.float64)
    if W.shape[0] != g.size or g.size == 0:
        raise ValueError(f"in_workspace: expected leading axis {g.size}, got shape {W.shape}")
    if np.any(np.diff(g) <= 0):
        raise ValueError("gamma_grid: expected strictly increasing values")
    n_in = W.sum(axis=0)
    prev_in = np.concatenate([np.zeros_like(W[:1]), W[:-1]], axis=0)
    if branch is not None:
        Bs = np.asarray(branch)
        crossed = np.concatenate([np.zeros_like(W[:1]), Bs[1:] != Bs[:-1]], axis=0)
        prev_in &= ~crossed
    starts = W & ~prev_in  # a run starts where the previous grid gamma does not continue it
    n_runs = starts.sum(axis=0)
    nan = np.full(W.shape[1:], np.nan)
    if mode == "extent":
        any_in = n_in > 0
        lo = np.argmax(W, axis=0)
        hi = g.size - 1 - np.argmax(W[::-1], axis=0)
        return np.where(any_in, g[lo], nan), np.where(any_in, g[hi], nan), n_in, n_runs
    if mode != "component":
        raise ValueError(f"mode: expected 'extent' or 'component', got {mode!r}")
    if gamma_ref is None:
        raise ValueError("gamma_ref: required for mode='component'")
    k = int(np.argmin(np.abs(g - gamma_ref)))
    idx = np.arange(g.size).reshape((-1,) + (1,) * (W.ndim - 1))
    # The run through k starts at the last start <= k and ends before the next start > k or
    # the first point out of the workspace above k.
    first = np.where(starts & (idx <= k), idx, -1).max(axis=0)
    below = first - 1
    stop = (~W) | starts
    above = np.where(stop & (idx > k), idx, g.size).min(axis=0)
    ok = W[k]
    return (
        np.where(ok, g[np.clip(below + 1, 0, g.size - 1)], nan),
        np.where(ok, g[np.clip(above - 1, 0, g.size - 1)], nan),
        n_in,
        n_runs,
    )


def gamma_range(
    evaluate: PoseEvaluator,
    alpha: Sequence[float] | np.ndarray,
    beta: Sequence[float] | np.ndarray,
    gamma_grid: Sequence[float] | np.ndarray,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    mode: Literal["extent", "component"] = "extent",
    gamma_ref: float | None = None,
) -> GammaRange:
    """gamma_min and gamma_max over the alpha-beta plane (lee Fig. 2).

    Parameters
    ----------
    evaluate : PoseEvaluator
    alpha, beta : array, shapes (n_a,), (n_b,)
        Grid axes [rad].
    gamma_grid : array, shape (n_g,)
        Increasing gamma values searched [rad]; the result's resolution.
    threshold : float
        Workspace threshold on sigma_KI.
    mode : {"extent", "component"}
    gamma_ref : float, optional
        Reference gamma [rad] for ``mode="component"``.

    Returns
    -------
    GammaRange
    """
    maps = orientation_maps(
        evaluate, alpha, beta, gamma_grid, threshold=threshold, keep_actuators=False
    )
    lo, hi, n_in, n_runs = gamma_range_from_mask(
        maps.in_workspace, maps.gamma, mode=mode, gamma_ref=gamma_ref, branch=maps.branch
    )
    return GammaRange(
        maps.alpha, maps.beta, maps.gamma, lo, hi, n_in, n_runs, mode, gamma_ref, float(threshold)
    )


# --------------------------------------------------------------------------- statistics


def area_fractions(in_workspace: np.ndarray) -> np.ndarray:
    """Fraction of the alpha-beta grid in the workspace at each gamma; (n_g, n_a, n_b) -> (n_g,)."""
    W = np.asarray(in_workspace, dtype=bool)
    return W.reshape(W.shape[0], -1).mean(axis=-1)


def volume_fraction(in_workspace: np.ndarray) -> float:
    """Fraction of the whole alpha-beta-gamma grid in the workspace."""
    return float(np.mean(np.asarray(in_workspace, dtype=bool)))


def sigma_statistics(sigma: np.ndarray, mask: np.ndarray | None = None) -> dict[str, float | int]:
    """Summary numbers of sigma_KI over the poses selected by ``mask`` (all when None).

    Returns ``{"count": n}`` alone when nothing is selected, else count, min, max, mean, median,
    p05, p95 (JSON-ready, never NaN).
    """
    s = np.asarray(sigma, dtype=np.float64)
    s = s[np.asarray(mask, dtype=bool)] if mask is not None else s.ravel()
    if s.size == 0:
        return {"count": 0}
    p05, p50, p95 = np.percentile(s, [5.0, 50.0, 95.0])
    return {
        "count": int(s.size),
        "min": float(s.min()),
        "max": float(s.max()),
        "mean": float(s.mean()),
        "median": float(p50),
        "p05": float(p05),
        "p95": float(p95),
    }


# --------------------------------------------------------------------------- lee scenarios


def _axis_from_range(lo_hi: tuple[float, float], n: int, name: str) -> np.ndarray:
    lo, hi = (float(v) for v in lo_hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi and n >= 2):
        raise ValueError(f"{name}: expected lo < hi and n >= 2, got ({lo}, {hi}), n = {n}")
    return np.linspace(lo, hi, int(n))


def _deg(x: float | np.floating[Any]) -> float:
    """Radians -> degrees for summary.json, rounded to 1e-9 deg (30, not 29.999999999999996)."""
    return round(math.degrees(float(x)), 9)


def _grid_entry(lo_hi: tuple[float, float], n: int) -> list[float]:
    return [_deg(lo_hi[0]), _deg(lo_hi[1]), int(n)]


def lee_workspace(
    *,
    r: float,
    gamma_sets: Mapping[str, Sequence[float]] | None = None,
    alpha_range: tuple[float, float] = (-math.pi / 2, math.pi / 2),
    beta_range: tuple[float, float] = (-math.pi / 2, math.pi / 2),
    n_alpha: int = 201,
    n_beta: int = 201,
    gamma_sweep: tuple[float, float] | None = None,
    n_gamma_sweep: int = 361,
    n_alpha_sweep: int = 91,
    n_beta_sweep: int = 91,
    gamma_mode: Literal["extent", "component"] = "extent",
    gamma_ref: float | None = None,
    threshold: float = DEFAULT_THRESHOLD,
    R: float = 1.0,
    center: tuple[float, float, float] = (0.0, 0.0, 1.0),
    stroke: tuple[float, float] = (0.5, 2.0),
    method: str = "closed_form",
    progress: Callable[[int, int], None] | None = None,
    poses: np.ndarray | Sequence[Sequence[float]] | None = None,
    stop: Callable[[], bool] | None = None,
) -> LeeWorkspaceRecord:
    """Compute the maps of one lee scenario from plain parameters (SI: lengths, rad).

    Parameters
    ----------
    r : float
        Top-plate radius (in units of the base radius ``R``, 1 in the paper).
    gamma_sets : mapping of str to sequence of float, optional
        Named gamma lists [rad] for sigma_KI maps (lee Figs. 3-5), e.g. ``{"text": 20/30/40
        deg, "captions": 20/40/60 deg}``. None or empty: no maps.
    alpha_range, beta_range : (float, float)
        Ranges [rad] of the alpha-beta grid, with ``n_alpha`` x ``n_beta`` points.
    gamma_sweep : (float, float), optional
        Range [rad] of the gamma grid for gamma_min/gamma_max (lee Fig. 2), with
        ``n_gamma_sweep`` points, on an ``n_alpha_sweep`` x ``n_beta_sweep`` grid over the same
        alpha/beta ranges. None: no gamma range.
    gamma_mode : {"extent", "component"}
    gamma_ref : float, optional
        [rad]; definition of gamma_min/gamma_max, see :func:`gamma_range`.
    threshold : float
        sigma_KI workspace threshold (0.01 in lee §3.2).
    R, center, stroke
        Base radius, centre of rotation P, and (l_min, l_max).
    method : {"closed_form", "svd"}
        Singular-value method.
    progress : callable, optional
        ``progress(done, total)`` over the maps (one per gamma set, one for the gamma range,
        one for the pose list).
    poses : array, shape (m, 3), optional
        An explicit list of (alpha, beta, gamma) [rad]: sigma_KI, leg lengths and workspace
        membership at each (summary ``poses``).
    stop : callable, optional
        ``stop()`` after every map but the last: when True the record holds the maps finished
        so far (each whole, in the order above; the caller's ``--max-time``).

    Returns
    -------
    LeeWorkspaceRecord
        ``summary`` reports angles in degrees (keys ending ``_deg``), including
        ``sigma_ki_at_origin``: sigma_KI at alpha = beta = 0 for each gamma (whether or not it is
        a grid point), the value PAPER_NOTES gives in closed form (0.483690 at 20 deg).
    """
    cx, cy, cz = (float(v) for v in center)
    geom = LeeGeometry(r=r, R=R, center=(cx, cy, cz), l_min=stroke[0], l_max=stroke[1])
    evaluate = lee_evaluator(geom, method=method)
    alpha = _axis_from_range(alpha_range, n_alpha, "alpha_range")
    beta = _axis_from_range(beta_range, n_beta, "beta_range")
    summary: dict[str, Any] = {
        "mechanism": "lee_spherical_rrps",
        "r": float(r),
        "R": float(R),
        "center": [cx, cy, cz],
        "stroke": [float(stroke[0]), float(stroke[1])],
        "threshold": float(threshold),
        "definition": {
            "in_workspace": "every leg within stroke and sigma_KI >= threshold",
            "fractions": "fractions of grid points (uniform in Euler angles)",
        },
    }
    isotropy: dict[str, OrientationMaps] = {}
    n_maps = len(gamma_sets or {}) + (gamma_sweep is not None) + (poses is not None)
    if progress is not None:
        progress(0, n_maps)
    for k_map, (name, gammas) in enumerate((gamma_sets or {}).items()):
        maps = orientation_maps(evaluate, alpha, beta, gammas, threshold=threshold)
        isotropy[name] = maps
        at_origin = evaluate(np.column_stack([0 * maps.gamma, 0 * maps.gamma, maps.gamma])).sigma
        per_gamma = []
        for g, gv in enumerate(maps.gamma):
            per_gamma.append(
                {
                    "gamma_deg": _deg(gv),
                    "sigma_ki_at_origin": float(at_origin[g]),
                    "area_fraction": float(area_fractions(maps.in_workspace[g : g + 1])[0]),
                    "within_stroke_fraction": float(np.mean(maps.within_limits[g])),
                    "sigma_ki_in_workspace": sigma_statistics(maps.sigma[g], maps.in_workspace[g]),
                    "sigma_ki_within_stroke": sigma_statistics(
                        maps.sigma[g], maps.within_limits[g]
                    ),
                }
            )
        summary.setdefault("isotropy", {})[name] = {
            "alpha_deg": _grid_entry(alpha_range, n_alpha),
            "beta_deg": _grid_entry(beta_range, n_beta),
            "gammas_deg": [_deg(v) for v in maps.gamma],
            "volume_fraction": volume_fraction(maps.in_workspace),
            "per_gamma": per_gamma,
        }
        if progress is not None:
            progress(k_map + 1, n_maps)
        if stop is not None and k_map + 1 < n_maps and stop():
            return LeeWorkspaceRecord(geom, isotropy, None, summary, None)
    gr: GammaRange | None = None
    if gamma_sweep is not None:
        gr = gamma_range(
            evaluate,
            _axis_from_range(alpha_range, n_alpha_sweep, "alpha_range"),
            _axis_from_range(beta_range, n_beta_sweep, "beta_range"),
            _axis_from_range(gamma_sweep, n_gamma_sweep, "gamma_sweep"),
            threshold=threshold,
            mode=gamma_mode,
            gamma_ref=gamma_ref,
        )
        d = gr.defined
        entry: dict[str, Any] = {
            "mode": gamma_mode,
            "gamma_ref_deg": None if gamma_ref is None else _deg(gamma_ref),
            "alpha_deg": _grid_entry(alpha_range, n_alpha_sweep),
            "beta_deg": _grid_entry(beta_range, n_beta_sweep),
            "gamma_deg": _grid_entry(gamma_sweep, n_gamma_sweep),
            "volume_fraction": float(gr.n_in.sum() / (gr.gamma_grid.size * gr.n_in.size)),
            "defined_fraction": float(d.mean()),
            "split_fraction": float(np.mean(gr.n_runs > 1)),
            "csv_rows": int(d.sum()),
            "rows_without_workspace": int((~d).sum()),
        }
        if d.any():
            entry["gamma_min_deg"] = {
                "min": _deg(gr.gamma_min[d].min()),
                "max": _deg(gr.gamma_min[d].max()),
            }
            entry["gamma_max_deg"] = {
                "min": _deg(gr.gamma_max[d].min()),
                "max": _deg(gr.gamma_max[d].max()),
            }
        summary["gamma_range"] = entry
        if progress is not None:
            progress(n_maps - (poses is not None), n_maps)
        if stop is not None and poses is not None and stop():
            return LeeWorkspaceRecord(geom, isotropy, gr, summary, None)
    plist: LeePoseList | None = None
    if poses is not None:
        P = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        ev = evaluate(P)
        inw = ev.within_limits & (ev.sigma >= threshold)
        plist = LeePoseList(P, ev.sigma, ev.within_limits, inw, ev.actuators)
        summary["poses"] = {
            "count": int(P.shape[0]),
            "within_stroke_fraction": float(ev.within_limits.mean()),
            "in_workspace_fraction": float(inw.mean()),
            "sigma_ki": sigma_statistics(ev.sigma),
            "sigma_ki_in_workspace": sigma_statistics(ev.sigma, inw),
        }
        if progress is not None:
            progress(n_maps, n_maps)
    return LeeWorkspaceRecord(geom, isotropy, gr, summary, plist)

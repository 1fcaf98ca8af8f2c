"""The records of a workspace run: what ``mechkin.io.workspace_out`` writes (DESIGN.md: records).

Every kind of ``workspace:`` section has its record of plain arrays and JSON-ready values:

* :class:`OrientationMaps`, :class:`GammaRange` and :class:`LeeWorkspaceRecord`: lee's
  isotropy maps (Figs. 3-5) and gamma_min/gamma_max (Fig. 2), computed by
  :func:`mechkin.solvers.workspace.maps.lee_workspace`;
* :class:`DesignSweepRecord`: one lee record per value of a design parameter
  (:func:`mechkin.solvers.workspace.sweeps.lee_design_sweep`);
* :class:`TaskSpaceRecord`: reachability and dexterity of task-space poses
  (:func:`mechkin.solvers.workspace.sweeps.task_space_sweep`);
* :class:`JointSweepRecord`: reachable positions and dexterity of a joint-space sweep
  (:func:`mechkin.solvers.workspace.joint_sweep.joint_sweep`).

:class:`WorkspaceOutput` wraps one of them with what only the writer needs (titles, CSV
column names, plot options); it is the ``data`` of the workspace :class:`~mechkin.records.Report`.

Imports: numpy and the standard library only (solvers and io both import this module).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "DesignSweepRecord",
    "GammaRange",
    "JointSweepRecord",
    "LeePoseList",
    "LeeWorkspaceRecord",
    "OrientationMaps",
    "TaskSpaceRecord",
    "WorkspaceOutput",
]


@dataclass(frozen=True)
class OrientationMaps:
    """Isotropy and workspace over an alpha-beta grid at several gammas.

    Attributes
    ----------
    alpha : ndarray, shape (n_a,)
    beta : ndarray, shape (n_b,)
    gamma : ndarray, shape (n_g,)
        Grid axes [rad].
    sigma : ndarray, shape (n_g, n_a, n_b)
        sigma_KI at ``(alpha[i], beta[j], gamma[g])`` -> ``sigma[g, i, j]``.
    within_limits, in_workspace : ndarray of bool, shape (n_g, n_a, n_b)
    actuators : ndarray, shape (n_g, n_a, n_b, k), or None
    threshold : float
    branch : ndarray of int8, shape (n_g, n_a, n_b), or None
        Sign of det of the rate Jacobian, when the evaluator provides it.
    """

    alpha: np.ndarray
    beta: np.ndarray
    gamma: np.ndarray
    sigma: np.ndarray
    within_limits: np.ndarray
    in_workspace: np.ndarray
    actuators: np.ndarray | None
    threshold: float
    branch: np.ndarray | None = None


@dataclass(frozen=True)
class GammaRange:
    """gamma_min / gamma_max over the alpha-beta plane (lee Fig. 2); see
    :mod:`mechkin.solvers.workspace.maps` for the definitions.

    Attributes
    ----------
    alpha, beta : ndarray, shapes (n_a,), (n_b,)
    gamma_grid : ndarray, shape (n_g,)
        The gamma values searched [rad].
    gamma_min, gamma_max : ndarray, shape (n_a, n_b)
        [rad]; NaN where no grid gamma qualifies (``n_in == 0``, or for ``"component"`` when
        the grid point nearest ``gamma_ref`` is outside the workspace).
    n_in : ndarray of int, shape (n_a, n_b)
        In-workspace grid gammas at each (alpha, beta).
    n_runs : ndarray of int, shape (n_a, n_b)
        Separate runs of consecutive in-workspace grid gammas (1 = one interval), cut also
        where the sign of det of the rate Jacobian changes.
    mode : {"extent", "component"}
    gamma_ref : float or None
    threshold : float
    """

    alpha: np.ndarray
    beta: np.ndarray
    gamma_grid: np.ndarray
    gamma_min: np.ndarray
    gamma_max: np.ndarray
    n_in: np.ndarray
    n_runs: np.ndarray
    mode: str
    gamma_ref: float | None
    threshold: float

    @property
    def defined(self) -> np.ndarray:
        """True where gamma_min/gamma_max are defined (not NaN), shape (n_a, n_b)."""
        return np.isfinite(self.gamma_min)


@dataclass(frozen=True)
class LeePoseList:
    """sigma_KI at an explicit list of ``m`` orientations of lee's mechanism.

    Attributes
    ----------
    poses : ndarray, shape (m, 3)
        (alpha, beta, gamma) [rad].
    sigma : ndarray, shape (m,)
    within_limits, in_workspace : ndarray of bool, shape (m,)
    actuators : ndarray, shape (m, 3)
        Leg lengths.
    """

    poses: np.ndarray
    sigma: np.ndarray
    within_limits: np.ndarray
    in_workspace: np.ndarray
    actuators: np.ndarray


@dataclass(frozen=True)
class LeeWorkspaceRecord:
    """Everything one lee workspace scenario computes (arrays + JSON-ready summary).

    Attributes
    ----------
    geometry : LeeGeometry
        :class:`mechkin.solvers.closed_form.lee_spherical.LeeGeometry` (the writer reads
        ``geometry.r`` only).
    isotropy : dict of str to OrientationMaps
        One entry per named gamma set (e.g. ``"text"``: 20/30/40 deg, ``"captions"``:
        20/40/60 deg), each a (n_g, n_a, n_b) map for lee Figs. 3-5.
    gamma_range : GammaRange or None
        lee Fig. 2, when requested.
    summary : dict
        Area/volume fractions and sigma_KI statistics per gamma set, gamma-range statistics,
        grid descriptions; degrees in keys ending ``_deg``.
    poses : LeePoseList or None
        The explicit pose list, when given.
    """

    geometry: Any
    isotropy: dict[str, OrientationMaps]
    gamma_range: GammaRange | None
    summary: dict[str, Any]
    poses: LeePoseList | None = None


@dataclass(frozen=True)
class DesignSweepRecord:
    """One lee workspace record per value of a design parameter.

    Attributes
    ----------
    parameter : str
        ``r``, ``R``, ``l_min`` or ``l_max``.
    values : tuple of float
        The values swept (SI).
    records : tuple of LeeWorkspaceRecord
        ``records[i]`` computed with ``parameter = values[i]``.
    comparison : list of dict
        :func:`mechkin.solvers.workspace.sweeps.design_comparison` of the records (JSON-ready).
    """

    parameter: str
    values: tuple[float, ...]
    records: tuple[LeeWorkspaceRecord, ...]
    comparison: list[dict[str, Any]]


@dataclass(frozen=True)
class TaskSpaceRecord:
    """Reachability and dexterity of ``m`` task-space poses (rows follow the input poses).

    Attributes
    ----------
    T_P : ndarray, shape (m, 4, 4)
        Target poses.
    q_v : ndarray, shape (m, n_v)
        Independent joints at the solutions (best attempt where not reached).
    status : ndarray of str, shape (m,)
        :class:`mechkin.solvers.ik.IkStatus` values.
    reachable : ndarray of bool, shape (m,)
        Status ok.
    position_error, orientation_error : ndarray, shape (m,)
        Verified by forward kinematics [m], [rad].
    iterations : ndarray of int, shape (m,)
    isotropy, isotropy_position, condition_number, manipulability : ndarray, shape (m,)
        Dexterity at the solutions (see :mod:`mechkin.solvers.workspace.sweeps`); 0
        (condition number: 0 too) where not reachable.
    isotropy_normalized : ndarray, shape (m,) or None
        The dimensionally honest isotropy (translational rows / ``characteristic_length``);
        0 where not reachable.
    characteristic_length : float or None
        [m].
    """

    T_P: np.ndarray
    q_v: np.ndarray
    status: np.ndarray
    reachable: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    iterations: np.ndarray
    isotropy: np.ndarray
    isotropy_position: np.ndarray
    condition_number: np.ndarray
    manipulability: np.ndarray
    isotropy_normalized: np.ndarray | None = None
    characteristic_length: float | None = None


@dataclass(frozen=True)
class JointSweepRecord:
    """``m`` samples of the independent joints and the frame they put where.

    Attributes
    ----------
    q_v : ndarray, shape (m, n_v)
        Independent joint values of the samples [rad | m].
    q : ndarray, shape (m, n)
        Every joint (0 where not finite).
    position : ndarray, shape (m, 3)
        Position of the swept frame [m] (0 where not finite).
    status : ndarray of str, shape (m,)
        :class:`mechkin.model.closure.ClosureStatus` values.
    converged, within_limits, reachable : ndarray of bool, shape (m,)
        Loop closure converged; every joint within limits; both and finite.
    manipulability, isotropy, isotropy_position : ndarray, shape (m,) or None
        Dexterity of the reduced frame Jacobian (None when not asked); 0 where not reachable.
    isotropy_normalized : ndarray, shape (m,) or None
        sigma_min/sigma_max of the Jacobian with translational rows divided by
        ``characteristic_length`` (and prismatic columns multiplied by it): the dimensionally
        honest index (:mod:`mechkin.solvers.workspace.dexterity`).
    characteristic_length : float or None
        [m].
    seed : ndarray of int, shape (m,), optional
        The sample whose solution started this sample's loop closure (-1: home).
    mode_change : ndarray of bool, shape (m,), optional
        The dependent joints jumped away from the branch of the seed sample (a change of
        assembly mode; see :func:`mechkin.solvers.workspace.joint_sweep.joint_sweep`).
    reseeded : ndarray of bool, shape (m,), optional
        The closure failed from the seed sample and was solved from home instead.
    crossed : ndarray of bool, shape (m,), optional
        A mode change on one smooth branch: the sign of ``det(dphi/dq_w)`` changed from the
        seed sample while the dependent joints followed the predictor (a constraint
        singularity, e.g. a four-bar's change point, lies between the two).
    """

    q_v: np.ndarray
    q: np.ndarray
    position: np.ndarray
    status: np.ndarray
    converged: np.ndarray
    within_limits: np.ndarray
    reachable: np.ndarray
    manipulability: np.ndarray | None = None
    isotropy: np.ndarray | None = None
    isotropy_position: np.ndarray | None = None
    isotropy_normalized: np.ndarray | None = None
    characteristic_length: float | None = None
    seed: np.ndarray | None = None
    mode_change: np.ndarray | None = None
    reseeded: np.ndarray | None = None
    crossed: np.ndarray | None = None


@dataclass
class WorkspaceOutput:
    """What ``mechkin.io.workspace_out.write`` needs for one workspace run.

    Attributes
    ----------
    kind : {"lee_spherical", "design", "task_space", "joint_sweep"}
    record : LeeWorkspaceRecord | DesignSweepRecord | TaskSpaceRecord | JointSweepRecord
    title : str
        Title of the main figure (task space and joint sweeps).
    joint_columns : list of str
        CSV column names of the independent joints (``<name>_rad`` / ``<name>_m``).
    slices : dict, optional
        Joint sweeps: the section planes of the point-cloud plot in SI, ``{"axis": "z",
        "at": [..] or None, "thickness": float or None}``; None: default planes.
    """

    kind: str
    record: Any
    title: str = ""
    joint_columns: list[str] = field(default_factory=list)
    slices: dict[str, Any] | None = None
    robot: Any = None  # records.robot.RobotSnapshot: the mechanism in workspace.mcap

"""The record of a track run (park §2-§5): what ``mechkin.io.track_out`` writes.

:class:`TrackTrajectory` is the realised trajectory at the DP nodes (the solver
:mod:`mechkin.solvers.track.dpct` returns it inside its ``TrackResult``); :class:`TrackRecord` adds
the plain arrays the CSV, the plots like park Figs. 4-8 and the MCAP need (frame tree, stick
segments, the other grids of a grid study, the part's phase-plane reference, the limits).

Imports: numpy and the standard library only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class TrackTrajectory:
    """The realised trajectory at the DP nodes (plus a rest node at ``t = 0`` if the hand waits).

    All arrays have K rows. ``qdd`` (Eq. (32)) and ``jerk`` (Eq. (33)) are forward differences
    and NaN where undefined: ``qdd`` at the last node, ``jerk`` at the last two nodes and across
    the initial wait. ``rdd`` and ``torque`` at node k belong to the transition leaving it
    (``rdd = 0`` at the last node). ``part`` and ``tracking_error`` are None without a reference.
    """

    t: np.ndarray  # (K,) [s]
    r: np.ndarray  # (K,) [-]
    rd: np.ndarray  # (K,) [1/s]
    rdd: np.ndarray  # (K,) [1/s^2]
    q: np.ndarray  # (K, n) [rad | m]
    qd: np.ndarray  # (K, n)
    qdd: np.ndarray  # (K, n)
    jerk: np.ndarray  # (K, n)
    torque: np.ndarray  # (K, n) [N m | N]
    hand: np.ndarray  # (K, d) [m]
    part: np.ndarray | None  # (K, d) [m]
    tracking_error: np.ndarray | None  # (K, d) hand - part [m]
    #: (K,) [1/s] the phase plane's limit curve at each node's r: the largest r' the torque and
    #: velocity limits admit (inf: unbounded; NaN: none admissible); None if not computed
    rd_limit: np.ndarray | None = None

    def columns(self, prismatic: Sequence[bool] | None = None) -> dict[str, np.ndarray]:
        """CSV-ready columns ``name_unit -> (K,)``: ``t_s, r, rd_1_s, q1_rad, u1_Nm, hand_x_m``...

        ``prismatic[k]`` switches joint k's units to m, m/s, ... and N (default: all revolute).
        """
        n = self.q.shape[1]
        pris = [False] * n if prismatic is None else list(prismatic)
        cols: dict[str, np.ndarray] = {
            "t_s": self.t,
            "r": self.r,
            "rd_1_s": self.rd,
            "rdd_1_s2": self.rdd,
        }
        for name, arr, unit_r, unit_p in (
            ("q", self.q, "rad", "m"),
            ("qd", self.qd, "rad_s", "m_s"),
            ("qdd", self.qdd, "rad_s2", "m_s2"),
            ("jerk", self.jerk, "rad_s3", "m_s3"),
            ("u", self.torque, "Nm", "N"),
        ):
            for k in range(n):
                cols[f"{name}{k + 1}_{unit_p if pris[k] else unit_r}"] = arr[:, k]
        axes = "xyz"
        points = (("hand", self.hand), ("part", self.part), ("error", self.tracking_error))
        for label, pts in points:
            if pts is not None:
                for k in range(pts.shape[1]):
                    cols[f"{label}_{axes[k]}_m"] = pts[:, k]
        return cols



@dataclass(frozen=True)
class GridTrace:
    """The phase-plane path ``(r, r')`` planned on one grid of a grid study (park §5.2)."""

    N1: int
    N2: int
    r: np.ndarray  # (K,)
    rd: np.ndarray  # (K,) [1/s]


@dataclass(frozen=True)
class CaseTrace:
    """One case of ``track.cases`` (park §5.3 compares three limit sets, Figs. 5-8): its name
    (the legend), realised plan, ``t_a`` [s] and limits ``name -> (lo, hi)`` [SI]."""

    name: str
    trajectory: TrackTrajectory
    t_a_s: float | None
    limits: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


@dataclass
class TrackRecord:
    """A planned track run as plain arrays for ``track.csv``, the PNGs and ``track.mcap``.

    Attributes
    ----------
    title : str
        Scenario name (plot titles, MCAP metadata).
    mechanism : str
        Mechanism name.
    joint_names : list of str
    prismatic : list of bool
        Per joint: prismatic (units m, N) or revolute (rad, N m).
    trajectory : TrackTrajectory
        The realised plan on the scenario's grid.
    grid : tuple of int
        ``(N1, N2)`` of that grid.
    t_a_s : float or None
        End of the transient (tracking) [s].
    phase_ref : tuple of float, optional
        ``(r0, x~2)`` of the part's reference ``x~1(t) = r0 + x~2 t`` (park Eq. (16)-(17)).
    study : list of GridTrace
        The other grids of a grid study (drawn in the phase plot).
    limits : dict
        ``name -> (lo (n,), hi (n,))`` [SI] (dashed in the joint plots).
    ends : array (2, 3)
        The hand line's end points [m].
    belt_velocity : array (3,), optional
        The belt's velocity [m/s] (the part and belt boxes of the MCAP scene).
    part_size : array (3,), optional
        The part box's size [m].
    segments : array (K, s, 2, 3), optional
        Stick-drawing segments in the base frame at every sample.
    axis_points : array (K, n, 3), optional
        A point on every joint axis.
    frame_root, frame_names, frame_parents, T_parent_child
        The /tf frame tree (``T_parent_child (K, k, 4, 4)``).
    metadata : dict
        MCAP metadata (scenario, mechanism, task).
    cases : list of CaseTrace
        The plans of ``track.cases``, drawn together in the overlay plots (park Figs. 5-8).
    hand_T : array (K, 4, 4), optional
        The hand frame's pose in the base frame at every sample (the triads of ``path_3d.png``).
    hand_frame : str, optional
        The hand frame's name.
    actuated : list of int, optional
        The joints the per-joint figures show (a closed chain's independent joints, the motors;
        None: every joint).
    """

    title: str
    mechanism: str
    joint_names: list[str]
    prismatic: list[bool]
    trajectory: TrackTrajectory
    grid: tuple[int, int]
    t_a_s: float | None
    phase_ref: tuple[float, float] | None = None
    study: list[GridTrace] = field(default_factory=list)
    limits: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    ends: np.ndarray | None = None
    belt_velocity: np.ndarray | None = None
    part_size: np.ndarray | None = None
    segments: np.ndarray | None = None
    axis_points: np.ndarray | None = None
    frame_root: str | None = None
    frame_names: list[str] = field(default_factory=list)
    frame_parents: list[str] = field(default_factory=list)
    T_parent_child: np.ndarray | None = None
    robot: Any = None  # records.robot.RobotDescription: the MCAP's URDF
    motors: list[str] | None = None  # actuated joints (the layout plots their torques)
    metadata: dict[str, Any] = field(default_factory=dict)
    cases: list[CaseTrace] = field(default_factory=list)
    hand_T: np.ndarray | None = None
    hand_frame: str | None = None
    actuated: list[int] | None = None

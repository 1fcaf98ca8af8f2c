"""The record of a motion (fk steps, ik targets): what ``mechkin.io.motion_out`` writes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class MotionRecord:
    """A mechanism at m configurations, as plain arrays for CSV, plots and MCAP.

    Attributes
    ----------
    task : str
        Base name of the CSV and MCAP files (``fk`` -> ``fk.csv``, ``fk.mcap``).
    title : str
        Scenario name (plot titles).
    mechanism : str
        Mechanism name.
    times : array (m,)
        Time of each configuration [s] (ik: one second per target).
    q : array (m, n)
        Every joint [rad | m].
    joint_names, joint_units : list of str
        Names and SI unit suffixes (``rad`` | ``m``) of the n joints.
    qd : array (m, n), optional
        Joint rates (fk), for ``/joint_states`` velocities.
    columns : dict
        The CSV table, in column order (units in the names).
    segments : array (m, s, 2, 3), optional
        Stick-drawing segments in the base frame, or in the world frame when the record has a
        moving base (plots and /scene); None when neither is asked.
    plates : dict of str to array (m, p, 3)
        Plates of the stick drawing (filled polygons, :mod:`mechkin.model.drawing`).
    axis_points : array (m, n, 3), optional
        A point on every joint axis (/scene spheres), in the frame of ``segments``.
    frame_root, frame_names, frame_parents, T_parent_child
        The /tf frame tree (``T_parent_child`` (m, k, 4, 4)); None when no MCAP is asked.
    state : list of dict
        Per-step ``/mechkin/state`` messages.
    metadata : dict
        MCAP metadata (scenario, mechanism, task).
    snapshots, snapshot_labels
        Which configurations the stick plot shows, and their labels.
    convergence : dict, optional
        ik: objective history per target label for ``convergence.png``.
    convergence_ylabel, convergence_title : str
        Labels of that plot.
    targets : array (m, 3), optional
        ik: the target position of each row in the base frame [m] (stick-plot markers).
    world_frame : str, optional
        fk with ``base:`` (kim1995 §5.1 Step 1): name of the world frame; the MCAP frame tree is
        then rooted there, with ``T_world_base`` (m, 4, 4), the base pose T_0(t), as the
        transform world -> ``frame_root``.
    T_world_base : array (m, 4, 4), optional
        The base pose in the world frame at each configuration.
    table : str
        Format of the ``<task>`` table: ``csv`` (``<task>.csv``), ``npz`` or ``parquet``
        (``outputs.table``; :mod:`mechkin.io.table_out`).
    robot : RobotDescription, optional
        The robot model for the MCAP's URDF (:mod:`mechkin.records.robot`); None without MCAP.
    motors : list of str, optional
        The actuated (independent) joints; the layout switches the others' series off.
    target_poses : array (m, 4, 4), optional
        ik: the target pose of each row in the base frame (MCAP: the ``/tf`` frame ``target``
        and its axes in ``/scene``).
    """

    task: str
    title: str
    mechanism: str
    times: np.ndarray
    q: np.ndarray
    joint_names: list[str]
    joint_units: list[str]
    columns: dict[str, Any]
    qd: np.ndarray | None = None
    segments: np.ndarray | None = None
    plates: dict[str, np.ndarray] = field(default_factory=dict)
    axis_points: np.ndarray | None = None
    frame_root: str | None = None
    frame_names: list[str] = field(default_factory=list)
    frame_parents: list[str] = field(default_factory=list)
    T_parent_child: np.ndarray | None = None
    state: list[dict[str, Any]] = field(default_factory=list)
    metadata: dict[str, str] = field(default_factory=dict)
    snapshots: list[int] = field(default_factory=list)
    snapshot_labels: list[str] = field(default_factory=list)
    convergence: dict[str, np.ndarray] | None = None
    convergence_ylabel: str = ""
    convergence_title: str = ""
    targets: np.ndarray | None = None
    world_frame: str | None = None
    T_world_base: np.ndarray | None = None
    table: str = "csv"
    robot: Any = None
    motors: list[str] | None = None
    target_poses: np.ndarray | None = None

"""The record of a biped run (``mechkin ik`` with ``biped:``): what ``mechkin.io.biped_out``
writes (``leg_right.csv``, ``leg_left.csv``, ``frames.csv``, ``biped.png``, ``biped.mcap``).

Plain arrays and values only: the task (``mechkin.tasks.biped``) fills them from the solved
sequence; the writer draws and logs them without knowing the closed forms.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class BipedPlot:
    """One snapshot panel of ``biped.png``: polylines (k, 3) [m] by name and a label."""

    polylines: dict[str, np.ndarray]
    label: str


@dataclass
class BipedRecord:
    """A biped sequence as plain arrays (m frames of the animation, one CSV row per step).

    Attributes
    ----------
    title : str
        Scenario name.
    mechanism : str
        Mechanism name.
    columns : dict
        ``{"right": {...}, "left": {...}}``: the two CSV tables in column order.
    frame_columns : dict
        ``frames.csv`` in column order: one row per frame of the animation (time, step, each
        leg joint's value ``<joint>_rad`` and rate ``<joint>_rad_s``, the contact angles).
    plot_title : str
        Title of ``biped.png``.
    snapshots : list of BipedPlot
        The panels of ``biped.png`` (the last frame of each step, at most 12).
    plot_planes : list of (origin (3,), normal (3,), size)
        The planes drawn under the panels.
    times : array (m,)
        Time of every frame [s].
    polylines : list of dict
        Per frame: ``body``, ``leg_right``, ``leg_left`` and ``foot_<side>`` or
        ``blade_<side>`` polylines (k, 3) [m] (world).
    contacts : array (m, 2, 3)
        Contact point of the right and left leg per frame [m].
    T_plane : array (m, p, 4, 4)
        The pose of each drawn plane per frame (p = 1: one plane ``plane``; 2: ``plane`` under
        the right and ``plane_left`` under the left leg).
    plane_half : float
        Half side of the drawn planes [m].
    T_0_G : array (m, 4, 4)
        Body pose per frame.
    label_texts : list of str
        Per frame label (step name and class).
    frame_root, frame_names, frame_parents, T_parent_child
        The mechanism's /tf tree (rooted at the body) per frame.
    joint_names : list of str
        Every joint of the mechanism.
    q : array (m, n)
        Joint values per frame [rad] (every run, also without MCAP).
    qd : array (m, n)
        Joint rates per frame [rad/s]: finite differences of ``q`` over ``times``
        (``mechkin.tasks.biped.frame_rates``); ``/joint_states`` velocity.
    state : list of dict
        Per-frame ``/mechkin/state`` messages.
    state_schema : dict, optional
        Explicit JSON schema of those messages.
    metadata : dict
        MCAP metadata.
    """

    title: str
    mechanism: str
    columns: dict[str, dict[str, list[Any]]]
    frame_columns: dict[str, list[Any]] = field(default_factory=dict)
    plot_title: str = ""
    snapshots: list[BipedPlot] = field(default_factory=list)
    plot_planes: list[tuple[np.ndarray, np.ndarray, float]] = field(default_factory=list)
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    polylines: list[dict[str, np.ndarray]] = field(default_factory=list)
    contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    T_plane: np.ndarray = field(default_factory=lambda: np.zeros((0, 1, 4, 4)))
    plane_half: float = 0.35
    T_0_G: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))
    label_texts: list[str] = field(default_factory=list)
    frame_root: str = ""
    frame_names: list[str] = field(default_factory=list)
    frame_parents: list[str] = field(default_factory=list)
    T_parent_child: np.ndarray | None = None
    robot: Any = None  # records.robot.RobotDescription: the MCAP's URDF
    joint_names: list[str] = field(default_factory=list)
    q: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    qd: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    state: list[dict[str, Any]] = field(default_factory=list)
    state_schema: dict[str, Any] | None = None
    metadata: dict[str, str] = field(default_factory=dict)

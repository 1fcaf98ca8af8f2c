"""The robot model a run hands to io: the mechanism (read duck-typed by
``mechkin.io.urdf_out.mechanism_to_urdf``, as ``mechkin export`` does) and the visual
geometry of its links, worked out by the task layer (``mechkin.tasks.robot``), so io writes a
URDF with visuals without importing the model.

Imports: numpy and the standard library only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

RGBA = tuple[float, float, float, float]

__all__ = ["RGBA", "RobotDescription", "RobotSnapshot", "Visual"]


@dataclass(frozen=True, eq=False)
class Visual:
    """One visual element of a URDF link.

    Attributes
    ----------
    link : str
        The URDF link (a mechkin link or named frame) it is fixed on.
    shape : {"cylinder", "sphere", "box", "mesh", "prism"}
        URDF geometry; a cylinder's axis is the z axis of ``T``; a prism is ``polygon``
        extruded along z (a plate; written as a mesh, :mod:`mechkin.io.collada`).
    T : array (4, 4)
        Pose of the geometry in the link frame.
    size : tuple of float
        cylinder (radius, length), sphere (radius,), box (x, y, z), mesh (sx, sy, sz) scale,
        prism (thickness,) [m].
    material : str
        Name of a colour in :attr:`RobotDescription.materials`; ``""``: none (a mesh keeps
        its own colours).
    uri : str
        Mesh file URI (``package://``, ``file://``, ``http(s)://``) for ``mesh``.
    polygon : array (p, 2), optional
        A prism's outline in the xy plane of ``T`` [m].
    generated : bool
        Generated from the kinematics (written as ``<visual name="mechkin_generated">``, which
        ``mechkin import`` skips), or False: the mechanism file's own visual.
    """

    link: str
    shape: str
    T: np.ndarray
    size: tuple[float, ...]
    material: str
    uri: str = ""
    polygon: np.ndarray | None = None
    generated: bool = True


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """What the URDF of a run is written from.

    Attributes
    ----------
    mechanism : object
        The built mechanism (duck-typed: names, ``A``, ``B``, limits, frames, cuts).
    visuals : tuple of Visual
        The mechanism file's own visuals (imported meshes, primitives) on their links, and
        generated geometry on the others: link cylinders between joint points, joint cylinders
        along their axes, plates; the end-effector triad.
    materials : dict of str to RGBA
        Colours the visuals name.
    rate_limits : dict of str to (velocity, effort)
        Joint velocity [rad/s | m/s] and effort [N m | N] limits where the run knows them (a
        track scenario's limits); written into the URDF ``<limit>`` elements of the joints whose
        mechanism file gives no ``velocity_limit`` / ``torque_limit`` of its own.
    """

    mechanism: Any
    visuals: tuple[Visual, ...] = ()
    materials: dict[str, RGBA] = field(default_factory=dict)
    rate_limits: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class RobotSnapshot:
    """The robot at a few configurations, for logs of tasks that are not motions (a workspace
    map shows the mechanism at home beside its point cloud).

    Attributes
    ----------
    description : RobotDescription
    root : str
        The base frame.
    frame_names, frame_parents : list of str
        The URDF's frame tree (:func:`mechkin.model.urdf_tree.urdf_frame_tree`).
    T_parent_child : array (m, k, 4, 4)
    joint_names : list of str
    q : array (m, n)
        Every joint [rad | m].
    """

    description: RobotDescription
    root: str
    frame_names: list[str]
    frame_parents: list[str]
    T_parent_child: np.ndarray
    joint_names: list[str]
    q: np.ndarray

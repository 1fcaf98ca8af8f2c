"""The content of an MCAP log, validated: :class:`MotionLog` (frame tree, joint states, per-step
state) and the scene items ``/scene`` draws (:class:`Lines`, :class:`Spheres`, :class:`Box`,
:class:`Label` in a :class:`Scene`), with the helpers callers use to build them
(:func:`poses_in_root`, :func:`skeleton_scene`). The channels that encode them are in
:mod:`mechkin.io.mcap_channels`; the writer is :func:`mechkin.io.mcap_out.write_mcap`.

Imports: errors only (numpy and the standard library).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mechkin.errors import OutputError

RGBA = tuple[float, float, float, float]
NS_PER_S = 1_000_000_000
ROTATION_TOL = 1e-6

# ---------------------------------------------------------------------------------------------
# Scene description: each item is either static (no time axis) or has one value per step.
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Lines:
    """A polyline in the root frame.

    Parameters
    ----------
    points : array, shape (m, p, 3) or (p, 3)
        Vertices per step [m], or one static set.
    rgba : tuple of 4 floats
        Colour, components in [0, 1].
    kind : {"strip", "loop", "list"}
        ``strip`` joins consecutive points, ``loop`` also closes the polygon, ``list`` draws
        independent segments 0-1, 2-3, ... (p must be even).
    thickness : float
        Line width [m].
    """

    points: np.ndarray
    rgba: RGBA = (0.85, 0.85, 0.85, 1.0)
    kind: str = "strip"
    thickness: float = 0.01


@dataclass(frozen=True, eq=False)
class Spheres:
    """Spheres of one radius in the root frame (joints, attachment points).

    Parameters
    ----------
    centers : array, shape (m, s, 3) or (s, 3)
        Centres per step [m], or static.
    radius : float
        Radius [m].
    rgba : tuple of 4 floats
        Colour.
    """

    centers: np.ndarray
    radius: float = 0.02
    rgba: RGBA = (0.95, 0.55, 0.1, 1.0)


@dataclass(frozen=True, eq=False)
class Box:
    """A box (a part on a conveyor, a plane drawn as a thin slab) in the root frame.

    Parameters
    ----------
    T : array, shape (m, 4, 4) or (4, 4)
        ``T_root_box``, pose of the box centre per step, or static.
    size : array, shape (3,)
        Edge lengths along the box axes [m].
    rgba : tuple of 4 floats
        Colour (alpha < 1 for translucent planes).
    """

    T: np.ndarray
    size: np.ndarray
    rgba: RGBA = (0.3, 0.7, 0.3, 0.6)


@dataclass(frozen=True, eq=False)
class Label:
    """A text label that faces the camera.

    Parameters
    ----------
    position : array, shape (m, 3) or (3,)
        Anchor point per step [m], or static.
    text : str or sequence of m str
        The text, fixed or one per step (e.g. the gait phase).
    rgba : tuple of 4 floats
        Colour.
    font_size : float
        Height of a line of text [m].
    """

    position: np.ndarray
    text: str | Sequence[str]
    rgba: RGBA = (1.0, 1.0, 1.0, 1.0)
    font_size: float = 0.05


@dataclass(frozen=True, eq=False)
class Points:
    """A static point cloud (``foxglove.PointCloud``, written once at the first step): e.g. the
    reachable positions of a workspace map with their isotropy index.

    Parameters
    ----------
    frame_id : str
        Frame of the points (a frame of the log's tree).
    points : array, shape (p, 3)
        Positions [m].
    fields : mapping of str to array (p,)
        Scalar fields per point (``isotropy`` ...), written as float32 beside x, y, z.
    """

    frame_id: str
    points: np.ndarray
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Scene:
    """What ``/scene`` draws at every step: one SceneEntity ``entity_id`` in the root frame."""

    lines: Sequence[Lines] = ()
    spheres: Sequence[Spheres] = ()
    boxes: Sequence[Box] = ()
    labels: Sequence[Label] = ()
    entity_id: str = "mechanism"


# ---------------------------------------------------------------------------------------------
# The log record.
# ---------------------------------------------------------------------------------------------


def _as_float_array(x: Any, what: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise OutputError(f"{what}: expected numbers, got {type(x).__name__}") from e
    if not np.isfinite(a).all():
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise OutputError(f"{what}{list(idx)}: expected a finite number, got {a[idx]!r}")
    return a


def _check_shape(a: np.ndarray, shape: tuple[int | None, ...], what: str) -> None:
    ok = a.ndim == len(shape) and all(s is None or s == d
                                      for s, d in zip(shape, a.shape, strict=False))
    if not ok:
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise OutputError(f"{what}: expected shape {want}, got {a.shape}")


def _per_step(a: np.ndarray, m: int, item_shape: tuple[int | None, ...], what: str) -> np.ndarray:
    """Broadcast a static item (item_shape) or check a per-step one ((m,) + item_shape)."""
    if a.ndim == len(item_shape):
        _check_shape(a, item_shape, what)
        return np.broadcast_to(a, (m,) + a.shape)
    _check_shape(a, (m,) + item_shape, what)
    return a


@dataclass(frozen=True, eq=False)
class MotionLog:
    """Everything one MCAP log shows, as arrays over m time steps.

    Parameters
    ----------
    times : array, shape (m,)
        Simulated time of each step [s], non-decreasing, ``>= 0``.
    root_frame : str
        The one frame without a parent (e.g. ``"world"``); the scene is drawn in it.
    frame_names : sequence of k str
        The other frames (unique, none equal to ``root_frame``).
    frame_parents : sequence of k str
        Parent of each frame: ``root_frame`` or another entry of ``frame_names``. The tree is
        fixed for the whole log.
    T_parent_child : array, shape (m, k, 4, 4)
        Pose of each frame in its parent at each step.
    joint_names : sequence of n str
        Names for ``/joint_states``; empty -> no such channel.
    q, qd, qdd, effort : array, shape (m, n), optional
        Joint positions [rad | m], velocities, accelerations and efforts [N*m | N].
        ``q`` is required when ``joint_names`` is given.
    scene : Scene, optional
        What ``/scene`` draws; default :func:`skeleton_scene` of the frame tree.
    state : sequence of m mappings, optional
        Per-step JSON-able values for ``/mechkin/state`` (residuals, errors, leg lengths,
        phase ...). NaN is refused; use ``None`` for a missing value.
    state_schema : mapping, optional
        JSON schema of a state message; default inferred from ``state``.
    epoch_ns : int
        Log time of ``t = 0`` [ns].
    metadata : mapping of str to str
        Written as the MCAP metadata record ``"mechkin"`` (scenario name, version ...).
    robot_description : str, optional
        The URDF of the mechanism (its spanning tree, with visuals): written once, at the first
        step, on ``/robot_description`` (``{"data": urdf}``, schema ``std_msgs/msg/String``,
        which Foxglove's URDF layer reads) and as the attachment ``robot.urdf``.
    point_clouds : mapping of topic to Points
        Static point clouds, each written once at the first step on its topic.

    Raises
    ------
    OutputError
        Shapes that disagree, NaN/inf, a frame tree that is not one tree rooted at
        ``root_frame``, or rotation blocks that are not rotations.
    """

    times: np.ndarray
    root_frame: str
    frame_names: Sequence[str]
    frame_parents: Sequence[str]
    T_parent_child: np.ndarray
    joint_names: Sequence[str] = ()
    q: np.ndarray | None = None
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    effort: np.ndarray | None = None
    scene: Scene | None = None
    state: Sequence[Mapping[str, Any]] | None = None
    state_schema: Mapping[str, Any] | None = None
    epoch_ns: int = 0
    metadata: Mapping[str, str] = field(default_factory=dict)
    robot_description: str | None = None
    point_clouds: Mapping[str, Points] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = _as_float_array(self.times, "times")
        _check_shape(t, (None,), "times")
        m = t.shape[0]
        if m == 0:
            raise OutputError("times: expected at least one step, got none")
        if (t < 0).any():
            raise OutputError(f"times: expected t >= 0, got {t.min()!r}")
        if (np.diff(t) < 0).any():
            i = int(np.flatnonzero(np.diff(t) < 0)[0])
            raise OutputError(f"times: expected non-decreasing times, got {t[i]!r} then "
                              f"{t[i + 1]!r} at step {i + 1}")
        object.__setattr__(self, "times", t)
        names, parents = list(self.frame_names), list(self.frame_parents)
        object.__setattr__(self, "frame_names", names)
        object.__setattr__(self, "frame_parents", parents)
        _check_tree(self.root_frame, names, parents)
        T = _as_float_array(self.T_parent_child, "T_parent_child")
        _check_shape(T, (m, len(names), 4, 4), "T_parent_child")
        _check_rotations(T[..., :3, :3], lambda i, j: f"T_parent_child[{i}, {j}] (frame "
                                                      f"{names[j]!r})")
        object.__setattr__(self, "T_parent_child", T)

        joints = list(self.joint_names)
        object.__setattr__(self, "joint_names", joints)
        if len(set(joints)) != len(joints) or not all(joints):
            raise OutputError(f"joint_names: expected unique non-empty names, got {joints}")
        for key in ("q", "qd", "qdd", "effort"):
            val = getattr(self, key)
            if val is None:
                continue
            a = _as_float_array(val, key)
            _check_shape(a, (m, len(joints)), key)
            object.__setattr__(self, key, a)
        if joints and self.q is None:
            raise OutputError("q: expected joint positions for the named joints, got None")
        if self.state is not None and len(self.state) != m:
            raise OutputError(f"state: expected {m} per-step entries, got {len(self.state)}")
        if self.state is not None and any("timestamp" in s for s in self.state):
            raise OutputError("state: 'timestamp' is reserved (added by the writer)")
        if isinstance(self.epoch_ns, bool) or not isinstance(self.epoch_ns, (int, np.integer)):
            raise OutputError(f"epoch_ns: expected an integer, got {self.epoch_ns!r}")
        if self.epoch_ns < 0:
            raise OutputError(f"epoch_ns: expected >= 0, got {self.epoch_ns}")
        known = {self.root_frame, *names}
        for topic, pc in self.point_clouds.items():
            p = _as_float_array(pc.points, f"point_clouds[{topic!r}].points")
            _check_shape(p, (None, 3), f"point_clouds[{topic!r}].points")
            if pc.frame_id not in known:
                raise OutputError(f"point_clouds[{topic!r}].frame_id: expected a frame of the "
                                  f"log, got {pc.frame_id!r}")
            for k, v in pc.fields.items():
                a = _as_float_array(v, f"point_clouds[{topic!r}].fields[{k!r}]")
                _check_shape(a, (p.shape[0],), f"point_clouds[{topic!r}].fields[{k!r}]")
        if self.robot_description is not None and not (
                isinstance(self.robot_description, str) and self.robot_description.strip()):
            raise OutputError("robot_description: expected URDF text, got "
                              f"{self.robot_description!r:.40}")

    @property
    def log_times_ns(self) -> np.ndarray:
        """Log time of each step [ns], int64, shape (m,)."""
        return np.rint(self.times * NS_PER_S).astype(np.int64) + int(self.epoch_ns)


def _check_tree(root: str, names: list[str], parents: list[str]) -> None:
    if not isinstance(root, str) or not root:
        raise OutputError(f"root_frame: expected a non-empty name, got {root!r}")
    if len(names) != len(parents):
        raise OutputError(f"frame_parents: expected {len(names)} parents (one per frame), "
                          f"got {len(parents)}")
    if len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names):
        raise OutputError(f"frame_names: expected unique non-empty names, got {names}")
    if not names:
        raise OutputError("frame_names: expected at least one frame below the root, got none")
    if root in names:
        raise OutputError(f"frame_names: the root frame {root!r} cannot have a parent")
    known = set(names) | {root}
    parent_of = dict(zip(names, parents, strict=False))
    for name, parent in parent_of.items():
        if parent not in known:
            raise OutputError(f"frame_parents: frame {name!r} has unknown parent {parent!r}; "
                              f"available frames: {sorted(known)}")
    for name in names:
        cur, seen = name, {name}
        while cur != root:
            cur = parent_of[cur]
            if cur in seen:
                raise OutputError(f"frame_parents: cycle through frame {name!r}")
            seen.add(cur)


def _check_rotations(R: np.ndarray, what: Callable[[int, int], str]) -> None:
    """Refuse rotation blocks R (m, k, 3, 3) that are not proper rotations."""
    if R.size == 0:
        return
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2))
    bad = (err > ROTATION_TOL) | (np.linalg.det(R) <= 0.0)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise OutputError(f"{what(i, j)}: expected a rotation block, got |R^T R - I| = "
                          f"{err[i, j]:.3g}, det = {np.linalg.det(R[i, j]):.3g}")


# ---------------------------------------------------------------------------------------------
# Helpers for callers: world poses and a default stick drawing of the frame tree.
# ---------------------------------------------------------------------------------------------


def poses_in_root(
    root_frame: str,
    frame_names: Sequence[str],
    frame_parents: Sequence[str],
    T_parent_child: np.ndarray,
) -> np.ndarray:
    """Chain parent->child poses into poses in the root frame.

    ``T_root_c = T_root_p @ T_p_c`` for every frame c with parent p.

    Parameters
    ----------
    root_frame, frame_names, frame_parents
        The frame tree, as in :class:`MotionLog`.
    T_parent_child : array, shape (m, k, 4, 4)
        Pose of each frame in its parent.

    Returns
    -------
    array, shape (m, k, 4, 4)
        ``T_root_frame`` for every frame, in ``frame_names`` order.
    """
    names, parents = list(frame_names), list(frame_parents)
    _check_tree(root_frame, names, parents)
    T = np.asarray(T_parent_child, dtype=np.float64)
    index = {n: j for j, n in enumerate(names)}
    out = np.empty_like(T)
    done = np.zeros(len(names), dtype=bool)

    def resolve(j: int) -> None:
        p = parents[j]
        if p == root_frame:
            out[:, j] = T[:, j]
        else:
            pj = index[p]
            if not done[pj]:
                resolve(pj)
            out[:, j] = out[:, pj] @ T[:, j]
        done[j] = True

    for j in range(len(names)):
        if not done[j]:
            resolve(j)
    return out


def skeleton_scene(
    root_frame: str,
    frame_names: Sequence[str],
    frame_parents: Sequence[str],
    T_parent_child: np.ndarray,
    *,
    radius: float = 0.01,
    thickness: float = 0.005,
) -> Scene:
    """A stick drawing of the frame tree: a segment from each parent origin to each child origin
    and a sphere at every frame origin.

    Parameters
    ----------
    root_frame, frame_names, frame_parents, T_parent_child
        The frame tree and poses, as in :class:`MotionLog`; ``T_parent_child`` (m, k, 4, 4).
    radius : float
        Sphere radius [m].
    thickness : float
        Segment width [m].

    Returns
    -------
    Scene
        One ``Lines`` (kind ``"list"``, shape (m, 2k, 3)) and one ``Spheres`` (m, k + 1, 3).
    """
    T_root = poses_in_root(root_frame, frame_names, frame_parents, T_parent_child)
    m = T_root.shape[0]
    p_child = T_root[:, :, :3, 3]
    p_all = np.concatenate([np.zeros((m, 1, 3)), p_child], axis=1)  # row 0 = root origin
    parent_row = np.array(
        [0 if p == root_frame else 1 + list(frame_names).index(p) for p in frame_parents],
        dtype=np.intp,
    )
    seg = np.stack([p_all[:, parent_row], p_child], axis=2).reshape(m, -1, 3)
    return Scene(
        lines=(Lines(seg, kind="list", thickness=thickness),) if len(frame_names) else (),
        spheres=(Spheres(p_all, radius=radius),),
    )

"""MCAP logs for Foxglove: frame transforms, a drawn scene, joint states and per-step state.

Channels (DESIGN.md, "What every run produces"):

==================  =========================  ====================================================
topic               schema (encoding)          content, one message per time step
==================  =========================  ====================================================
``/tf``             foxglove.FrameTransforms   one FrameTransform per frame: parent -> child pose
``/scene``          foxglove.SceneUpdate       one SceneEntity in the root frame: lines, spheres,
                                               boxes, text labels
``/joint_states``   foxglove.JointStates       name, position, velocity, acceleration, effort
``/mechkin/state``  JSON (JSON schema)         ``{"timestamp": {"sec", "nsec"}, **state[i]}``
==================  =========================  ====================================================

Times are simulated time: ``log_time = publish_time = round(t * 1e9) + epoch_ns`` and every
message's ``timestamp`` field holds the same instant. Chunks are zstd-compressed; chunk and
message indexes, statistics and summary offsets are written, so Foxglove opens the file by
seeking. The file is written to a temp name and renamed (:func:`mechkin.io.atomic.atomic_path`).

Message objects are built once per channel and updated in place at each step (about three times
faster than building new ones), so ~1000 steps of ~40 frames write in a fraction of a second.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.writer import CompressionType, IndexType, Writer
from mcap_protobuf.schema import register_schema

from mechkin import __version__
from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_path
from mechkin.io.summary import jsonable
from mechkin.io.topics import TOPIC_JOINTS, TOPIC_SCENE, TOPIC_STATE, TOPIC_TF
from mechkin.spatial.rotations import quat_from_matrix

__all__ = [
    "TOPIC_JOINTS",
    "TOPIC_SCENE",
    "TOPIC_STATE",
    "TOPIC_TF",
    "Box",
    "Label",
    "Lines",
    "MotionLog",
    "Scene",
    "Spheres",
    "poses_in_root",
    "skeleton_scene",
    "write_mcap",
]

log = logging.getLogger(__name__)

RGBA = tuple[float, float, float, float]
NS_PER_S = 1_000_000_000
ROTATION_TOL = 1e-6
CHUNK_SIZE = 1 << 20
_LINE_TYPES = {
    "strip": LinePrimitive.LINE_STRIP,
    "loop": LinePrimitive.LINE_LOOP,
    "list": LinePrimitive.LINE_LIST,
}


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


# ---------------------------------------------------------------------------------------------
# Channel writers: one message template per channel, updated in place at every step.
# ---------------------------------------------------------------------------------------------


def _positive(x: float, what: str) -> float:
    v = float(x)
    if not (np.isfinite(v) and v > 0.0):
        raise OutputError(f"{what}: expected a positive size [m], got {x!r}")
    return v


def _set_stamp(stamp: Any, ns: int) -> None:
    stamp.seconds, stamp.nanos = divmod(ns, NS_PER_S)


def _set_color(color: Any, rgba: Sequence[float], what: str) -> None:
    c = _as_float_array(rgba, what)
    _check_shape(c, (4,), what)
    if ((c < 0) | (c > 1)).any():
        raise OutputError(f"{what}: expected components in [0, 1], got {c.tolist()}")
    color.r, color.g, color.b, color.a = c.tolist()


def _xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (x, y, z, w) of rotation matrices (..., 3, 3) -> (..., 4)."""
    e = quat_from_matrix(R)
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    return np.concatenate([e[..., 1:], e[..., :1]], axis=-1)


class _TfChannel:
    def __init__(self, lg: MotionLog) -> None:
        self.msg = FrameTransforms()
        self.transforms = []
        for name, parent in zip(lg.frame_names, lg.frame_parents, strict=False):
            tr = self.msg.transforms.add()
            tr.parent_frame_id, tr.child_frame_id = parent, name
            self.transforms.append(tr)
        self.p = lg.T_parent_child[..., :3, 3]
        self.quat = _xyzw(lg.T_parent_child[..., :3, :3])

    def step(self, i: int, ns: int) -> bytes:
        for tr, p, e in zip(self.transforms, self.p[i].tolist(), self.quat[i].tolist(),
                            strict=False):
            _set_stamp(tr.timestamp, ns)
            v = tr.translation
            v.x, v.y, v.z = p
            r = tr.rotation
            r.x, r.y, r.z, r.w = e
        return self.msg.SerializeToString()


class _SceneChannel:
    def __init__(self, lg: MotionLog, scene: Scene) -> None:
        m = lg.times.shape[0]
        self.msg = SceneUpdate()
        ent = self.entity = self.msg.entities.add()
        ent.frame_id, ent.id, ent.frame_locked = lg.root_frame, scene.entity_id, False
        # per-step setters; static items are set once here and never again
        self.updates: list[Callable[[int], None]] = []
        for a, ln in enumerate(scene.lines):
            what = f"scene.lines[{a}]"
            if ln.kind not in _LINE_TYPES:
                raise OutputError(f"{what}.kind: expected one of {sorted(_LINE_TYPES)}, "
                                  f"got {ln.kind!r}")
            pts = _as_float_array(ln.points, f"{what}.points")
            pts = _per_step(pts, m, (None, 3), f"{what}.points")
            if ln.kind == "list" and pts.shape[1] % 2:
                raise OutputError(f"{what}.points: expected an even number of points for a "
                                  f"line list, got {pts.shape[1]}")
            prim = ent.lines.add()
            prim.type = _LINE_TYPES[ln.kind]
            prim.pose.orientation.w = 1.0
            prim.thickness = _positive(ln.thickness, f"{what}.thickness")
            prim.scale_invariant = False
            _set_color(prim.color, ln.rgba, f"{what}.rgba")
            points = [prim.points.add() for _ in range(pts.shape[1])]
            self._track(points, pts, _set_xyz_list)
        for a, sp in enumerate(scene.spheres):
            what = f"scene.spheres[{a}]"
            c = _per_step(_as_float_array(sp.centers, f"{what}.centers"), m, (None, 3),
                          f"{what}.centers")
            d = 2.0 * _positive(sp.radius, f"{what}.radius")
            positions = []
            for _ in range(c.shape[1]):
                prim = ent.spheres.add()
                prim.pose.orientation.w = 1.0
                prim.size.x, prim.size.y, prim.size.z = d, d, d
                _set_color(prim.color, sp.rgba, f"{what}.rgba")
                positions.append(prim.pose.position)
            self._track(positions, c, _set_xyz_list)
        for a, bx in enumerate(scene.boxes):
            what = f"scene.boxes[{a}]"
            T = _per_step(_as_float_array(bx.T, f"{what}.T"), m, (4, 4), f"{what}.T")
            _check_rotations(T[:, None, :3, :3], lambda i, _, w=what: f"{w}.T[{i}]")
            size = _as_float_array(bx.size, f"{what}.size")
            _check_shape(size, (3,), f"{what}.size")
            prim = ent.cubes.add()
            prim.size.x, prim.size.y, prim.size.z = (
                _positive(v, f"{what}.size[{n}]") for n, v in enumerate(size.tolist())
            )
            _set_color(prim.color, bx.rgba, f"{what}.rgba")
            pose = np.concatenate([T[:, :3, 3], _xyzw(T[:, :3, :3])], axis=-1)
            self._track(prim.pose, pose, _set_pose)
        for a, lb in enumerate(scene.labels):
            what = f"scene.labels[{a}]"
            pos = _per_step(_as_float_array(lb.position, f"{what}.position"), m, (3,),
                            f"{what}.position")
            prim = ent.texts.add()
            prim.pose.orientation.w = 1.0
            prim.billboard, prim.scale_invariant = True, False
            prim.font_size = _positive(lb.font_size, f"{what}.font_size")
            _set_color(prim.color, lb.rgba, f"{what}.rgba")
            self._track(prim.pose.position, pos, _set_xyz)
            if isinstance(lb.text, str):
                prim.text = lb.text
            else:
                texts = [str(s) for s in lb.text]
                if len(texts) != m:
                    raise OutputError(f"{what}.text: expected a str or {m} str, got {len(texts)}")
                self.updates.append(lambda i, p=prim, ts=texts: setattr(p, "text", ts[i]))

    def _track(self, target: Any, values: np.ndarray, setter: Callable[[Any, Any], None]) -> None:
        if values.strides[0] == 0:  # broadcast static item
            setter(target, values[0].tolist())
        else:
            self.updates.append(lambda i, t=target, v=values, s=setter: s(t, v[i].tolist()))

    def step(self, i: int, ns: int) -> bytes:
        _set_stamp(self.entity.timestamp, ns)
        for update in self.updates:
            update(i)
        return self.msg.SerializeToString()


def _set_xyz(target: Any, xyz: list[float]) -> None:
    target.x, target.y, target.z = xyz


def _set_xyz_list(targets: list[Any], rows: list[list[float]]) -> None:
    for t, (x, y, z) in zip(targets, rows, strict=False):
        t.x, t.y, t.z = x, y, z


def _set_pose(pose: Any, row: list[float]) -> None:
    p, o = pose.position, pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = row


class _JointChannel:
    def __init__(self, lg: MotionLog) -> None:
        self.msg = JointStates()
        self.joints = []
        for name in lg.joint_names:
            j = self.msg.joints.add()
            j.name = name
            self.joints.append(j)
        self.fields = [
            (name, arr)
            for name, arr in zip(
                ("position", "velocity", "acceleration", "effort"),
                (lg.q, lg.qd, lg.qdd, lg.effort), strict=False,
            )
            if arr is not None
        ]

    def step(self, i: int, ns: int) -> bytes:
        _set_stamp(self.msg.timestamp, ns)
        for name, arr in self.fields:
            for j, v in zip(self.joints, arr[i].tolist(), strict=False):
                setattr(j, name, v)
        return self.msg.SerializeToString()


def _json_type(v: Any) -> str:
    if isinstance(v, bool):
        return "boolean"
    if isinstance(v, int):
        return "integer"
    if isinstance(v, float):
        return "number"
    if isinstance(v, str):
        return "string"
    if isinstance(v, list):
        return "array"
    return "object"


def _infer_schema(values: list[Any]) -> dict[str, Any]:
    """JSON schema that accepts every value in ``values`` (all of them JSON-able already)."""
    present = [v for v in values if v is not None]
    if not present:
        return {"type": "null"}
    kinds = list(dict.fromkeys(_json_type(v) for v in present))
    if set(kinds) == {"integer", "number"}:
        kinds = ["number"]
    schema: dict[str, Any] = {"type": kinds[0] if len(kinds) == 1 else kinds}
    if kinds == ["object"]:
        keys = list(dict.fromkeys(k for v in present for k in v))
        schema["properties"] = {k: _infer_schema([v.get(k) for v in present]) for k in keys}
    elif kinds == ["array"]:
        schema["items"] = _infer_schema([x for v in present for x in v])
    if len(present) < len(values):
        t = schema["type"]
        schema["type"] = (t if isinstance(t, list) else [t]) + ["null"]
    return schema


_STAMP_SCHEMA = {
    "type": "object",
    "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
}


class _StateChannel:
    def __init__(self, lg: MotionLog) -> None:
        self.values = [jsonable(dict(s), f"state[{i}]") for i, s in enumerate(lg.state or ())]
        if lg.state_schema is not None:
            schema = dict(jsonable(lg.state_schema, "state_schema"))
        else:
            schema = _infer_schema(self.values)
            schema["title"] = "mechkin.State"
        props = {"timestamp": _STAMP_SCHEMA, **schema.get("properties", {})}
        self.schema = {**schema, "type": "object", "properties": props}

    def step(self, i: int, ns: int) -> bytes:
        sec, nsec = divmod(ns, NS_PER_S)
        doc = {"timestamp": {"sec": sec, "nsec": nsec}, **self.values[i]}
        return json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8")


# ---------------------------------------------------------------------------------------------
# The writer.
# ---------------------------------------------------------------------------------------------


def write_mcap(path: str | os.PathLike[str], lg: MotionLog, *, fsync: bool = True) -> Path:
    """Write ``lg`` as an MCAP file for Foxglove, atomically.

    Parameters
    ----------
    path : path-like
        Output file (``.mcap``); replaced only when the complete file is written.
    lg : MotionLog
        The log; see the module docstring for the channels.
    fsync : bool
        Flush the file to disk before the rename.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        Bad scene items (shapes, NaN, colours), NaN in ``state``, or an I/O failure.

    Examples
    --------
    >>> lg = MotionLog(times=t, root_frame="world", frame_names=["link1"],  # doctest: +SKIP
    ...                frame_parents=["world"], T_parent_child=T, joint_names=["q1"], q=q)
    >>> write_mcap(out / "motion.mcap", lg)                                 # doctest: +SKIP
    """
    scene = lg.scene
    if scene is None:
        scene = skeleton_scene(lg.root_frame, lg.frame_names, lg.frame_parents, lg.T_parent_child)
    # Build (and so validate) every channel before a byte is written.
    channels: list[tuple[str, Any]] = [(TOPIC_TF, _TfChannel(lg)),
                                       (TOPIC_SCENE, _SceneChannel(lg, scene))]
    if lg.joint_names:
        channels.append((TOPIC_JOINTS, _JointChannel(lg)))
    if lg.state is not None:
        channels.append((TOPIC_STATE, _StateChannel(lg)))
    log_ns = lg.log_times_ns.tolist()

    final = Path(path)
    with atomic_path(final, fsync=fsync) as tmp, open(tmp, "wb") as f:
        writer = Writer(
            f,
            chunk_size=CHUNK_SIZE,
            compression=CompressionType.ZSTD,
            index_types=IndexType.ALL,
            use_chunking=True,
            use_statistics=True,
            use_summary_offsets=True,
        )
        writer.start(profile="", library=f"mechkin/{__version__}")
        ids: list[int] = []
        for topic, ch in channels:
            if isinstance(ch, _StateChannel):
                sid = writer.register_schema(
                    name="mechkin.State",
                    encoding="jsonschema",
                    data=json.dumps(ch.schema).encode("utf-8"),
                )
                ids.append(writer.register_channel(topic, "json", sid))
            else:
                sid = register_schema(writer, type(ch.msg))
                ids.append(writer.register_channel(topic, "protobuf", sid))
        if lg.metadata:
            writer.add_metadata("mechkin", {str(k): str(v) for k, v in lg.metadata.items()})
        for i, ns in enumerate(log_ns):
            for cid, (_, ch) in zip(ids, channels, strict=False):
                writer.add_message(cid, log_time=ns, data=ch.step(i, ns), publish_time=ns,
                                   sequence=i)
        writer.finish()
    log.info("wrote %s (%d steps, %d channels)", final, len(log_ns), len(channels))
    return final

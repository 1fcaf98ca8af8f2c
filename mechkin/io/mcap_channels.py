"""The channels of an MCAP log: one message template per channel, updated in place at every step
(about three times faster than building new messages).

==================  =========================  ====================================================
class               schema (encoding)          content, one message per time step
==================  =========================  ====================================================
``TfChannel``       foxglove.FrameTransforms   one FrameTransform per frame: parent -> child pose
``SceneChannel``    foxglove.SceneUpdate       one SceneEntity in the root frame: lines, spheres,
                                               boxes, text labels
``JointChannel``    foxglove.JointStates       name, position, velocity, acceleration, effort
``StateChannel``    JSON (JSON schema)         ``{"timestamp": {"sec", "nsec"}, **state[i]}``
==================  =========================  ====================================================

Imports: errors, io.summary, io.mcap_log, spatial.rotations.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from mechkin.errors import OutputError
from mechkin.io.mcap_log import (
    NS_PER_S,
    MotionLog,
    Points,
    Scene,
    _as_float_array,
    _check_rotations,
    _check_shape,
    _per_step,
)
from mechkin.io.summary import jsonable
from mechkin.spatial.rotations import quat_from_matrix

_LINE_TYPES = {
    "strip": LinePrimitive.LINE_STRIP,
    "loop": LinePrimitive.LINE_LOOP,
    "list": LinePrimitive.LINE_LIST,
}

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


class TfChannel:
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


class SceneChannel:
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


class JointChannel:
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


class StateChannel:
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


def point_cloud_message(pc: Points, ns: int) -> bytes:
    """``foxglove.PointCloud`` of ``pc``: float32 x, y, z and each field, packed per point."""
    pts = np.asarray(pc.points, dtype=np.float64)
    cols = [pts[:, 0], pts[:, 1], pts[:, 2]] + [np.asarray(v, dtype=np.float64)
                                                for v in pc.fields.values()]
    names = ["x", "y", "z", *pc.fields]
    msg = PointCloud()
    _set_stamp(msg.timestamp, ns)
    msg.frame_id = pc.frame_id
    msg.pose.orientation.w = 1.0
    msg.point_stride = 4 * len(names)
    for i, name in enumerate(names):
        f = msg.fields.add()
        f.name, f.offset, f.type = name, 4 * i, PackedElementField.FLOAT32
    msg.data = np.ascontiguousarray(np.stack(cols, axis=1).astype("<f4")).tobytes()
    return msg.SerializeToString()

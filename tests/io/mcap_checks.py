"""Checks of a written MCAP shared by the io tests (not a test module).

:func:`strict_check` is the strict validation Foxglove needs, after the checks of the
``check_mcap.py --strict`` tool the project was validated with: the file reads to the end with
chunk CRCs checked; a summary with statistics and chunk indexes covering every chunk; counts
per channel equal the statistics; log times non-decreasing per channel; every message decodes
(protobuf with the mcap-protobuf decoder, JSON against its channel's JSON schema); the /tf
frames form one tree (one parent per child for the whole file, one root); scene entities are in
that tree; quaternions are unit; every ``timestamp`` field equals the log time; every attachment
has a name, a media type and data, and ``robot.urdf`` equals the ``/robot_description`` text.

:func:`urdf_fk_errors` draws the picture Foxglove's URDF layer draws: the URDF of
``/robot_description`` parsed with yourdfpy, its forward kinematics at each ``/joint_states``
message (a joint's own position, or its mimic source's) against the logged ``/tf`` chained to
the root, link by link.
"""

from __future__ import annotations

import io
import json
from collections import defaultdict
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def _quat_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.seconds) * 1_000_000_000 + int(stamp.nanos)


def read_all(path: Path) -> dict[str, Any]:
    """Decoded messages by topic ([(log_time, message)]), schemas, attachments, summary."""
    factory = DecoderFactory()
    decoders: dict[int, Any] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        by_topic: dict[str, list[tuple[int, Any]]] = defaultdict(list)
        schema_of: dict[str, Any] = {}
        encoding_of: dict[str, str] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            schema_of[channel.topic] = schema
            encoding_of[channel.topic] = channel.message_encoding
            if channel.message_encoding == "json":
                doc = json.loads(message.data)
                jsonschema.validate(doc, json.loads(schema.data))
                by_topic[channel.topic].append((message.log_time, doc))
            else:
                assert channel.message_encoding == "protobuf", channel.message_encoding
                if schema.id not in decoders:
                    decoders[schema.id] = factory.decoder_for("protobuf", schema)
                by_topic[channel.topic].append((message.log_time,
                                                decoders[schema.id](message.data)))
        f.seek(0)
        attachments = {a.name: a for a in make_reader(f).iter_attachments()}
    return {"summary": summary, "msgs": dict(by_topic), "schemas": schema_of,
            "encodings": encoding_of, "attachments": attachments}


def strict_check(path: Path) -> dict[str, Any]:
    """Every check of the module docstring; returns :func:`read_all`'s result."""
    data = read_all(path)
    summary = data["summary"]
    assert summary is not None and summary.statistics is not None, "no summary / statistics"
    assert summary.chunk_indexes, "no chunk index"
    stats = summary.statistics
    assert stats.chunk_count == len(summary.chunk_indexes)
    counts = {summary.channels[c].topic: n for c, n in stats.channel_message_counts.items()}
    assert counts == {t: len(m) for t, m in data["msgs"].items()}, "counts != statistics"
    assert stats.message_count == sum(counts.values())
    assert len(summary.schemas) == len({c.schema_id for c in summary.channels.values()})

    parent_of: dict[str, str] = {}
    for topic, msgs in data["msgs"].items():
        times = [t for t, _ in msgs]
        assert times == sorted(times), f"{topic}: log times decrease"
        for t, msg in msgs:
            if isinstance(msg, dict):
                if "timestamp" in msg:
                    ts = msg["timestamp"]
                    assert ts["sec"] * 1_000_000_000 + ts["nsec"] == t, topic
                continue
            if hasattr(msg, "transforms"):
                for tr in msg.transforms:
                    assert tr.parent_frame_id and tr.child_frame_id
                    assert tr.parent_frame_id != tr.child_frame_id
                    assert parent_of.setdefault(tr.child_frame_id, tr.parent_frame_id) == \
                        tr.parent_frame_id, f"{tr.child_frame_id}: two parents"
                    r = tr.rotation
                    assert abs(r.x**2 + r.y**2 + r.z**2 + r.w**2 - 1.0) < 1e-9
                    assert _stamp_ns(tr.timestamp) == t
            elif hasattr(msg, "entities"):
                for e in msg.entities:
                    assert _stamp_ns(e.timestamp) == t
            elif hasattr(msg, "timestamp"):
                assert _stamp_ns(msg.timestamp) == t, topic
    if parent_of:
        roots = set(parent_of.values()) - set(parent_of)
        assert len(roots) == 1, f"/tf roots {roots}"
        for child in parent_of:  # no cycles
            seen, cur = {child}, child
            while cur in parent_of:
                cur = parent_of[cur]
                assert cur not in seen, f"cycle through {child}"
                seen.add(cur)
        frames = set(parent_of) | roots
        for _, msg in data["msgs"].get("/scene", ()):
            for e in msg.entities:
                assert e.frame_id in frames, e.frame_id
    for _, msg in (m for t, ms in data["msgs"].items() for m in ms
                   if data["schemas"][t].name == "foxglove.PointCloud"):
        point_cloud_arrays(msg)  # stride and offsets consistent, every field decodes
    for name, a in data["attachments"].items():
        assert name and a.media_type and a.data, name
    if "/robot_description" in data["msgs"]:
        assert data["schemas"]["/robot_description"].name == "std_msgs/msg/String"
        (_, doc), *rest = data["msgs"]["/robot_description"]
        assert not rest
        assert data["attachments"]["robot.urdf"].data.decode() == doc["data"]
    return data


def _axis_motion(jtype: str, axis: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(m, 4, 4) motion of a joint about/along its unit ``axis`` for positions q (m,)."""
    m = len(q)
    T = np.tile(np.eye(4), (m, 1, 1))
    if jtype in ("revolute", "continuous"):
        k = axis / np.linalg.norm(axis)
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
        T[:, :3, :3] = np.eye(3) + s * K + (1 - c) * (K @ K)
    elif jtype == "prismatic":
        T[:, :3, 3] = q[:, None] * axis
    return T


def urdf_fk_errors(data: dict[str, Any]) -> tuple[float, int, int]:
    """(max |T_urdf - T_tf| over links and messages, messages compared, links compared)."""
    import yourdfpy

    urdf = data["msgs"]["/robot_description"][0][1]["data"]
    robot = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=False, load_meshes=False,
                               build_collision_scene_graph=False, load_collision_meshes=False)
    states = data["msgs"]["/joint_states"]
    names = [j.name for j in states[0][1].joints]
    q = np.array([[j.position for j in msg.joints] for _, msg in states])
    col = {n: i for i, n in enumerate(names)}
    # URDF forward kinematics, batched over the messages
    joints = {j.child: j for j in robot.robot.joints}
    roots = set(robot.link_map) - set(joints)
    assert len(roots) == 1, f"URDF roots {roots}"
    root = roots.pop()
    T_w: dict[str, np.ndarray] = {root: np.tile(np.eye(4), (len(states), 1, 1))}

    def pose(link: str) -> np.ndarray:
        if link not in T_w:
            j = joints[link]
            if j.name in col:
                qj = q[:, col[j.name]]
            elif j.mimic is not None:
                qj = j.mimic.multiplier * q[:, col[j.mimic.joint]] + j.mimic.offset
            else:
                qj = np.zeros(len(states))
            origin = j.origin if j.origin is not None else np.eye(4)
            T_w[link] = pose(j.parent) @ origin @ _axis_motion(j.type, np.asarray(j.axis), qj)
        return T_w[link]

    worlds = dict(zip([t for t, _ in data["msgs"]["/tf"]], tf_world_poses(data), strict=True))
    worst, links = 0.0, 0
    for i, (t, _) in enumerate(states):
        world = worlds[t]
        T_root = world.get(root, np.eye(4))  # the URDF root's pose in the /tf root (moving base)
        links = 0
        for link in robot.link_map:
            if link == root:
                continue
            assert link in world, f"URDF link {link} not in /tf"
            err = np.abs(T_root @ pose(link)[i] - world[link]).max()
            worst = max(worst, float(err))
            links += 1
    return worst, len(states), links


def tf_world_poses(data: dict[str, Any]) -> list[dict[str, np.ndarray]]:
    """Per /tf message: frame -> pose (4, 4) in the /tf root, chained parent to child."""
    out = []
    for _, msg in data["msgs"]["/tf"]:
        local = {tr.child_frame_id: tr for tr in msg.transforms}
        world: dict[str, np.ndarray] = {}

        def chain(f: str, local: dict = local, world: dict = world) -> np.ndarray:
            if f not in local:
                return np.eye(4)
            if f not in world:
                tr = local[f]
                T = np.eye(4)
                T[:3, :3] = _quat_matrix(tr.rotation.x, tr.rotation.y, tr.rotation.z,
                                         tr.rotation.w)
                T[:3, 3] = (tr.translation.x, tr.translation.y, tr.translation.z)
                world[f] = chain(tr.parent_frame_id) @ T
            return world[f]

        for f in local:
            chain(f)
        out.append(world)
    return out


def point_cloud_arrays(msg: Any) -> dict[str, np.ndarray]:
    """Field name -> values of a ``foxglove.PointCloud`` of float32 / float64 fields."""
    n = len(msg.data) // msg.point_stride
    assert n * msg.point_stride == len(msg.data)
    raw = np.frombuffer(msg.data, dtype=np.uint8).reshape(n, msg.point_stride)
    out = {}
    for f in msg.fields:
        width, dtype = {7: (4, "<f4"), 8: (8, "<f8")}[f.type]
        assert f.offset + width <= msg.point_stride
        out[f.name] = raw[:, f.offset:f.offset + width].copy().view(dtype)[:, 0].astype(float)
    return out


def mesh_uri_ok(uri: str) -> bool:
    """A mesh URI a URDF viewer can resolve as written: ``package://NAME/path``, an absolute
    ``file:///path`` or the ``data:`` COLLADA mechkin embeds for plates."""
    from urllib.parse import urlparse

    u = urlparse(uri)
    if u.scheme == "package":
        return bool(u.netloc) and len(u.path) > 1
    if u.scheme == "file":
        return u.netloc == "" and u.path.startswith("/")
    if u.scheme in ("http", "https"):
        return bool(u.netloc)
    return uri.startswith("data:model/vnd.collada+xml;base64,")


def check_robot_in_view(data: dict[str, Any], mcap_path: Path) -> list[str]:
    """The robot Foxglove draws: ``/robot_description`` parses with yourdfpy, every mesh URI is
    well formed (:func:`mesh_uri_ok`), and the layout beside the MCAP has one URDF layer that
    reads that topic with its joints driven by ``/joint_states``. Returns the mesh URIs."""
    import yourdfpy

    urdf = data["msgs"]["/robot_description"][0][1]["data"]
    robot = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=False, load_meshes=False,
                               build_collision_scene_graph=False, load_collision_meshes=False)
    uris = [v.geometry.mesh.filename for lk in robot.robot.links for v in lk.visuals
            if v.geometry is not None and v.geometry.mesh is not None]
    bad = [u[:80] for u in uris if not mesh_uri_ok(u)]
    assert not bad, f"malformed mesh URIs {bad}"
    assert sum(len(lk.visuals) for lk in robot.robot.links) > 0, "a URDF without visuals"
    lay = json.loads((mcap_path.parent / f"{mcap_path.stem}.layout.json").read_text())
    three_d = [c for pid, c in lay["configById"].items() if pid.startswith("3D!")]
    assert len(three_d) == 1
    layers = [c for c in three_d[0]["layers"].values() if c["layerId"] == "foxglove.Urdf"]
    assert len(layers) == 1
    assert (layers[0]["sourceType"], layers[0]["topic"]) == ("topic", "/robot_description")
    assert (layers[0]["controlMode"], layers[0]["jointStatesTopic"]) == ("jointStates",
                                                                        "/joint_states")
    return uris

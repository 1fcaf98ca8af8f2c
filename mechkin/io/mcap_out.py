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
``/robot_descr...`` std_msgs/msg/String (JSON) ``{"data": urdf}``, once at the first step, and the
                                               same URDF as the attachment ``robot.urdf``
point-cloud topics  foxglove.PointCloud        ``MotionLog.point_clouds``, once at the first step
==================  =========================  ====================================================

Times are simulated time: ``log_time = publish_time = round(t * 1e9) + epoch_ns`` and every
message's ``timestamp`` field holds the same instant. Chunks are zstd-compressed; chunk and
message indexes, statistics and summary offsets are written, so Foxglove opens the file by
seeking. The log's content is :mod:`mechkin.io.mcap_log`, its channels
:mod:`mechkin.io.mcap_channels`. The file is written to a temp name and renamed
(:func:`mechkin.io.atomic.atomic_path`).

Message objects are built once per channel and updated in place at each step (about three times
faster than building new ones), so ~1000 steps of ~40 frames write in a fraction of a second.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any

from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
from mcap.writer import CompressionType, IndexType, Writer
from mcap_protobuf.schema import register_schema

from mechkin import __version__
from mechkin.io.atomic import atomic_path
from mechkin.io.mcap_channels import (
    JointChannel,
    SceneChannel,
    StateChannel,
    TfChannel,
    point_cloud_message,
)
from mechkin.io.mcap_log import (
    NS_PER_S,
    RGBA,
    Box,
    Label,
    Lines,
    MotionLog,
    Points,
    Scene,
    Spheres,
    poses_in_root,
    skeleton_scene,
)
from mechkin.io.topics import TOPIC_JOINTS, TOPIC_ROBOT, TOPIC_SCENE, TOPIC_STATE, TOPIC_TF

__all__ = [
    "NS_PER_S",
    "RGBA",
    "TOPIC_JOINTS",
    "TOPIC_ROBOT",
    "TOPIC_SCENE",
    "TOPIC_STATE",
    "TOPIC_TF",
    "Box",
    "Label",
    "Lines",
    "MotionLog",
    "Points",
    "Scene",
    "Spheres",
    "poses_in_root",
    "skeleton_scene",
    "write_mcap",
]

log = logging.getLogger(__name__)

CHUNK_SIZE = 1 << 20
#: Schema of ``/robot_description``: the ROS message Foxglove's URDF layer subscribes to
#: (``URDF_TOPIC_SCHEMAS`` in Lichtblick's ``renderables/Urdfs.ts``), JSON-encoded.
ROBOT_SCHEMA_NAME = "std_msgs/msg/String"
ROBOT_SCHEMA = {"type": "object", "title": ROBOT_SCHEMA_NAME,
                "properties": {"data": {"type": "string", "description": "URDF XML"}},
                "required": ["data"]}
ROBOT_ATTACHMENT = "robot.urdf"

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
    channels: list[tuple[str, Any]] = [(TOPIC_TF, TfChannel(lg)),
                                       (TOPIC_SCENE, SceneChannel(lg, scene))]
    if lg.joint_names:
        channels.append((TOPIC_JOINTS, JointChannel(lg)))
    if lg.state is not None:
        channels.append((TOPIC_STATE, StateChannel(lg)))
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
            if isinstance(ch, StateChannel):
                sid = writer.register_schema(
                    name="mechkin.State",
                    encoding="jsonschema",
                    data=json.dumps(ch.schema).encode("utf-8"),
                )
                ids.append(writer.register_channel(topic, "json", sid))
            else:
                sid = register_schema(writer, type(ch.msg))
                ids.append(writer.register_channel(topic, "protobuf", sid))
        robot_id = None
        if lg.robot_description is not None:
            sid = writer.register_schema(name=ROBOT_SCHEMA_NAME, encoding="jsonschema",
                                         data=json.dumps(ROBOT_SCHEMA).encode("utf-8"))
            robot_id = writer.register_channel(TOPIC_ROBOT, "json", sid)
        cloud_ids = {}
        if lg.point_clouds:
            sid = register_schema(writer, PointCloud)
            cloud_ids = {t: writer.register_channel(t, "protobuf", sid) for t in lg.point_clouds}
        if lg.metadata:
            writer.add_metadata("mechkin", {str(k): str(v) for k, v in lg.metadata.items()})
        if robot_id is not None:
            urdf = lg.robot_description or ""
            writer.add_message(robot_id, log_time=log_ns[0], publish_time=log_ns[0], sequence=0,
                               data=json.dumps({"data": urdf}).encode("utf-8"))
            writer.add_attachment(create_time=log_ns[0], log_time=log_ns[0],
                                  name=ROBOT_ATTACHMENT, media_type="application/xml",
                                  data=urdf.encode("utf-8"))
        for topic, cid in cloud_ids.items():
            writer.add_message(cid, log_time=log_ns[0], publish_time=log_ns[0], sequence=0,
                               data=point_cloud_message(lg.point_clouds[topic], log_ns[0]))
        for i, ns in enumerate(log_ns):
            for cid, (_, ch) in zip(ids, channels, strict=False):
                writer.add_message(cid, log_time=ns, data=ch.step(i, ns), publish_time=ns,
                                   sequence=i)
        writer.finish()
    log.info("wrote %s (%d steps, %d channels)", final, len(log_ns), len(channels))
    return final

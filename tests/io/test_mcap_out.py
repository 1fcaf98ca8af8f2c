"""MCAP logs read back with the mcap reader: channels, schemas, counts, times, decoded fields."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import make_reader
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory

from mechkin.errors import OutputError
from mechkin.io.mcap_out import (
    TOPIC_JOINTS,
    TOPIC_SCENE,
    TOPIC_STATE,
    TOPIC_TF,
    Box,
    Label,
    Lines,
    MotionLog,
    Scene,
    Spheres,
    poses_in_root,
    write_mcap,
)
from mechkin.spatial.rotations import matrix_from_quat, rot_x, rot_z

M = 20
DT = 0.01
NAMES = ["base", "link1", "link2", "tool", "cam"]
PARENTS = ["world", "base", "link1", "link2", "base"]


class _JsonDecoderFactory(McapDecoderFactory):
    def decoder_for(
        self, message_encoding: str, schema: Schema | None
    ) -> Callable[[bytes], Any] | None:
        if message_encoding == "json":
            return lambda data: json.loads(data)
        return None


def _transforms(m: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(m) * DT
    k = len(NAMES)
    T = np.tile(np.eye(4), (m, k, 1, 1))
    T[:, 0, 2, 3] = 0.3
    T[:, 1, :3, :3] = rot_z(2.0 * t)
    T[:, 2, :3, :3] = rot_x(np.pi - t)  # near pi: exercises every quaternion branch
    T[:, 2, 0, 3] = 0.4
    T[:, 3, 0, 3] = 0.25 + t
    T[:, 4, :3, :3] = rot_x(np.pi)
    T[:, 4, 1, 3] = 0.1
    return t, T


def _log(**overrides: Any) -> MotionLog:
    t, T = _transforms(M)
    T_root = poses_in_root("world", NAMES, PARENTS, T)
    q = np.stack([2.0 * t, np.pi - t, 0.25 + t], axis=1)
    box_T = np.tile(np.eye(4), (M, 1, 1))
    box_T[:, 0, 3] = 0.5 + 0.1 * t
    scene = Scene(
        lines=(
            Lines(T_root[:, :4, :3, 3], rgba=(0.2, 0.4, 1.0, 1.0)),
            Lines(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]]), kind="loop"),
        ),
        spheres=(Spheres(T_root[:, :, :3, 3], radius=0.03),),
        boxes=(Box(box_T, np.array([0.1, 0.2, 0.05])),
               Box(np.eye(4), np.array([2.0, 2.0, 0.001]), rgba=(0.5, 0.5, 0.5, 0.3))),
        labels=(Label(np.array([0.0, 0.0, 1.0]), [f"phase {i % 2}" for i in range(M)]),),
    )
    state = [{"residual_m": 1e-12 * i, "phase": "swing" if i % 2 else "stance",
              "legs_m": [0.5, 0.5 + 0.01 * i], "err": None if i == 3 else 0.1}
             for i in range(M)]
    kwargs: dict[str, Any] = dict(
        times=t, root_frame="world", frame_names=NAMES, frame_parents=PARENTS, T_parent_child=T,
        joint_names=["q1", "q2", "d3"], q=q, qd=np.gradient(q, t, axis=0),
        effort=np.full((M, 3), 0.5), scene=scene, state=state, metadata={"scenario": "test"},
    )
    kwargs.update(overrides)
    return MotionLog(**kwargs)


def _read(path: Path) -> tuple[Any, dict[str, list[tuple[Any, Any, Any]]]]:
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(), _JsonDecoderFactory()])
        summary = reader.get_summary()
        by_topic: dict[str, list[tuple[Any, Any, Any]]] = {}
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            by_topic.setdefault(channel.topic, []).append((schema, message, decoded))
    return summary, by_topic


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, MotionLog, Any, dict]:
    path = tmp_path_factory.mktemp("mcap") / "motion.mcap"
    lg = _log()
    assert write_mcap(path, lg) == path
    summary, by_topic = _read(path)
    return path, lg, summary, by_topic


def test_channels_schemas_counts_and_time_range(written: tuple) -> None:
    path, lg, summary, by_topic = written
    topics = {c.topic: c for c in summary.channels.values()}
    assert list(topics) == [TOPIC_TF, TOPIC_SCENE, TOPIC_JOINTS, TOPIC_STATE]
    schema_of = {t: summary.schemas[c.schema_id] for t, c in topics.items()}
    assert schema_of[TOPIC_TF].name == "foxglove.FrameTransforms"
    assert schema_of[TOPIC_SCENE].name == "foxglove.SceneUpdate"
    assert schema_of[TOPIC_JOINTS].name == "foxglove.JointStates"
    assert schema_of[TOPIC_STATE].encoding == "jsonschema"
    assert topics[TOPIC_STATE].message_encoding == "json"
    stats = summary.statistics
    assert stats.message_count == 4 * M
    assert all(stats.channel_message_counts[c.id] == M for c in topics.values())
    assert stats.message_start_time == 0
    assert stats.message_end_time == round((M - 1) * DT * 1e9)
    assert summary.chunk_indexes and all(
        ci.compression == "zstd" for ci in summary.chunk_indexes)
    for topic, msgs in by_topic.items():
        log_times = [m.log_time for _, m, _ in msgs]
        assert log_times == lg.log_times_ns.tolist(), topic
        assert [m.publish_time for _, m, _ in msgs] == log_times


def test_metadata(written: tuple) -> None:
    path = written[0]
    with open(path, "rb") as f:
        meta = list(make_reader(f).iter_metadata())
    assert [(m.name, m.metadata) for m in meta] == [("mechkin", {"scenario": "test"})]


def test_tf_decodes_to_the_input_poses(written: tuple) -> None:
    _, lg, _, by_topic = written
    parent_of: dict[str, str] = {}
    for i, (_, message, tf) in enumerate(by_topic[TOPIC_TF]):
        assert len(tf.transforms) == len(NAMES)
        for j, tr in enumerate(tf.transforms):
            assert parent_of.setdefault(tr.child_frame_id, tr.parent_frame_id) == PARENTS[j]
            assert tr.child_frame_id == NAMES[j]
            assert tr.timestamp.seconds * 10**9 + tr.timestamp.nanos == message.log_time
            xyzw = np.array([tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w])
            assert abs(np.linalg.norm(xyzw) - 1.0) < 1e-12
            R = matrix_from_quat(np.r_[xyzw[3], xyzw[:3]])
            np.testing.assert_allclose(R, lg.T_parent_child[i, j, :3, :3], atol=1e-12)
            p = [tr.translation.x, tr.translation.y, tr.translation.z]
            np.testing.assert_array_equal(p, lg.T_parent_child[i, j, :3, 3])
    roots = set(parent_of.values()) - set(parent_of)
    assert roots == {"world"}


def test_scene_decodes(written: tuple) -> None:
    _, lg, _, by_topic = written
    T_root = poses_in_root("world", NAMES, PARENTS, lg.T_parent_child)
    for i, (_, message, upd) in enumerate(by_topic[TOPIC_SCENE]):
        (ent,) = upd.entities
        assert ent.frame_id == "world" and ent.id == "mechanism"
        assert ent.timestamp.seconds * 10**9 + ent.timestamp.nanos == message.log_time
        assert [len(ln.points) for ln in ent.lines] == [4, 3]
        assert ent.lines[1].type == 1  # LINE_LOOP
        pts = np.array([[p.x, p.y, p.z] for p in ent.lines[0].points])
        np.testing.assert_array_equal(pts, T_root[i, [0, 1, 2, 3], :3, 3])
        assert len(ent.spheres) == len(NAMES)
        assert ent.spheres[2].size.x == pytest.approx(0.06)
        c = ent.spheres[4].pose.position
        np.testing.assert_array_equal([c.x, c.y, c.z], T_root[i, 4, :3, 3])
        assert len(ent.cubes) == 2
        assert ent.cubes[0].pose.position.x == pytest.approx(0.5 + 0.1 * i * DT)
        assert ent.cubes[0].pose.orientation.w == pytest.approx(1.0)
        assert ent.cubes[1].color.a == pytest.approx(0.3)
        assert ent.texts[0].text == f"phase {i % 2}"


def test_joint_states_decode(written: tuple) -> None:
    _, lg, _, by_topic = written
    for i, (_, message, js) in enumerate(by_topic[TOPIC_JOINTS]):
        assert js.timestamp.seconds * 10**9 + js.timestamp.nanos == message.log_time
        assert [j.name for j in js.joints] == ["q1", "q2", "d3"]
        np.testing.assert_array_equal([j.position for j in js.joints], lg.q[i])
        np.testing.assert_array_equal([j.velocity for j in js.joints], lg.qd[i])
        np.testing.assert_array_equal([j.effort for j in js.joints], lg.effort[i])
        assert not js.joints[0].HasField("acceleration")


def test_state_json_and_schema(written: tuple) -> None:
    _, lg, _, by_topic = written
    for i, (_schema, message, st) in enumerate(by_topic[TOPIC_STATE]):
        assert st["timestamp"]["sec"] * 10**9 + st["timestamp"]["nsec"] == message.log_time
        assert st["phase"] == ("swing" if i % 2 else "stance")
        assert st["legs_m"] == [0.5, 0.5 + 0.01 * i]
    js = json.loads(by_topic[TOPIC_STATE][-1][0].data)
    assert js["type"] == "object"
    assert list(js["properties"]) == ["timestamp", "residual_m", "phase", "legs_m", "err"]
    assert js["properties"]["legs_m"] == {"type": "array", "items": {"type": "number"}}
    assert js["properties"]["err"]["type"] == ["number", "null"]


def test_default_scene_and_epoch(tmp_path: Path) -> None:
    t, T = _transforms(5)
    lg = MotionLog(times=t, root_frame="world", frame_names=NAMES, frame_parents=PARENTS,
                   T_parent_child=T, epoch_ns=10**9)
    path = write_mcap(tmp_path / "skel.mcap", lg)
    summary, by_topic = _read(path)
    assert sorted(c.topic for c in summary.channels.values()) == [TOPIC_SCENE, TOPIC_TF]
    assert summary.statistics.message_start_time == 10**9
    assert summary.statistics.message_end_time == 10**9 + round(4 * DT * 1e9)
    ent = by_topic[TOPIC_SCENE][-1][2].entities[0]
    assert ent.frame_id == "world"
    assert len(ent.lines[0].points) == 2 * len(NAMES) and len(ent.spheres) == len(NAMES) + 1
    T_root = poses_in_root("world", NAMES, PARENTS, T)
    tool = ent.lines[0].points[2 * 3 + 1]
    np.testing.assert_allclose([tool.x, tool.y, tool.z], T_root[-1, 3, :3, 3], atol=1e-15)


def test_poses_in_root_chains_parents() -> None:
    _, T = _transforms(3)
    T_root = poses_in_root("world", NAMES, PARENTS, T)
    np.testing.assert_allclose(T_root[:, 3], T[:, 0] @ T[:, 1] @ T[:, 2] @ T[:, 3])
    np.testing.assert_allclose(T_root[:, 4], T[:, 0] @ T[:, 4])


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"frame_parents": ["world", "base", "link1", "link2", "nowhere"]}, "unknown parent"),
        ({"frame_parents": ["cam", "base", "link1", "link2", "base"]}, "cycle"),
        ({"frame_names": ["world", "link1", "link2", "tool", "cam"]}, "root frame"),
        ({"frame_names": ["base", "base", "link2", "tool", "cam"]}, "unique"),
        ({"times": np.arange(M)[::-1] * DT}, "non-decreasing"),
        ({"q": np.zeros((M, 2))}, r"q: expected shape \(20, 3\)"),
        ({"state": [{"x": float("nan")}] * M}, r"state\[0\]\.x: expected a finite number"),
        ({"state": [{"timestamp": 1}] * M}, "reserved"),
        ({"scene": Scene(lines=(Lines(np.zeros((M, 3, 3)), kind="list"),))}, "even number"),
        ({"scene": Scene(spheres=(Spheres(np.zeros((M + 1, 2, 3))),))}, r"centers: expected"),
        ({"scene": Scene(boxes=(Box(np.eye(4), np.ones(3), rgba=(2, 0, 0, 1)),))}, r"\[0, 1\]"),
        ({"scene": Scene(boxes=(Box(2 * np.eye(4), np.ones(3)),))},
         r"scene\.boxes\[0\]\.T\[0\]: expected a rotation"),
        ({"scene": Scene(spheres=(Spheres(np.zeros((2, 3)), radius=-1.0),))}, "positive size"),
        ({"frame_names": [], "frame_parents": [], "T_parent_child": np.zeros((M, 0, 4, 4))},
         "at least one frame"),
    ],
)
def test_bad_logs_raise_and_write_nothing(tmp_path: Path, change: dict, match: str) -> None:
    with pytest.raises(OutputError, match=match):
        write_mcap(tmp_path / "bad.mcap", _log(**change))
    assert list(tmp_path.iterdir()) == []


def test_bad_rotation_and_nan_pose() -> None:
    _, T = _transforms(M)
    T_bad = T.copy()
    T_bad[4, 2, :3, :3] *= 1.01
    with pytest.raises(OutputError, match=r"T_parent_child\[4, 2\] \(frame 'link2'\)"):
        _log(T_parent_child=T_bad)
    T_bad = T.copy()
    T_bad[1, 0, 0, 3] = np.nan
    with pytest.raises(OutputError, match=r"T_parent_child\[1, 0, 0, 3\]"):
        _log(T_parent_child=T_bad)


def test_robot_description_and_point_cloud_pass_the_strict_check(tmp_path: Path) -> None:
    """/robot_description (std_msgs/msg/String as JSON) once, the same text as the attachment
    robot.urdf, and a static point cloud once; every channel passes the strict check."""
    from mechkin.io.mcap_out import Points
    from tests.io.mcap_checks import point_cloud_arrays, strict_check

    urdf = '<?xml version="1.0"?>\n<robot name="r"><link name="world"/></robot>\n'
    pts = np.array([[0.0, 0.1, 0.2], [1.0, 1.5, -2.0]])
    path = write_mcap(tmp_path / "r.mcap", _log(
        robot_description=urdf,
        point_clouds={"/cloud": Points("base", pts, {"isotropy": np.array([0.25, 1.0])})}))
    data = strict_check(path)
    assert data["msgs"]["/robot_description"] == [(0, {"data": urdf})]
    assert data["attachments"]["robot.urdf"].media_type == "application/xml"
    (t, msg), = data["msgs"]["/cloud"]
    assert t == 0 and msg.frame_id == "base"
    cols = point_cloud_arrays(msg)
    np.testing.assert_allclose(np.stack([cols["x"], cols["y"], cols["z"]], 1), pts, atol=1e-7)
    np.testing.assert_allclose(cols["isotropy"], [0.25, 1.0])
    with pytest.raises(OutputError, match="frame_id"):
        _log(point_clouds={"/c": Points("nowhere", pts)})
    with pytest.raises(OutputError, match="robot_description"):
        _log(robot_description="  ")

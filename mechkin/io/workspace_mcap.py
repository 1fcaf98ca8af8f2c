"""``workspace.mcap`` and ``workspace.layout.json`` of task-space and joint-sweep workspace runs.

One step at ``t = 0``: the mechanism at home (``/tf`` of its URDF tree, ``/joint_states`` with
every joint, ``/robot_description``, ``/scene`` a stick drawing of the frame tree) and the map
as the point cloud ``/mechkin/workspace`` (``foxglove.PointCloud`` in the base frame): one point
per reachable sample with the fields ``isotropy`` (the normalised isotropy index where the run
has a characteristic length, else the plain one; 0..1), ``manipulability`` and
``condition_number`` where computed. The layout colours the cloud by ``isotropy`` (colour map
turbo, 0 to 1) beside the URDF layer.

lee_spherical and design runs write no MCAP: their maps are over the platform's orientation
angles (alpha, beta, gamma), not positions in space; their PNG heat maps show them.

Imports: records (types), io.mcap_out, io.foxglove_layout, io.urdf_out.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.io.foxglove_layout import layout
from mechkin.io.output_dir import OutputDir
from mechkin.records.workspace import WorkspaceOutput

TOPIC_WORKSPACE = "/mechkin/workspace"
__all__ = ["TOPIC_WORKSPACE", "workspace_cloud", "workspace_layout", "write_workspace_mcap"]


def workspace_cloud(out: WorkspaceOutput) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(positions (p, 3), fields) of the reachable samples of a task-space or joint-sweep run."""
    rec = out.record
    reach = np.asarray(rec.reachable, dtype=bool)
    pos = (np.asarray(rec.T_P, float)[:, :3, 3] if out.kind == "task_space"
           else np.asarray(rec.position, float))
    fields: dict[str, np.ndarray] = {}
    iso = rec.isotropy_normalized if rec.isotropy_normalized is not None else rec.isotropy
    if iso is not None:
        fields["isotropy"] = np.asarray(iso, float)[reach]
    for name in ("manipulability", "condition_number"):
        v = getattr(rec, name, None)
        if v is not None:
            fields[name] = np.asarray(v, float)[reach]
    keep = np.all(np.isfinite(pos[reach]), axis=1)
    for v in fields.values():
        keep &= np.isfinite(v)
    return pos[reach][keep], {k: v[keep] for k, v in fields.items()}


def write_workspace_mcap(od: OutputDir, out: WorkspaceOutput) -> bool:
    """Write ``workspace.mcap`` and its layout; False (nothing written) without a robot."""
    from mechkin.io.mcap_out import MotionLog, Points, write_mcap
    from mechkin.io.urdf_out import robot_urdf

    snap = out.robot
    if snap is None or out.kind not in ("task_space", "joint_sweep"):
        return False
    pts, fields = workspace_cloud(out)
    lg = MotionLog(
        times=np.zeros(1), root_frame=snap.root, frame_names=snap.frame_names,
        frame_parents=snap.frame_parents, T_parent_child=snap.T_parent_child,
        joint_names=snap.joint_names, q=snap.q,
        point_clouds={TOPIC_WORKSPACE: Points(snap.root, pts, fields)},
        metadata={"task": "workspace", "kind": out.kind, "title": out.title},
        robot_description=robot_urdf(snap.description),
    )
    write_mcap(od.path_for("workspace.mcap"), lg)
    od.write_json("workspace.layout.json", workspace_layout(out, "isotropy" in fields))
    return True


def workspace_layout(out: WorkspaceOutput, isotropy: bool) -> dict[str, Any]:
    """3D panel: the robot (URDF layer) and the map coloured by isotropy; joint positions."""
    snap = out.robot
    lay = layout(snap.root, snap.joint_names, [], robot=True,
                 extra_topics=[TOPIC_WORKSPACE], title=out.title or "workspace")
    cfg = lay["configById"]["3D!mechkin"]["topics"][TOPIC_WORKSPACE]
    if isotropy:
        cfg.update(minValue=0.0, maxValue=1.0)
    else:  # no isotropy computed: one colour
        cfg.update(colorMode="flat", flatColor="#3f7fe0")
        cfg.pop("colorField", None)
        cfg.pop("colorMap", None)
    return lay

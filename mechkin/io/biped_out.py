"""The files of a biped run: ``leg_right.csv``, ``leg_left.csv`` (one row per step),
``frames.csv`` (one row per frame: joint values and rates), ``biped.png`` (the biped standing
on its plane, like hwang2023 Figs. 7/8) and ``biped.mcap``
(/tf, /scene with the planes, body, legs, feet or blades and the phase, /joint_states with
position and velocity, /mechkin/state) with its Foxglove layout ``biped.layout.json`` (3D on
``world``, joint positions, each leg's forward-kinematics position error and foot angle).

Imports: records (types), io.atomic, io.mcap_out, io.foxglove_layout, io.plots (lazily).
"""

from __future__ import annotations

import numpy as np

from mechkin.io.foxglove_layout import layout, state_path
from mechkin.io.mcap_out import Box, Label, Lines, MotionLog, Scene, Spheres, write_mcap
from mechkin.io.motion_out import robot_text
from mechkin.io.output_dir import OutputDir
from mechkin.records import Report
from mechkin.records.biped import BipedRecord

SIDES = ("right", "left")


def write(od: OutputDir, report: Report, plots: bool) -> None:
    rec: BipedRecord = report.data
    outs = report.outputs
    if outs.csv:
        for s in SIDES:
            od.write_table(f"leg_{s}", rec.columns[s])
        if rec.frame_columns:
            od.write_table("frames", rec.frame_columns)
    if plots and outs.plots:
        plot_biped(od.path_for("biped.png"), rec)
    if outs.mcap:
        write_mcap(od.path_for("biped.mcap"), biped_log(rec))
        od.write_json("biped.layout.json", biped_layout(rec))


def biped_layout(rec: BipedRecord) -> dict:
    """Foxglove layout of ``biped.mcap``: 3D on ``world``, joints, the legs' key figures
    (fields of the record's state schema only, so every plotted path exists)."""
    props = (rec.state_schema or {}).get("properties", {})
    def series(field: str, what: str) -> list[tuple[str, str]]:
        return [(state_path(field.format(s=s)), f"{s} {what}") for s in SIDES
                if field.format(s=s) in props]

    return layout("world", list(rec.joint_names),
                  [("legs: FK position error [m]", series("position_error_{s}_m", "error")),
                   ("legs: foot angle beta [deg]", series("beta_{s}_deg", "beta"))],
                  robot=rec.robot is not None, title="biped")


def plot_biped(path, rec: BipedRecord) -> None:
    """``biped.png``: one 3-D panel per snapshot with the planes under it."""
    from mechkin.io.plots import Stick, plot_stick_3d

    snaps, labels = [], []
    for snap in rec.snapshots:
        pl = snap.polylines
        items = [Stick(pl["body"], color="k", linewidth=2.5, label="body"),
                 Stick(pl["leg_right"], color="C3", label="right leg"),
                 Stick(pl["leg_left"], color="C0", label="left leg")]
        for s, c in (("right", "C3"), ("left", "C0")):
            for pre in ("foot", "blade"):
                if f"{pre}_{s}" in pl:
                    items.append(Stick(pl[f"{pre}_{s}"], color=c, linewidth=1.5, marker=""))
        snaps.append(items)
        labels.append(snap.label)
    plot_stick_3d(path, snaps, rec.plot_title, labels=labels, planes=list(rec.plot_planes),
                  view=(18.0, -70.0))


def _stack_contact(polys: list[dict[str, np.ndarray]], prefix: str, side: str,
                   other: str) -> np.ndarray:
    """(m, p, 3) of the ``prefix`` outline (foot/blade); collapsed to a point where the frame
    uses the other contact (so one Lines item with a fixed vertex count serves every step)."""
    key = f"{prefix}_{side}"
    p = next((len(pl[key]) for pl in polys if key in pl), None)
    if p is None:
        return np.zeros((0,))
    out = np.empty((len(polys), p, 3))
    for i, pl in enumerate(polys):
        if key in pl:
            out[i] = pl[key]
        else:
            out[i] = pl[f"{other}_{side}"][0]
    return out


def _T(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def biped_log(rec: BipedRecord) -> MotionLog:
    """The MCAP log of the record: planes and body under ``world``, the mechanism's frames."""
    polys = rec.polylines
    n_planes = rec.T_plane.shape[1]
    plane_names = ["plane", "plane_left"][:n_planes]
    all_names = plane_names + [rec.frame_root] + list(rec.frame_names)
    all_parents = ["world"] * (n_planes + 1) + list(rec.frame_parents)
    T_all = np.concatenate([rec.T_plane, rec.T_0_G[:, None], rec.T_parent_child], axis=1)
    lines = [Lines(np.stack([p["body"] for p in polys]), rgba=(0.1, 0.1, 0.1, 1.0),
                   thickness=0.012),
             Lines(np.stack([p["leg_right"] for p in polys]), rgba=(0.85, 0.25, 0.2, 1.0),
                   thickness=0.01),
             Lines(np.stack([p["leg_left"] for p in polys]), rgba=(0.2, 0.4, 0.85, 1.0),
                   thickness=0.01)]
    for s in SIDES:
        for pre, other, rgba in (("foot", "blade", (0.4, 0.3, 0.2, 1.0)),
                                 ("blade", "foot", (0.7, 0.7, 0.75, 1.0))):
            pts = _stack_contact(polys, pre, s, other)
            if pts.size:
                lines.append(Lines(pts, rgba=rgba, thickness=0.006))
    half = rec.plane_half
    below = _T(np.eye(3), np.array([0.0, 0.0, -0.001]))
    boxes = tuple(Box(rec.T_plane[:, i] @ below, np.array([2 * half, 2 * half, 0.002]),
                      rgba=(0.4, 0.6, 0.85, 0.35)) for i in range(n_planes))
    label = Label(rec.T_0_G[:, :3, 3] + np.array([0.0, 0.0, 0.12]), list(rec.label_texts),
                  font_size=0.04)
    scene = Scene(lines=tuple(lines), spheres=(Spheres(rec.contacts, radius=0.008),),
                  boxes=boxes, labels=(label,), entity_id="biped")
    return MotionLog(
        times=np.asarray(rec.times, float), root_frame="world", frame_names=all_names,
        frame_parents=all_parents, T_parent_child=T_all, joint_names=list(rec.joint_names),
        q=rec.q, qd=rec.qd if rec.qd.shape == rec.q.shape else None, scene=scene,
        state=rec.state, state_schema=rec.state_schema,
        metadata=rec.metadata, robot_description=robot_text(rec.robot))

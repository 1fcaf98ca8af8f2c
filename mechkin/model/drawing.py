"""Geometry for stick drawings of a mechanism (kim1995 Figs. 2, 4, 6 style)."""

from __future__ import annotations

import numpy as np

from mechkin.model.kinematics import Kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.spatial.transforms import invert


def skeleton_segments(mech: Mechanism, kin: Kinematics) -> np.ndarray:
    """Segments (m, s, 2, 3) in the base frame: for every joint, parent frame origin -> joint
    axis origin -> child link origin, and every named frame hung from its link's origin."""
    m = kin.q.shape[0]
    T_f = kin.frames(mech)
    origins = T_f[..., :3, 3]  # (m, nf, 3)
    axis_o = kin.axes()[1]  # (m, n, 3) points on the joint axes
    child_o = kin.T_links[:, mech.joint_child_link][..., :3, 3]
    parent_o = origins[:, mech.joint_parent_frame]
    seg = [np.stack([parent_o, axis_o], axis=2), np.stack([axis_o, child_o], axis=2)]
    named = np.arange(mech.n_links, len(mech.frame_names))
    if named.size:
        seg.append(np.stack([kin.T_links[:, mech.frame_link[named]][..., :3, 3], origins[:, named]],
                            axis=2))
    out = np.concatenate(seg, axis=1)
    # drop segments of zero length everywhere (coincident origins)
    length = np.linalg.norm(out[:, :, 1] - out[:, :, 0], axis=-1).max(axis=0)
    return out[:, length > 1e-12] if m else out


def frame_tree(mech: Mechanism, kin: Kinematics) -> tuple[str, list[str], list[str], np.ndarray]:
    """(root, names, parents, T_parent_child (m, k, 4, 4)) of every link and named frame, for /tf.

    A link hangs from the frame its joint is placed on; a named frame from its link.
    """
    T_f = kin.frames(mech)
    nf = len(mech.frame_names)
    parents = [mech.frame_parent_frame(f) for f in range(nf)]
    idx = [f for f in range(nf) if parents[f] >= 0]
    par = [parents[f] for f in idx]
    T_pc = invert(T_f[:, par]) @ T_f[:, idx]
    return (
        mech.frame_names[0],
        [mech.frame_names[f] for f in idx],
        [mech.frame_names[p] for p in par],
        T_pc,
    )

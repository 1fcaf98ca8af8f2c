"""Time write_mcap on a synthetic log: python benchmarks/bench_mcap.py [steps] [frames] [out.mcap].

A serial chain of ``frames`` revolute frames moving for ``steps`` steps, drawn with the default
skeleton scene plus a box, a per-step label, joint states and a JSON state channel.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mechkin.io.mcap_out import Box, Label, MotionLog, Scene, skeleton_scene, write_mcap
from mechkin.spatial.rotations import rot_z


def make_log(m: int, k: int) -> MotionLog:
    """A k-frame chain (each frame rotated about z and offset 0.1 m along x) over m steps."""
    t = np.arange(m) * 0.01
    q = 0.5 * np.sin(t[:, None] * (1.0 + np.arange(k)[None, :] * 0.1))
    T = np.zeros((m, k, 4, 4))
    T[..., :3, :3] = rot_z(q)
    T[..., 0, 3] = 0.1
    T[..., 3, 3] = 1.0
    names = [f"link{j + 1}" for j in range(k)]
    parents = ["world"] + names[:-1]
    skel = skeleton_scene("world", names, parents, T)
    box_T = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
    box_T[:, 0, 3] = 0.2 * t
    scene = Scene(
        lines=skel.lines,
        spheres=skel.spheres,
        boxes=(Box(box_T, np.array([0.1, 0.1, 0.05])),),
        labels=(Label(np.array([0.0, 0.0, 0.3]), [f"step {i}" for i in range(m)]),),
    )
    state = [{"residual_m": float(1e-12 * i), "phase": "swing" if i % 2 else "stance",
              "leg_lengths_m": q[i, :6].tolist()} for i in range(m)]
    return MotionLog(times=t, root_frame="world", frame_names=names, frame_parents=parents,
                     T_parent_child=T, joint_names=[f"q{j + 1}" for j in range(k)], q=q,
                     qd=np.gradient(q, t, axis=0), effort=np.zeros((m, k)), scene=scene,
                     state=state, metadata={"scenario": "bench"})


def main() -> None:
    m = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    k = int(sys.argv[2]) if len(sys.argv) > 2 else 40
    t0 = time.perf_counter()
    lg = make_log(m, k)
    t1 = time.perf_counter()
    out = Path(sys.argv[3]) if len(sys.argv) > 3 else Path(tempfile.mkdtemp()) / "bench.mcap"
    write_mcap(out, lg)
    t2 = time.perf_counter()
    print(f"{m} steps x {k} frames: build log {t1 - t0:.3f} s, write_mcap {t2 - t1:.3f} s, "
          f"{out.stat().st_size / 1e6:.2f} MB -> {out}")


if __name__ == "__main__":
    main()

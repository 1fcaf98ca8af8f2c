"""Velocity + acceleration cost per step (run on demand: ``python benchmarks/bench_motion.py``).

The kim1995 Stewart platform (36 joint coordinates, 5 cuts, 30 closure equations, 6 legs)
along a 1000-step smooth leg-length trajectory: the loop closure is solved first
(:func:`solve_trajectory`, not part of the figure), then
:func:`mechkin.model.differential.motion_derivatives` gives the rates and accelerations of all
36 joints, the twists and accelerations of the 41 frames, gamma, and the singularity measures
(SVDs of d(phi)/d(q_w) (30 x 30) and of the reduced Jacobian (6 x 6)):

1. the whole trajectory in one batched call (time per step = total / 1000);
2. one call per step (the cost a step-by-step caller pays);
3. only the end-effector frame requested (``frames=["E"]``), batched.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from timing import best_of  # benchmarks/timing.py (this folder is on sys.path)

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_trajectory
from mechkin.model.differential import motion_derivatives

ROOT = Path(__file__).resolve().parents[1]


def bench_stewart(steps: int = 1000, repeat: int = 5) -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    q0v = mech.home[mech.independent]
    t = np.linspace(0.0, 1.0, steps)
    phase = np.arange(len(q0v))
    w = 2 * np.pi
    qv = q0v * (1 + 0.05 * np.sin(w * t[:, None] + phase))
    qd_v = q0v * 0.05 * w * np.cos(w * t[:, None] + phase)
    qdd_v = -q0v * 0.05 * w**2 * np.sin(w * t[:, None] + phase)
    t0 = time.perf_counter()
    res = solve_trajectory(mech, qv, mech.home[mech.dependent])
    solve = time.perf_counter() - t0
    assert res.ok.all()
    q = res.q
    md = motion_derivatives(mech, q, qd_v, qdd_v)  # warm up
    batched = best_of(lambda: motion_derivatives(mech, q, qd_v, qdd_v), repeat)
    ee = best_of(lambda: motion_derivatives(mech, q, qd_v, qdd_v, frames=["E"]), repeat)
    n1 = 200
    t0 = time.perf_counter()
    for k in range(n1):
        motion_derivatives(mech, q[k : k + 1], qd_v[k], qdd_v[k])
    single = (time.perf_counter() - t0) / n1
    print(f"Stewart platform, {steps} steps ({mech.n} joints, {mech.n_equations} closure "
          f"equations, {len(mech.frame_names)} frames)")
    print(f"  loop closure (solve_trajectory, for reference): {solve / steps * 1e3:.3f} ms/step")
    print(f"  velocity+acceleration, batched, all frames:     {batched / steps * 1e6:.1f} us/step "
          f"({batched * 1e3:.1f} ms for {steps})")
    print(f"  velocity+acceleration, batched, frame E only:   {ee / steps * 1e6:.1f} us/step")
    print(f"  velocity+acceleration, one call per step:       {single * 1e6:.1f} us/step")
    print(f"  max ||Phi qd|| {md.closure_rate_residual.max():.1e}, "
          f"max ||Phi qdd + gamma|| {md.closure_accel_residual.max():.1e}, "
          f"cond(dphi/dq_w) {md.singularity.cond_closure.min():.0f}.."
          f"{md.singularity.cond_closure.max():.0f}, classes "
          f"{sorted(set(md.singularity.label))}")


if __name__ == "__main__":
    bench_stewart()

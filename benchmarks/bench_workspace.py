"""Speed of the workspace maps and sweeps (issue 5): run on demand, never timed in tests.

Command::

    python benchmarks/bench_workspace.py [--repeat 3] [--skip-design]

Targets: one alpha-beta-gamma map of 201 x 201 x 3 poses with sigma_KI <= 1 s; one million
poses <= 10 s (both through :func:`mechkin.solvers.workspace.maps.orientation_maps` with
:func:`mechkin.solvers.workspace.maps.lee_evaluator`, i.e. Eq. (9) leg lengths and Eq. (21) sigma_KI
in closed form); forward position (all assembly modes) per call; the lee design sweep over
r = 0.25, 0.5, 0.75 (Fig. 2 gamma range on a 91 x 91 x 361 grid plus the Figs. 3-5 maps on
181 x 181) on 1 and 2 worker processes.
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np
from timing import best_of  # benchmarks/timing.py (this folder is on sys.path)

from mechkin.solvers.closed_form.lee_spherical import (
    LeeGeometry,
    forward_position,
    forward_position_batch,
    inverse_position,
)
from mechkin.solvers.workspace.maps import lee_evaluator, orientation_maps
from mechkin.solvers.workspace.sweeps import lee_design_sweep

DEG = math.pi / 180.0



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs")
    parser.add_argument("--skip-design", action="store_true", help="skip the design sweep")
    args = parser.parse_args()
    rep = args.repeat
    g = LeeGeometry(r=0.75)
    ev = lee_evaluator(g)

    ab = np.deg2rad(np.linspace(-90, 90, 201))
    gam = np.deg2rad([20.0, 30.0, 40.0])
    t = best_of(lambda: orientation_maps(ev, ab, ab, gam), rep)
    print(f"map 201 x 201 x 3 = {201 * 201 * 3} poses with sigma_KI: {t:.3f} s (aim <= 1 s)")

    ab1 = np.deg2rad(np.linspace(-90, 90, 409))
    gam1 = np.deg2rad(np.linspace(-180, 180, 6))  # 409 * 409 * 6 = 1,003,686 poses
    n1 = ab1.size**2 * gam1.size
    t = best_of(lambda: orientation_maps(ev, ab1, ab1, gam1, keep_actuators=False),
                max(1, rep - 1))
    print(f"map 409 x 409 x 6 = {n1} poses with sigma_KI: {t:.3f} s (aim <= 10 s)")

    rng = np.random.default_rng(0)
    mus = np.column_stack([rng.uniform(-1.2, 1.2, 1000), rng.uniform(-1.2, 1.2, 1000),
                           rng.uniform(-np.pi, np.pi, 1000)])
    lengths = inverse_position(g, mus)
    n_single = 200
    t = best_of(lambda: [forward_position(g, lengths[i]) for i in range(n_single)], rep)
    print(f"forward position, all assembly modes, one call: {1e3 * t / n_single:.3f} ms")
    t = best_of(lambda: forward_position_batch(g, lengths), rep)
    print(f"forward position, all assembly modes, batch of 1000: {1e3 * t / 1000:.3f} ms "
          "per problem")

    if args.skip_design:
        return
    params = {
        "gamma_sets": {"text": [20 * DEG, 30 * DEG, 40 * DEG],
                       "captions": [20 * DEG, 40 * DEG, 60 * DEG]},
        "n_alpha": 181, "n_beta": 181,
        "gamma_sweep": (-math.pi, math.pi), "n_gamma_sweep": 361,
        "n_alpha_sweep": 91, "n_beta_sweep": 91, "gamma_mode": "component",
        "gamma_ref": 30 * DEG,
    }
    values = [0.25, 0.5, 0.75]
    print(f"design sweep r = {values} (Figs. 2-5 grids, {os.cpu_count()} cpus):")
    for w in (1, 2):
        t = best_of(lambda w=w: lee_design_sweep("r", values, workers=w, **params),
                    max(1, rep - 1))
        print(f"  workers = {w}: {t:.3f} s")


if __name__ == "__main__":
    main()

"""Speed of lee's spherical mechanism: isotropy maps, a million poses, forward position.

Run on demand (never timed asserts in tests)::

    python benchmarks/bench_lee.py [--repeat 5]

Targets (issue 5): one 201 x 201 x 3 alpha-beta-gamma map with sigma_KI <= 1 s; one million
poses <= 10 s; forward position (all assembly modes) time per call.
"""

from __future__ import annotations

import argparse
from functools import partial

import numpy as np
from timing import best_of  # benchmarks/timing.py (this folder is on sys.path)

from mechkin.solvers.closed_form.lee_spherical import (
    LeeGeometry,
    evaluate_poses,
    forward_position,
    forward_position_batch,
    inverse_position,
)
from mechkin.solvers.workspace.maps import lee_evaluator, orientation_maps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="best of N runs")
    args = parser.parse_args()
    rep = args.repeat
    g = LeeGeometry(r=0.75)
    rng = np.random.default_rng(0)

    alpha = np.deg2rad(np.linspace(-90, 90, 201))
    gammas = np.deg2rad([20.0, 30.0, 40.0])
    for method in ("closed_form", "svd"):
        ev = lee_evaluator(g, method=method)
        t = best_of(partial(orientation_maps, ev, alpha, alpha, gammas), rep)
        print(f"map 201 x 201 x 3 = {201 * 201 * 3} poses, sigma_KI ({method}): {t:.3f} s")

    mu = np.column_stack(
        [
            rng.uniform(-np.pi, np.pi, 10**6),
            rng.uniform(-1.5, 1.5, 10**6),
            rng.uniform(-np.pi, np.pi, 10**6),
        ]
    )
    for method in ("closed_form", "svd"):
        t = best_of(partial(evaluate_poses, g, mu, method=method), max(1, rep // 2))
        print(f"1,000,000 poses, lengths + sigma_KI ({method}): {t:.3f} s")

    mus = np.column_stack(
        [
            rng.uniform(-1.2, 1.2, 1000),
            rng.uniform(-1.2, 1.2, 1000),
            rng.uniform(-np.pi, np.pi, 1000),
        ]
    )
    lengths = inverse_position(g, mus)
    n_single = 200
    t = best_of(lambda: [forward_position(g, lengths[i]) for i in range(n_single)], rep)
    print(f"forward position, all modes, one call: {1e3 * t / n_single:.3f} ms per call")
    t = best_of(lambda: forward_position_batch(g, lengths), rep)
    print(f"forward position, all modes, batch of 1000: {1e3 * t / 1000:.3f} ms per problem")
    counts = np.bincount([r.n_modes for r in forward_position_batch(g, lengths)], minlength=9)
    print(
        "real assembly modes over 1000 random poses (r = 0.75):",
        {k: int(c) for k, c in enumerate(counts) if c},
    )


if __name__ == "__main__":
    main()

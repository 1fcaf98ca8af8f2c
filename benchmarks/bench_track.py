"""Track planning on the PUMA 560 line: python benchmarks/bench_track.py [repeats].

scenarios/puma560_track_line.yaml (6-D path IK, orientation held; torque and velocity limits):

1. ``tracking`` (the DP) at 50x100 and 100x200, through :func:`plan_track` (path IK, RNEA
   coefficients and the DP: what ``mechkin track`` spends after loading);
2. ``time`` (rest to rest) and 3. ``intercept`` (rest to the part's state): mechkin's TOPP-RA
   (``planner: topp``) and the DP against toppra's TOPPRA (``pip install toppra``; the bench
   extra, never imported by mechkin). toppra gets the same joint path as a cubic spline through
   ``q(r)`` at 201 knots and the same RNEA per point; mechkin's TOPP-RA is timed both on that
   spline (``plan_time_optimal``, same inputs as toppra) and through ``plan_track`` on its own
   path IK. Accuracy: the relative error of the duration against mechkin's TOPP-RA at
   N = 4000 on the same path; "equal accuracy" pairs runs on the same grid (both solve the
   same LPs). The intercept uses a part 0.1 m ahead of the hand (the scenario's part, 0.05 m
   behind, is met at r = 0.005). toppra has no intercept: it is timed on its one
   rest-to-moving-state solve to the intercept point mechkin found (a lower bound of any
   toppra-based intercept, which needs a root-find over such solves).

Timing: median of ``repeats`` (default 5) interleaved rounds (every method once per round);
ratios are mechkin / toppra (below 1: mechkin faster).
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from mechkin.config.scenario import load_scenario
from mechkin.config.track_spec import limits_si, point_si
from mechkin.model import load_mechanism
from mechkin.solvers.dynamics.from_mechanism import dynamics_from_mechanism
from mechkin.solvers.track.dpct import ConveyorReference, TrackLimits
from mechkin.solvers.track.plan import plan_track
from mechkin.solvers.track.topp import plan_time_optimal, torque_coefficients
from mechkin.tasks.track import hand_ik

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "puma560_track_line.yaml"


def setup() -> tuple:
    sc = load_scenario(SCENARIO)
    spec = sc.section
    mech = load_mechanism(sc.mechanism_path)
    dyn = dynamics_from_mechanism(mech)
    lim = limits_si(spec.limits, sc.spec.units, np.asarray(mech.s) == 1)
    lim["q"] = (np.asarray(mech.lower, dtype=float), np.asarray(mech.upper, dtype=float))
    units = sc.spec.units
    path = hand_ik(sc, mech, point_si(spec.path.start, units), point_si(spec.path.end, units))
    ref = ConveyorReference(point_si(spec.conveyor.part_start, units),
                            point_si(spec.conveyor.belt_velocity, units))
    return dyn, path, ref, TrackLimits(**lim), lim


def interleaved(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median wall time [s] of each function over ``repeats`` rounds (one call per round)."""
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


def main(repeats: int) -> None:
    dyn, path, ref, limits, lim = setup()
    print(f"PUMA 560 line ({SCENARIO.name}), median of {repeats} interleaved rounds")

    # 1. tracking (DP) ------------------------------------------------------------------------
    runs = {f"tracking DP {a}x{b}": (lambda a=a, b=b: plan_track(
        dynamics=dyn, path=path, reference=ref, limits=limits, N1=a, N2=b,
        objective="tracking")) for a, b in ((50, 100), (100, 200))}
    med = interleaved(runs, repeats)
    for k, fn in runs.items():
        res = fn()
        print(f"  {k:28s} {med[k] * 1e3:9.1f} ms  t_a = {res.t_a_s:.4f} s  {res.status.value}")

    # the joint path as a spline for toppra (and for mechkin on identical inputs)
    import toppra
    import toppra.algorithm
    import toppra.constraint as tc

    toppra.setup_logging("WARNING")
    knots = np.linspace(0.0, 1.0, 201)
    spline = toppra.SplineInterpolator(knots, path.q(knots))
    tq = lim["torque"]
    qd = lim["qd"]

    def inv_dyn(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return dyn.inverse_dynamics(q[None], v[None], a[None])[0]

    from toppra.constraint.linear_constraint import (
        LinearConstraint,
        canlinear_colloc_to_interpolate,
    )

    class BatchedTorque(LinearConstraint):  # type: ignore[misc]
        """Torque limits with A, B, C from mechkin's batched RNEA (the same call mechkin's
        planner makes), in toppra's canonical form, interpolation scheme."""

        def __init__(self) -> None:
            super().__init__()
            self.identical = True
            self.discretization_type = tc.DiscretizationType.Interpolation

        def compute_constraint_params(self, path_, gridpoints, *args, **kwargs):
            q, d1, d2 = path_(gridpoints), path_(gridpoints, 1), path_(gridpoints, 2)
            A, B, C = torque_coefficients(dyn.inverse_dynamics, q, d1, d2)
            F = np.vstack([np.eye(6), -np.eye(6)])
            g = np.concatenate([tq[1], -tq[0]])
            return canlinear_colloc_to_interpolate(A, B, C, F, g, None, None, gridpoints,
                                                   identical=True)

    def toppra_solve(N: int, s_end: float = 1.0, sd_end: float = 0.0,
                     callback: bool = False) -> float:
        grid = np.linspace(0.0, s_end, N + 1)
        geo = spline if s_end == 1.0 else toppra.SplineInterpolator(
            np.linspace(0.0, s_end, 41), path.q(np.linspace(0.0, s_end, 41)))
        torque = (tc.JointTorqueConstraint(inv_dyn, np.stack(tq, 1), np.zeros(6),
                                           discretization_scheme=tc.DiscretizationType.
                                           Interpolation) if callback else BatchedTorque())
        cons = [torque, tc.JointVelocityConstraint(np.stack(qd, 1))]
        algo = toppra.algorithm.TOPPRA(cons, geo, gridpoints=grid, solver_wrapper="seidel")
        traj = algo.compute_trajectory(0.0, sd_end)
        return float("nan") if traj is None else float(traj.duration)

    def mech_spline(N: int, s_end: float = 1.0, sd_end: float = 0.0) -> float:
        grid = np.linspace(0.0, s_end, N + 1)
        q, d1, d2 = spline(grid), spline(grid, 1), spline(grid, 2)
        res = plan_time_optimal(grid, d1, d2, q=q, torque=tq,
                                inverse_dynamics=dyn.inverse_dynamics, qd=qd, sd_end=sd_end)
        return float(res.duration_s)

    # 2. time objective -----------------------------------------------------------------------
    T_ref = mech_spline(4000)
    T_ref_ik = plan_track(dynamics=dyn, path=path, limits=limits, N1=4000, objective="time",
                          planner="topp").duration_s
    print(f"  time objective: reference duration {T_ref:.6f} s (mechkin TOPP-RA, spline, "
          f"N = 4000); on the path IK {T_ref_ik:.6f} s")
    for N in (100, 1000):
        fns = {
            "toppra": lambda N=N: toppra_solve(N),
            "mechkin topp (spline)": lambda N=N: mech_spline(N),
            "mechkin plan_track topp": lambda N=N: plan_track(
                dynamics=dyn, path=path, limits=limits, N1=N, objective="time",
                planner="topp"),
        }
        if N <= 100:  # toppra's own torque constraint: one RNEA call per point and order
            fns["toppra (RNEA callback)"] = lambda N=N: toppra_solve(N, callback=True)
        med = interleaved(fns, repeats)
        d_t, d_m = toppra_solve(N), mech_spline(N)
        d_p = fns["mechkin plan_track topp"]().duration_s
        m_s, m_p, t_b = (med["mechkin topp (spline)"], med["mechkin plan_track topp"],
                         med["toppra"])
        print(f"  N = {N}: toppra {t_b * 1e3:8.1f} ms (err {d_t / T_ref - 1:+.2e}); mechkin "
              f"spline {m_s * 1e3:8.1f} ms (err {d_m / T_ref - 1:+.2e}), ratio {m_s / t_b:.3f}; "
              f"plan_track {m_p * 1e3:8.1f} ms (err {d_p / T_ref_ik - 1:+.2e}), ratio "
              f"{m_p / t_b:.3f}")
        if "toppra (RNEA callback)" in med:
            print(f"           toppra with its JointTorqueConstraint (RNEA per point): "
                  f"{med['toppra (RNEA callback)'] * 1e3:8.1f} ms")
    for a, b in ((50, 500), (100, 1000)):
        def fn(a: int = a, b: int = b):  # noqa: ANN202
            return plan_track(dynamics=dyn, path=path, limits=limits, N1=a, N2=b,
                              objective="time", planner="dp")

        med = interleaved({"dp": fn}, max(1, repeats // 2))
        d = fn().duration_s
        print(f"  DP {a}x{b}: {med['dp'] * 1e3:8.1f} ms (err {d / T_ref_ik - 1:+.2e})")

    # 3. intercept ----------------------------------------------------------------------------
    # the scenario's part (0.05 m behind) is met almost at once (r* = 0.005); a part 0.1 m
    # ahead of the hand makes the hand chase it
    ref = ConveyorReference(ref.part_start + np.array([0.0, 0.15, 0.0]), ref.belt_velocity)
    ref_res = plan_track(dynamics=dyn, path=path, reference=ref, limits=limits, N1=4000,
                         objective="intercept", planner="topp")
    pm = ref.motion(path)
    print(f"  intercept: reference t_a {ref_res.t_a_s:.6f} s at r = {ref_res.intercept_r:.5f} "
          "(TOPP-RA, N = 4000)")
    for N in (100, 1000):
        mine = plan_track(dynamics=dyn, path=path, reference=ref, limits=limits, N1=N,
                          objective="intercept", planner="topp")
        s_star, v_star = mine.intercept_r, float(pm.speed_at(mine.intercept_r))
        n_seg = max(20, int(round(N * s_star)))
        fns = {
            "mechkin intercept": lambda N=N: plan_track(
                dynamics=dyn, path=path, reference=ref, limits=limits, N1=N,
                objective="intercept", planner="topp"),
            "toppra one solve": lambda n=n_seg, s=s_star, v=v_star: toppra_solve(n, s, v),
        }
        med = interleaved(fns, repeats)
        print(f"  N = {N}: mechkin {med['mechkin intercept'] * 1e3:8.1f} ms (t_a err "
              f"{mine.t_a_s / ref_res.t_a_s - 1:+.2e}); toppra one rest-to-moving solve to s* "
              f"{med['toppra one solve'] * 1e3:8.1f} ms; ratio "
              f"{med['mechkin intercept'] / med['toppra one solve']:.3f}")
    for a, b in ((50, 100), (100, 200)):
        def fn(a: int = a, b: int = b):  # noqa: ANN202
            return plan_track(dynamics=dyn, path=path, reference=ref, limits=limits, N1=a,
                              N2=b, objective="intercept", planner="dp")

        med = interleaved({"dp": fn}, max(1, repeats // 2))
        r = fn()
        print(f"  DP intercept {a}x{b}: {med['dp'] * 1e3:8.1f} ms (t_a {r.t_a_s:.4f} s, err "
              f"{r.t_a_s / ref_res.t_a_s - 1:+.2e})")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)

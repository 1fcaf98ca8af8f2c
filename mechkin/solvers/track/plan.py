"""The track task's planner dispatch: the phase-plane DP, the DP intercept by decomposition,
or TOPP-RA (``planner: auto | dp | topp``).

DESIGN: one entry point, :func:`plan_track`, with the arguments of
:func:`mechkin.solvers.track.dpct.solve_conveyor_tracking` plus ``planner``. ``auto`` (the scenario
default) plans ``objective: time`` and ``objective: intercept`` by TOPP-RA
(:func:`mechkin.solvers.track.intercept.plan_track_topp`, O(N1)) when torque, velocity or
acceleration limits bound the speed and no jerk limit is set, and everything else by the DP.
With the DP, an intercept whose part starts ahead of the hand or rides an accelerating belt
goes through :func:`mechkin.solvers.track.intercept_dp.plan_intercept_dp` (dpct reading 11: the
single backward pass of reading 10 keeps one time per node and no grid state holds an
accelerating part's speed); the rest is :func:`~mechkin.solvers.track.dpct.solve_conveyor_tracking`.
This module exists so that dpct and intercept do not import each other.

Imports: mechkin.solvers (dpct, intercept, dynamics, path).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from mechkin.errors import ConfigError
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.track.dpct import (
    DEFAULT_DP,
    NT_FRACTION,
    ConveyorReference,
    DPOptions,
    TrackLimits,
    TrackResult,
    resolve_planner,
    solve_conveyor_tracking,
)
from mechkin.solvers.track.intercept import plan_track_topp
from mechkin.solvers.track.intercept_dp import plan_intercept_dp
from mechkin.solvers.track.path import JointPath


def plan_track(
    *,
    dynamics: InverseDynamics,
    path: JointPath,
    reference: ConveyorReference | None = None,
    limits: TrackLimits | None = None,
    N1: int = 50,
    N2: int = 100,
    objective: Literal["tracking", "time", "intercept"] = "tracking",
    nt_fraction: float = NT_FRACTION,
    x2_max: float | None = None,
    joint_names: Sequence[str] | None = None,
    planner: Literal["auto", "dp", "topp"] = "auto",
    dp: DPOptions | None = None,
) -> TrackResult:
    """Plan the hand's motion along the path (module docstring for the choice of planner).

    Parameters are those of :func:`mechkin.solvers.track.dpct.solve_conveyor_tracking`; TOPP-RA
    uses the ``N1 + 1`` points ``r = i / N1`` and ignores ``N2``, ``nt_fraction`` and
    ``x2_max``.

    Raises
    ------
    ConfigError
        ``planner: topp`` with a jerk limit or the tracking objective, and the errors of the
        planner chosen.
    """
    choice = resolve_planner(planner, objective, limits)
    readings = DEFAULT_DP if dp is None else dp
    if readings != DEFAULT_DP and (choice == "topp" or (
            objective == "intercept" and reference is not None and (
                reference.accelerating or reference.phase(path)[0] > 0.0))):
        what = "TOPP-RA" if choice == "topp" else "the intercept DP of a part ahead or an " \
            "accelerating belt (reading 11)"
        raise ConfigError(f"dp: the DP readings (step_time, wait_cost, jerk_ends) apply to the "
                          f"phase-plane DP of tracking and time only, not to {what}; set "
                          "planner: dp or remove dp")
    if choice == "topp":
        return plan_track_topp(dynamics=dynamics, path=path, reference=reference,
                               limits=limits, N=N1, objective=objective,
                               joint_names=joint_names)
    if objective == "intercept" and reference is not None and (
            reference.accelerating or reference.phase(path)[0] > 0.0):  # reading 11
        return plan_intercept_dp(dynamics=dynamics, path=path, reference=reference,
                                 limits=limits, N1=N1, N2=N2, nt_fraction=nt_fraction,
                                 joint_names=joint_names)
    return solve_conveyor_tracking(dynamics=dynamics, path=path, reference=reference,
                                   limits=limits, N1=N1, N2=N2, objective=objective,
                                   nt_fraction=nt_fraction, x2_max=x2_max,
                                   joint_names=joint_names, dp=readings)

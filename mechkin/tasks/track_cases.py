"""The ``track.cases`` of a scenario (park §5.3, Figs. 5-8: three limit sets compared) and the
``track.dp`` readings: one plan per case, solved like the scenario's own plan, for the
summary's ``cases`` list and the writer's overlay plots.

A case replaces the scenario's ``limits`` and/or ``dp`` (absent: the scenario's); a case equal
to the scenario's own plan reuses it. The CSV and the MCAP stay those of the scenario's plan.

Imports: config, solvers, records.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.track_spec import (
    CaseSpec,
    DpSpec,
    LimitsSpec,
    TrackSpec,
    limit_count_message,
    mechanism_limits_si,
)
from mechkin.errors import ConfigError
from mechkin.records.track import CaseTrace
from mechkin.solvers.result import Stopped
from mechkin.solvers.track.dpct import DPOptions, TrackLimits, TrackResult


def dp_options(spec: DpSpec | None) -> DPOptions:
    """The solver's readings of a ``dp:`` block (None: the defaults)."""
    if spec is None:
        return DPOptions()
    return DPOptions(step_time=spec.step_time, wait_cost=spec.wait_cost,
                     jerk_ends=spec.jerk_ends)


def case_limits(scenario: Scenario, mech: Any, limits: LimitsSpec,
                key: tuple[Any, ...]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``limits`` in SI with the mechanism's joint position limits as the default ``q``; a
    wrong count is a ConfigError at ``key + (name,)``."""
    lim = mechanism_limits_si(limits, scenario.spec.units, mech)
    if "q" not in lim:
        lim["q"] = (np.asarray(mech.lower, dtype=float), np.asarray(mech.upper, dtype=float))
    for name, (lo, _) in lim.items():
        if lo.shape != (mech.n,):
            raise ConfigError(f"{scenario.doc.where(key + (name,))}: "
                              f"{limit_count_message(mech, lo.shape[0])}")
    return lim


def solve_cases(
    scenario: Scenario, mech: Any, own: TrackResult,
    solve: Callable[[TrackLimits, DPOptions], TrackResult],
) -> list[tuple[CaseSpec, TrackResult, dict[str, tuple[np.ndarray, np.ndarray]]]]:
    """Every case of ``track.cases`` solved by ``solve(limits, dp)`` (the scenario's grid,
    path, part and dynamics); ``own`` (the scenario's plan) is reused for a case equal to it."""
    spec: TrackSpec = scenario.section
    out = []
    for k, case in enumerate(spec.cases or []):
        key = ("track", "cases", k, "limits")
        lim_spec = case.limits if case.limits is not None else spec.limits
        lim = case_limits(scenario, mech, lim_spec, key if case.limits is not None
                          else ("track", "limits"))
        dp_spec = case.dp if case.dp is not None else spec.dp
        if lim_spec == spec.limits and dp_spec == spec.dp:
            res = own
        else:
            try:
                res = solve(TrackLimits(**lim), dp_options(dp_spec))
            except Stopped:  # --max-time: the cases solved so far
                break
        out.append((case, res, lim))
    return out


def case_record(case: CaseSpec, res: TrackResult) -> dict[str, Any]:
    """One entry of the summary's ``cases`` list."""
    s = res.summary()
    keys = ("status", "message", "t_a_s", "t_start_s", "duration_s", "peak_torque",
            "limits_ok", "active_limits", "cost", "blocked_at_r", "blocking_limits", "dp",
            "time_penalty", "solve_time_s")
    return {"name": case.name, **{k: s[k] for k in keys}}


def case_traces(cases: list[tuple[CaseSpec, TrackResult, dict[str, Any]]]) -> list[CaseTrace]:
    """The feasible cases as plain arrays for the overlay plots (park Figs. 5-8)."""
    return [CaseTrace(name=c.name, trajectory=r.trajectory, t_a_s=r.t_a_s,
                      limits={k: (np.asarray(lo), np.asarray(hi)) for k, (lo, hi) in lim.items()})
            for c, r, lim in cases if r.trajectory is not None]

"""How long a task's job will take, from its size, before it starts (issue 28).

Every task calls :func:`mechkin.tasks.budget.estimate_time` with one of these before any work:
the estimate is printed beyond 30 s, by ``mechkin check``, kept in summary.json
(``estimated_time_s``) and compared with ``--max-time``. It is an order of magnitude: the
constants below were measured on the development machine (2 cores shared with other jobs, load
5-7, numba caches warm, so the first run of a new install also pays numba's compilation, up to
~90 s once); the same jobs ran 2-4 times faster when the load dropped, so an estimate is high
on an idle machine and small jobs (a few seconds) are dominated by :data:`RUN_OVERHEAD_S`;
tests/tasks/test_estimates.py keeps a medium job within a factor of 5.

How they were measured (2026-12-03): ``mechkin fk|ik|workspace|track SCENARIO --no-plots
--json --force`` on bundled scenarios made larger (fk: 20000-100000 steps; ik: the bundled
target sets; sweeps: the bundled grids and 20000 samples; DP grids up to 400 x 1000), the
wall time of the command minus its ~1.5 s start-up divided by the job size; the fitted per-item
costs are in the comments beside each constant.

Imports: the standard library only.
"""

from __future__ import annotations

from typing import Any

#: A run's fixed cost beyond the command's start-up: the task's imports (scipy, numba, the
#: writers), the compiled kernels' load, the writers' setup (0.2-5 s on small jobs of every
#: task with the load: e.g. 4 ik targets of the delta in 0.2 s at load 5, 6.0 s at load 7).
RUN_OVERHEAD_S = 1.5

#: fk, per step. Closed chains: the loop closure (Newton from the previous step) costs about
#: ``FK_CLOSED_STEP_S + FK_CLOSED_EQ_S`` x equations (five-bar, 2 equations: 1.5e-4 s;
#: delta, 12: 5.3e-4 s; Stewart, 30: 1.6e-3 s); open chains have none (one batched FK).
FK_CLOSED_STEP_S = 1e-4
FK_CLOSED_EQ_S = 4e-5
#: Rates (q', q'', twists) per step and joint: closed 2e-5 s (Stewart 7.6e-4 s for 36 joints),
#: open 5e-6 s (PUMA 3e-5 s for 6).
FK_RATES_CLOSED_S = 2e-5
FK_RATES_OPEN_S = 5e-6
#: Writing, per step and per joint + link + frame: fk.mcap 1.6e-5 s, fk.csv 4e-6 s (PUMA,
#: 21 of them, 100000 steps: mcap + csv 35 s, csv alone 7.5 s; delta, 50: 1e-3 s per step).
WRITE_MCAP_S = 1.6e-5
WRITE_CSV_S = 4e-6

#: ik, per start of one target (a start is the first solve or a restart). lm on an open chain
#: 1.5e-3 to 2.7e-3 s (PUMA, Panda: 50 random targets, 590-980 starts, 1.5-1.6 s); on a closed
#: chain about ``IK_CLOSED_START_S + IK_CLOSED_EQ_S`` x equations (Stewart, 30: 0.03 s), plus
#: the first target's assembly from home (``IK_CLOSED_FIRST_S``: five-bar, delta 0.4-0.5 s).
IK_LM_START_S = 2e-3
IK_CLOSED_START_S = 1e-2
IK_CLOSED_EQ_S = 1e-3
IK_CLOSED_FIRST_S = 0.5
#: cg-golden (kim1995 §5.2) per start: ~2000 function evaluations, 0.13-0.47 s per target.
IK_CG_START_S = 0.4
#: analytic / closed-form per target (PUMA: 50 targets in 0.3-1.7 s, nearly all of it loading
#: the compiled subproblems once: ``COMPILED_LOAD_S``).
IK_ANALYTIC_S = 1e-3
COMPILED_LOAD_S = 0.5
#: Of the allowed restarts, the share a target uses on average (random targets with cold
#: starts: PUMA 0.62, Panda 0.36 of 30; precision points: 0).
IK_RESTART_SHARE = 0.2

#: Joint sweeps, per sample: the frame's FK and dexterity (open chains: PUMA 20000 samples in
#: 0.9-1.5 s) or the loop closure from a neighbour too (``SWEEP_CLOSED_S + SWEEP_CLOSED_EQ_S`` x
#: equations: five-bar 1e-3 s, delta 2.3e-3 s, Stewart 6e-3 s), points.csv and MCAP 5e-5 s;
#: plus ``COMPILED_LOAD_S`` once.
SWEEP_OPEN_S = 5e-5
SWEEP_CLOSED_S = 5e-4
SWEEP_CLOSED_EQ_S = 2e-4
SWEEP_WRITE_S = 5e-5

#: Task-space sweeps, per ik start (121 poses x 9 starts of the PUMA: 10 s of compute).
TASK_SPACE_START_S = 1e-2

#: The phase-plane DP per transition (N1 x N2 x N2 of a grid) with the compiled stage
#: (solvers/track/dp_stage.py, dp_jit.py): 100 x 400 in 2.0 s, 200 x 600 in 2.3 s,
#: 400 x 1000 in 3.1 s (2.0 s at a lower load), 100 x 2000 in 4.6 s, time-optimal 200 x 1000 in
#: 3.2 s (1.3 s): about 5e-9 s each beyond a fixed 0.5-1.5 s (the kernel's load, the path ik
#: and dynamics); small grids run the numpy stage (1e-7 s per transition, 50 x 100 in 0.2 s)
#: and load nothing. (The constant before the compiled stage was 3e-7 s per transition.)
DP_S_PER_TRANSITION = 5e-9
DP_NUMPY_S_PER_TRANSITION = 1e-7


def _write_per_item(mech: Any, outputs: Any) -> float:
    k = mech.n + mech.n_links + len(mech.frame_names)
    return k * ((WRITE_MCAP_S if outputs.mcap else 0.0) + (WRITE_CSV_S if outputs.csv else 0.0))


def fk_seconds(mech: Any, m: int, outputs: Any) -> float:
    """m fk steps of ``mech`` with the scenario's ``outputs`` (loop closure, rates, files)."""
    closed = bool(mech.is_closed and len(mech.dependent))
    per = (FK_CLOSED_STEP_S + FK_CLOSED_EQ_S * mech.n_equations + FK_RATES_CLOSED_S * mech.n
           if closed else FK_RATES_OPEN_S * mech.n)
    return RUN_OVERHEAD_S + m * (per + _write_per_item(mech, outputs))


def ik_seconds(mech: Any, k: int, method: str, restarts: int, outputs: Any) -> float:
    """k ik targets of ``method`` with up to ``restarts`` restarts each."""
    closed = bool(mech.is_closed and len(mech.dependent))
    starts = 1.0 + IK_RESTART_SHARE * restarts
    if method in ("analytic", "closed-form") or (method == "auto" and not closed):
        solve, fixed = IK_ANALYTIC_S, COMPILED_LOAD_S
    elif method == "cg-golden":
        solve, fixed = starts * IK_CG_START_S, IK_CLOSED_FIRST_S if closed else 0.0
    elif closed:
        solve = starts * (IK_CLOSED_START_S + IK_CLOSED_EQ_S * mech.n_equations)
        fixed = IK_CLOSED_FIRST_S
    else:
        solve, fixed = starts * IK_LM_START_S, 0.0
    return RUN_OVERHEAD_S + fixed + k * (solve + _write_per_item(mech, outputs))


def joint_sweep_seconds(mech: Any, m: int) -> float:
    """A joint sweep of m samples (FK, dexterity, loop closure of closed chains, files)."""
    closed = bool(mech.is_closed and len(mech.dependent))
    per = (SWEEP_CLOSED_S + SWEEP_CLOSED_EQ_S * mech.n_equations) if closed else SWEEP_OPEN_S
    return RUN_OVERHEAD_S + COMPILED_LOAD_S + m * (per + SWEEP_WRITE_S)


def task_space_seconds(m: int, starts: int) -> float:
    """A task-space sweep of m poses with ``starts`` ik starts each (1 + restarts)."""
    return RUN_OVERHEAD_S + TASK_SPACE_START_S * m * starts


def dp_seconds(N1: int, N2: int, first: bool = True) -> float:
    """One phase-plane DP on an N1 x N2 grid (the numpy stage below ~1.5 s of work);
    ``first``: the run's first grid (it pays :data:`RUN_OVERHEAD_S`)."""
    transitions = float(N1) * float(N2) ** 2
    return (RUN_OVERHEAD_S if first else 0.0) + DP_S_PER_TRANSITION * transitions + min(
        DP_NUMPY_S_PER_TRANSITION * transitions, COMPILED_LOAD_S)

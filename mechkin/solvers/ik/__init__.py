r"""Inverse kinematics of complex chains by optimisation (kim1995 §3-§5).

The end-effector frame {E} is driven onto a precision point {P} by searching the independent
joints q_v; the dependent joints q_w follow from the loop closure (kim1995 Eq. (4)-(6)); the
objective is f(q_v) = 1/2 x^T W x (Eq. (7)-(9)) with the gradient of Eq. (10). Two methods
share that objective:

* ``cg-golden``: kim1995 §5.2 as printed: Fletcher-Reeves conjugate gradient, golden-section
  line search with bracketing (Arora 1989);
* ``lm``: damped Gauss-Newton (Levenberg-Marquardt) on the reduced Jacobian; the default.
  :func:`solve_ik_batch` runs it on many targets at once, vectorized across targets.

Joint limits and leg strokes of the independent joints are respected by projection. Every
result carries the position and orientation error of {E} recomputed by forward kinematics at
the returned joints.

Design
------
One solver family in several modules, each doing one thing:

==================== ===============================================================================
``kernel``           IkKernel (per-mechanism constants), the objective, evaluate, pose_errors
``results``          IkOptions, IkResult, IkBatchResult, IkStatus; verification and status
``seeds``            the seeded codebook (KD-tree of reachable poses), restart starts
``lm``               Levenberg-Marquardt, batched (numpy; dispatches to the compiled kernels)
``cg_golden``        kim1995 §5.2: conjugate gradient with golden-section line search
``solve``            solve_ik, solve_ik_batch (starts, restarts, results)
``chain``            solve_ik_sequence, solve_ik_warm (warm-started chains; closed chains retry a
                     failed target as a lone one)
``accel``            whether the compiled kernels can be used
``serial_jit``       compiled lm for open chains (numba, optional)
``tree_jit``         compiled lm and evaluation for closed chains (numba, optional)
``tree_closure_jit`` its tree kinematics and loop closure (cut and coupling rows) of one
                     configuration
``coupled_jit``      compiled lm of a coupled open chain in its reduced coordinates (numba; the
                     closed form q = S q_v + c0 is :mod:`mechkin.model.couplings`)
``all_solutions``    every solution of a target by multi-start lm
``warm``             the kernels ``mechkin warmup`` compiles
``multi_frame``      several frames' targets solved together (a biped's feet; closure, couplings)
``analytic``         analytic IK by subproblem decomposition (Paden-Kahan, IK-Geo), every branch
==================== ===============================================================================

Imports go down this table's dependency order (kernel <- results <- seeds, lm, cg_golden <-
solve); the family imports :mod:`mechkin.model`, :mod:`mechkin.spatial`,
:mod:`mechkin.solvers.result` and :mod:`mechkin.solvers.assembly`; no other solver room
(``closed_form`` builds on ``ik``, not the other way), never ``io/``, ``cli/`` or ``tasks/``
(docs/ARCHITECTURE.md).

References
----------
kim1995_complex_chain_ik §3-§5, Eq. (4)-(10); §5.1 (loop closure) and §5.2 (inverse kinematics).
"""

from __future__ import annotations

from mechkin.solvers.ik.accel import compiled_lm_available
from mechkin.solvers.ik.cg_golden import ACTIVE_BAND, GOLDEN, MAX_ITER_CG
from mechkin.solvers.ik.chain import solve_ik_sequence, solve_ik_warm
from mechkin.solvers.ik.kernel import (
    MAX_ITER_CLOSURE,
    TOL_DQ_CLOSURE,
    TOL_PHI,
    IkKernel,
    evaluate,
    gradient,
    kernel_for,
    objective,
    pose_errors,
    reduced_jacobian,
)
from mechkin.solvers.ik.lm import LM_MU, MAX_ITER_LM, PASSIVE_BAND, STALL_WINDOW
from mechkin.solvers.ik.results import (
    GRAD_TOL,
    TOL_ORI_RAD,
    TOL_POS_M,
    IkBatchResult,
    IkOptions,
    IkResult,
    IkStatus,
    Method,
    verify,
)
from mechkin.solvers.ik.seeds import SEED_CODEBOOK, SEED_RESTARTS
from mechkin.solvers.ik.solve import solve_ik, solve_ik_batch

__all__ = [
    "ACTIVE_BAND", "GOLDEN", "GRAD_TOL", "LM_MU", "MAX_ITER_CG", "MAX_ITER_CLOSURE", "MAX_ITER_LM",
    "PASSIVE_BAND", "SEED_CODEBOOK", "SEED_RESTARTS", "STALL_WINDOW", "TOL_DQ_CLOSURE",
    "TOL_ORI_RAD", "TOL_PHI", "TOL_POS_M", "IkBatchResult", "IkKernel", "IkOptions", "IkResult",
    "IkStatus", "Method", "compiled_lm_available", "evaluate", "gradient", "kernel_for",
    "objective", "pose_errors", "reduced_jacobian", "solve_ik", "solve_ik_batch",
    "solve_ik_sequence", "solve_ik_warm", "verify",
]

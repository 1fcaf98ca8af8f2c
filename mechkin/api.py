"""The public Python API (DESIGN.md: the same tasks as the CLI, no files, no printing).

>>> import mechkin
>>> mech = mechkin.load_mechanism("mechanisms/kim1995_direct_drive.yaml")   # doctest: +SKIP
>>> res = mechkin.fk(mech, [[0.3, 1.2]], frames=["end_effector"])        # doctest: +SKIP
>>> res.poses["end_effector"].shape                                        # doctest: +SKIP
(1, 4, 4)
>>> report = mechkin.run("scenarios/kim1995_direct_drive_fk.yaml")        # doctest: +SKIP
>>> report.status, report.write("outputs/demo")["files"]                  # doctest: +SKIP

Every function returns records (:mod:`mechkin.records`, the solvers' result records) and raises
:class:`mechkin.errors.MechkinError` subclasses on bad input; none writes a file except
:meth:`Report.write`.

Imports: config, model, solvers, tasks, records (all inside the functions, so ``import
mechkin`` stays cheap).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mechkin.solver import SolverBase, frame_indices, open_fk

if TYPE_CHECKING:  # pragma: no cover

    from mechkin.config.scenario import Scenario
    from mechkin.model import Mechanism
    from mechkin.records import FkResult, Report
    from mechkin.solvers.ik import IkResult


def load_mechanism(path: str | Path) -> Mechanism:
    """Read, validate and build a mechanism YAML file into an immutable :class:`Mechanism`."""
    from mechkin.model import load_mechanism as _load

    return _load(path)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (its mechanism path resolved, not yet loaded)."""
    from mechkin.config.scenario import load_scenario as _load

    return _load(Path(path))


def fk(
    mech: Mechanism,
    q_v: Any,
    *,
    q_w0: Any = None,
    frames: Sequence[str] | None = None,
    tol_phi: float | None = None,
) -> FkResult:
    """Forward kinematics of a batch of independent-joint values (kim1995 §5.1).

    Parameters
    ----------
    mech : Mechanism
    q_v : array_like, shape (m, n_v) or (n_v,)
        Independent joints [rad | m], in ``mech.independent_names`` order.
    q_w0 : array_like, shape (n_w,) or (m, n_w), optional
        Closed chains only. Default: every row is reached from the home assembly by
        continuation in q_v (the assembly mode connected to home). (n_w,): the home assembly
        is closed from this guess instead (choosing the mode). (m, n_w): a guess per row,
        Newton from it; rows that do not close from it are reached from home.
    frames : list of str, optional
        Frames whose poses to return; ``"end_effector"`` names the mechanism's {E}
        (default: the end effector if there is one).
    tol_phi : float, optional
        Loop-closure tolerance on ||phi_R||.

    Returns
    -------
    FkResult
        All joints ``q`` (m, n), per-row ``status`` (``converged``, ``outside limits`` when a
        passive joint is outside its limits, ``constraint singularity`` when the path from home
        stops where the assembly folds, ``not converged``), ``within_limits`` (closed chains),
        ``singularity_crossed`` (closed chains: per row, True when its path from home crossed a
        constraint singularity, a change point such as a parallelogram folding flat; the row
        stays ``converged``, on the smooth continuation of its branch) and ``residual``, and
        ``poses[name]`` (m, 4, 4) in the base frame.
    """
    if not mech.is_closed:  # open chain (no cuts, no couplings): only the frames asked for
        return open_fk(mech, q_v, q_w0, frames)
    import numpy as np

    from mechkin.errors import ConfigError
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import frame_poses
    from mechkin.records import FkResult

    qv = np.atleast_2d(np.asarray(q_v, dtype=float))
    if qv.shape[1] != len(mech.independent):
        raise ConfigError(f"q_v: expected {len(mech.independent)} columns "
                          f"({', '.join(mech.independent_names)}), got {qv.shape[1]}")
    bad_rows = np.flatnonzero(~np.isfinite(qv).all(axis=1))
    if bad_rows.size:
        raise ConfigError(f"q_v: row {int(bad_rows[0])} is not finite: {qv[bad_rows[0]].tolist()}")
    kw = {} if tol_phi is None else {"tol_phi": tol_phi}
    inside = start = crossed = None
    if mech.is_closed and len(mech.dependent):
        # closed chains: every row reached from home (or the guess) by continuation, passive
        # limits part of the status (mechkin.model.continuation)
        from mechkin.model.continuation import fk_rows, within_limits

        res, start = fk_rows(mech, qv, q_w0=q_w0, **kw)
        inside = within_limits(mech, res.q)[1].tolist()
        crossed = ([False] * len(qv) if res.crossings is None
                   else (np.asarray(res.crossings) > 0).tolist())
    else:
        qw0 = mech.home[mech.dependent] if q_w0 is None else np.asarray(q_w0, dtype=float)
        qw0 = np.broadcast_to(np.atleast_2d(qw0), (qv.shape[0], len(mech.dependent)))
        res = solve_closure(mech, qv, np.array(qw0), **kw)
    names, idx = frame_indices(mech, frames)
    T = frame_poses(mech, res.q, idx) if idx else np.zeros((len(qv), 0, 4, 4))
    return FkResult(q=res.q, status=[s.value for s in res.status], residual=res.residual,
                    iterations=res.iterations, poses={n: T[:, k] for k, n in enumerate(names)},
                    joint_names=list(mech.joint_names), within_limits=inside,
                    assembly_from=start, singularity_crossed=crossed)


def ik(
    mech: Mechanism,
    targets: Any,
    *,
    weights: Any = None,
    method: str = "auto",
    q_v0: Any = None,
    q_w0: Any = None,
    restarts: int | None = None,
    batch: bool = False,
    seed: int = 0,
    fixed: dict[str, float] | None = None,
) -> list[IkResult]:
    """Inverse kinematics of precision points (kim1995 §3-5), each verified by FK.

    Parameters
    ----------
    mech : Mechanism
    targets : array_like, shape (k, 4, 4) or (4, 4)
        Poses of {E} in the base frame [m].
    weights : array_like, shape (6,), optional
        Diagonal of W (position, orientation); default ones.
    method : {"auto", "analytic", "lm", "cg-golden"}
        ``auto`` (default): every branch by subproblem decomposition where the mechanism's
        axes allow it (:mod:`mechkin.solvers.ik.analytic`), the one nearest the guess; else
        ``lm``. ``analytic`` refuses a mechanism that does not decompose.
    q_v0, q_w0 : array_like, optional
        First guess; targets are then solved in order, each warm-started from the previous
        answer (kim1995 §5.2 Step 2).
    restarts : int, optional
        Extra seeded starts on failure (default: the scenario default of ``mechkin ik``).
    fixed : dict, optional
        ``{joint name: value}`` [rad | m]: hold these independent joints (a 7R arm's redundant
        joint) and solve the remaining 6R analytically (``auto`` / ``analytic`` only).
    batch : bool
        Solve all targets at once: one compiled call of the analytic solver (``auto`` on a
        decomposable arm: each target's solution nearest ``q_v0``), else vectorised lm.

    Returns
    -------
    list of IkResult
        One per target, with status and the verified position/orientation errors.
    """
    from mechkin.solvers.ik.analytic.api_ik import ik_one_fast

    fast = None if fixed else ik_one_fast(mech, targets, method, weights, q_v0, batch)
    if fast is not None:  # one pose, analytic, verified: no further checks needed
        return fast

    import numpy as np

    from mechkin.errors import ConfigError
    from mechkin.solvers.ik import solve_ik_batch, solve_ik_warm

    T = np.asarray(targets, dtype=float)
    T = T[None] if T.ndim == 2 else T
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ConfigError(f"targets: expected (k, 4, 4) poses, got shape {T.shape}")
    if method not in ("auto", "analytic", "lm", "cg-golden"):
        raise ConfigError(f"method: expected 'auto', 'analytic', 'lm' or 'cg-golden', got "
                          f"{method!r}")
    from mechkin.solver import ik_options

    opts, w = ik_options(mech, method if method in ("lm", "cg-golden") else "lm", weights,
                         restarts, seed)
    qv = mech.home[mech.independent].copy() if q_v0 is None else np.asarray(q_v0, float)
    qw = mech.home[mech.dependent].copy() if q_w0 is None else np.asarray(q_w0, float)
    if fixed and method not in ("auto", "analytic"):
        raise ConfigError(f"fixed: holds joints for method auto or analytic, not {method}")
    if method in ("auto", "analytic"):
        from mechkin.solvers.ik.analytic.api_ik import ik_analytic

        out_a = ik_analytic(mech, T, method=method, weights=w, q_v0=qv, q_w0=qw,
                            options=opts, batch=batch, fixed=fixed)
        if out_a is not None:
            return out_a
    if batch:
        from mechkin.tasks.ik_solve import batch_results

        W = np.broadcast_to(w, (len(T), 6))
        return batch_results(solve_ik_batch(mech, T, q_v0=qv, q_w0=qw, weights=W,
                                            options=opts), len(T), mech)
    out = []
    cold = (qv.copy(), qw.copy())  # closed chains: a failed warm target retried as a lone one
    for Tk in T:
        r = solve_ik_warm(mech, Tk, q_v0=qv, q_w0=qw, cold=cold, weights=w, options=opts)
        out.append(r)
        if np.all(np.isfinite(r.q)):
            qv, qw = r.q_v, r.q_w
    return out


def ik_frames(mech: Mechanism, targets: Sequence[dict[str, Any]], *, q_v0: Any = None,
              q_w0: Any = None, seed: int = 0, base_pose: Any = None) -> Any:
    """Several frames' targets solved together (a biped's feet, a humanoid's feet and hands):
    ``targets`` = ``[{"frame": "left_sole", "T": (4, 4), "weights": (6,) optional}, ...]``,
    with the loop closure and the joint couplings; a floating base's six joints are unknowns
    like the others, or, with ``base_pose`` (4, 4) (the floating base's pose in the world),
    held there while the rest is solved. Returns a
    :class:`mechkin.solvers.ik.multi_frame.MultiFrameResult` (status, q, per-frame verified
    errors)."""
    import numpy as np

    from mechkin.errors import ConfigError
    from mechkin.solvers.ik.multi_frame import FrameTarget, solve_multi_frame

    held = None
    if base_pose is not None:
        from mechkin.config.schema import FLOATING_JOINTS
        from mechkin.spatial.rotations import rpy_from_matrix

        if not mech.floating:
            raise ConfigError(f"base_pose: mechanism {mech.name!r} has no floating base")
        B = np.asarray(base_pose, dtype=float)
        if B.shape != (4, 4) or not np.all(np.isfinite(B)):
            raise ConfigError("base_pose: expected a finite (4, 4) pose")
        r, p, y = rpy_from_matrix(B[:3, :3])  # R = Rz(yaw) Ry(pitch) Rx(roll)
        values = dict(zip(FLOATING_JOINTS, (*B[:3, 3], y, p, r), strict=True))
        held = {i: float(values[n]) for i, n in enumerate(mech.independent_names)
                if n in values}

    fts = []
    for k, t in enumerate(targets):
        if t.get("frame") not in mech.frame_names:
            raise ConfigError(f"targets[{k}].frame: unknown frame {t.get('frame')!r}")
        T = np.asarray(t.get("T"), dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise ConfigError(f"targets[{k}].T: expected a finite (4, 4) pose")
        w = np.asarray(t.get("weights", np.ones(6)), dtype=float)
        fts.append(FrameTarget(str(t["frame"]), T, w))
    return solve_multi_frame(mech, fts, q_v0=None if q_v0 is None else np.asarray(q_v0, float),
                             q_w0=None if q_w0 is None else np.asarray(q_w0, float), seed=seed,
                             held=held)


def run(scenario: str | Path | Scenario, **options: Any) -> Report:
    """Run a scenario (a path or a loaded :class:`Scenario`) as ``mechkin <task>`` would, without
    writing files; ``report.write(out_dir)`` writes them. ``options``: workspace ``workers``,
    ``scheduler``, ``progress``."""
    from mechkin import tasks

    if isinstance(scenario, (str, Path)):
        return tasks.run_file(scenario, **options)
    return tasks.run(scenario, **options)



class Solver(SolverBase):
    """Forward and inverse kinematics of one mechanism with its plans, kernels and options
    kept (:class:`mechkin.solver.SolverBase`): ``Solver(mech).pose(q_v)`` (4, 4),
    ``.poses(qs)`` (m, k, 4, 4), ``.fk(qs)`` an :class:`FkResult` as :func:`fk`, ``.ik(T)``
    an :class:`IkResult` (a list for (k, 4, 4) targets) as :func:`ik`. Closed chains call
    :func:`fk` and :func:`ik` themselves."""

    def _closed_fk(self, q_v: Any, q_w0: Any, tol_phi: float | None) -> FkResult:
        return fk(self.mech, q_v, q_w0=q_w0, frames=self._frames, tol_phi=tol_phi)

    def _ik_many(self, T: Any, q_v0: Any, q_w0: Any, batch: bool) -> list[IkResult]:
        method, weights, restarts, seed = self._ik_args
        return ik(self.mech, T, weights=weights, method=method, q_v0=q_v0, q_w0=q_w0,
                  restarts=restarts, batch=batch, seed=seed)

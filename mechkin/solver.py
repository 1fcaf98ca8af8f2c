"""A per-mechanism solver object: the public API's fast path for repeated calls.

>>> import mechkin
>>> mech = mechkin.load_mechanism("mechanisms/puma560.yaml")            # doctest: +SKIP
>>> sol = mechkin.Solver(mech)                                          # doctest: +SKIP
>>> sol.pose([0.1, 0.2, 0.3, 0.0, 0.5, 0.0]).shape                      # doctest: +SKIP
(4, 4)
>>> sol.fk(qs).poses["end_effector"].shape   # an FkResult, as mechkin.fk      # doctest: +SKIP
>>> sol.ik(T).status                         # T (4, 4): one IkResult          # doctest: +SKIP

A :class:`Solver` resolves the frame names, the joint layout, the FK path plan (the joints on
the paths from the base to the frames asked for, :func:`mechkin.model.kinematics.frame_poses`)
and the IK options once, so repeated calls pay only for the kinematics. Results are those of
:func:`mechkin.fk` and :func:`mechkin.ik`, which call the same code: open chains evaluate only
the path joints of the requested frames (no loop closure: an open chain has none), closed
chains go through :func:`mechkin.api.fk` (the loop closure) unchanged.

Routes of one configuration (:meth:`Solver.pose`): the compiled FK kernel once
:mod:`mechkin.model.fk_accel` has loaded it (rent or buy, or ``compiled=True`` here, which
loads it at construction), else the plan's generated straight-line function; both give the
same bits (tests/model/test_fk_routes.py).

Design
------
Part of the public API: :class:`mechkin.api.Solver` is :class:`SolverBase` with the closed-chain
calls of :mod:`mechkin.api` (this module never imports the API: no cycle). Imports config,
model, solvers and records inside the functions, so ``import mechkin`` stays free of numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from mechkin.model import Mechanism
    from mechkin.records import FkResult
    from mechkin.solvers.ik import IkResult


def frame_indices(mech: Mechanism, frames: Sequence[str] | None) -> tuple[list[str], list[int]]:
    """Names and frame indices of ``frames`` (``"end_effector"`` names {E}; default {E} when
    the mechanism has one); bad names raise :class:`mechkin.errors.ConfigError`."""
    from mechkin.errors import ConfigError

    names = list(frames) if frames is not None else (
        ["end_effector"] if mech.end_effector is not None else [])
    idx = []
    for nm in names:
        if nm == "end_effector":
            if mech.end_effector is None:
                raise ConfigError(f"frames: mechanism {mech.name} has no end_effector")
            idx.append(int(mech.end_effector))
        else:
            try:
                idx.append(mech.frame_index(nm))
            except KeyError as exc:
                raise ConfigError(f"frames: {exc.args[0]}") from None
    return names, idx


_DEFAULT_RESTARTS: list[int] = []


def ik_options(mech: Mechanism, method: str, weights: Any, restarts: int | None,
               seed: int) -> tuple[Any, Any]:
    """The :class:`IkOptions` and weights (6,) of :func:`mechkin.ik` (checked; the default
    restarts are those of ``mechkin ik``, read once per process)."""
    import numpy as np

    from mechkin.errors import ConfigError
    from mechkin.solvers.ik import IkOptions

    if method not in ("lm", "cg-golden"):
        raise ConfigError(f"method: expected 'lm' or 'cg-golden', got {method!r}")
    if mech.end_effector is None:
        raise ConfigError(f"mechanism {mech.name} has no end_effector frame")
    w = np.ones(6) if weights is None else np.asarray(weights, dtype=float)
    if restarts is None and not _DEFAULT_RESTARTS:
        from mechkin.config.ik_spec import IkSpec

        _DEFAULT_RESTARTS.append(int(IkSpec.model_fields["restarts"].default))
    n_rs = _DEFAULT_RESTARTS[0] if restarts is None else int(restarts)
    return IkOptions(method=method, restarts=n_rs, seed=seed), w  # type: ignore[arg-type]


def open_fk(mech: Mechanism, q_v: Any, q_w0: Any, frames: Sequence[str] | None) -> FkResult:
    """:func:`mechkin.fk` of an open chain (no cuts): no loop closure, only the path joints of
    the requested frames; the same numbers as the closure route (whose open-chain branch
    assembles q and reports residual 0, converged, 0 iterations)."""
    key = None if frames is None else tuple(frames)
    cache = mech.__dict__.get("_api_solvers")
    if cache is None:
        cache = {}
        object.__setattr__(mech, "_api_solvers", cache)
    sol = cache.get(key)
    if sol is None:
        sol = SolverBase(mech, frames)
        if len(cache) < 16:
            cache[key] = sol
    return sol.fk(q_v, q_w0=q_w0)


class SolverBase:
    """Forward and inverse kinematics of one mechanism, with plans, kernels and options kept.

    Parameters
    ----------
    mech : Mechanism
    frames : list of str, optional
        Frames whose poses :meth:`fk` and :meth:`poses` return (default {E}).
    compiled : bool, optional
        Load the compiled FK kernel now (numba; the first call then pays nothing). Default:
        rent or buy, as :func:`mechkin.model.kinematics.frame_poses`.
    method, weights, restarts, seed, tol_pos, tol_ori :
        IK options of :meth:`ik` (as :func:`mechkin.ik`).
    """

    def __init__(self, mech: Mechanism, frames: Sequence[str] | None = None, *,
                 compiled: bool | None = None, method: str = "auto", weights: Any = None,
                 restarts: int | None = None, seed: int = 0) -> None:
        import numpy as np

        from mechkin.errors import ConfigError
        from mechkin.model import fk_accel
        from mechkin.model.fk_plan import _path_plan

        self.mech = mech
        self.frame_names, self._idx = frame_indices(mech, frames)
        self._frames = None if frames is None else list(frames)
        self.is_open = not mech.is_closed  # no cuts, no joint couplings
        self.n_v = len(mech.independent)
        n = mech.n
        self._plan = _path_plan(mech, np.asarray(self._idx, dtype=int), tuple(self._idx)) \
            if self._idx else None
        # open chains whose joints are all independent, in order: q is q_v
        self._identity = bool(len(mech.dependent) == 0 and
                              np.array_equal(mech.independent, np.arange(n)))
        self._home_w = mech.home[mech.dependent].copy()
        # the single-configuration hot path's constants (no lookups per call)
        self._fast = self._identity and self._plan is not None
        self._accel = fk_accel
        self._np, self._ndarray, self._f64, self._empty = np, np.ndarray, np.dtype(np.float64), \
            np.empty
        self._shape_v, self._shape_1, self._stride1 = (self.n_v,), (1, n), (8,)
        self._p = len(self._plan.steps) if self._plan is not None else 0
        self._jit = None if self._plan is None else self._plan.jit
        self._shape_out = None if self._plan is None else self._plan.shape1
        if compiled and self._plan is not None and fk_accel.compiled_fk_available():
            fk_accel.load()
        if method not in ("auto", "analytic", "lm", "cg-golden"):
            raise ConfigError(f"method: expected 'auto', 'analytic', 'lm' or 'cg-golden', got "
                              f"{method!r}")
        self._ik_args = (method, weights, restarts, seed)
        self._ik_opts: Any = None

    _RUNTIME = ("_accel", "_np", "_ndarray", "_f64", "_empty")

    def __getstate__(self) -> dict:
        """Pickled without its module references (a mechanism carries its cached solvers to
        distributed workers); :meth:`__setstate__` restores them."""
        return {k: v for k, v in self.__dict__.items() if k not in self._RUNTIME}

    def __setstate__(self, state: dict) -> None:
        import numpy as np

        from mechkin.model import fk_accel

        self.__dict__.update(state)
        self._accel, self._np, self._ndarray = fk_accel, np, np.ndarray
        self._f64, self._empty = np.dtype(np.float64), np.empty

    # ---- forward kinematics --------------------------------------------------------------
    def _q(self, qv: Any, q_w0: Any):
        """All joints (m, n) from q_v (m, n_v) and the dependent joints' guess."""
        import numpy as np

        if self._identity:
            return qv.copy()
        qw0 = self._home_w if q_w0 is None else np.asarray(q_w0, dtype=float)
        return self.mech.assemble(qv, np.broadcast_to(np.atleast_2d(qw0),
                                                      (qv.shape[0], len(self.mech.dependent))))

    def _check(self, q_v: Any):
        import numpy as np

        qv = np.asarray(q_v, dtype=np.float64)
        if qv.ndim == 1:
            qv = qv[None]
        if qv.ndim != 2 or qv.shape[1] != self.n_v:
            from mechkin.errors import ConfigError

            got = qv.shape[1] if qv.ndim == 2 else qv.shape
            raise ConfigError(f"q_v: expected {self.n_v} columns "
                              f"({', '.join(self.mech.independent_names)}), got {got}")
        return qv

    def poses(self, q_v: Any, q_w0: Any = None):
        """Poses (m, k, 4, 4) of the solver's frames for q_v (m, n_v) or (n_v,) (m = 1).

        Open chains: the path joints only; closed chains: after the loop closure
        (:func:`mechkin.api.fk`)."""
        if not self.is_open:
            res = self.fk(q_v, q_w0=q_w0)
            import numpy as np

            return np.stack([res.poses[nm] for nm in self.frame_names], axis=1) \
                if self.frame_names else np.zeros((len(res.q), 0, 4, 4))
        return self._poses(self._q(self._check(q_v), q_w0))

    def _poses(self, q):
        import numpy as np

        plan = self._plan
        if plan is None:
            return np.zeros((q.shape[0], 0, 4, 4))
        if q.shape[0] == 1 and q.flags.c_contiguous:
            return self._one(q)
        from mechkin.model.kinematics import frame_poses

        return frame_poses(self.mech, q, self._idx)

    def _one(self, q):
        """Poses (1, k, 4, 4) of one C-ordered float64 configuration q (1, n): the compiled
        kernel when loaded (or when rent or buy loads it now), else the generated function."""
        accel = self._accel
        entry = accel.ENTRY
        plan = self._plan
        if entry is None and accel.kernel_for_job(self._p, 1) is not None:
            entry = accel.ENTRY
        if entry is not None:
            out = self._empty(plan.shape1)
            entry(q, plan.jit, out)
            return out
        fn = plan.__dict__.get("_one")
        if fn is None:
            from mechkin.model.fk_plan import _plan_one_fast

            return _plan_one_fast(plan, q[0])
        return fn(q[0].tolist())

    def pose(self, q_v: Any):
        """Pose (4, 4) of the first frame (default {E}) for one configuration q_v (n_v,).

        The fastest call: open chains whose joints are all independent go straight to the
        plan's compiled kernel or generated function."""
        if self._fast:
            if (type(q_v) is self._ndarray and q_v.dtype is self._f64
                    and q_v.shape == self._shape_v and q_v.strides == self._stride1):
                q = q_v[None]  # (1, n), C-ordered: the kernel's own argument types
            else:
                q = self._np.array(q_v, dtype=self._f64, ndmin=2)
                if q.shape != self._shape_1:
                    q = self._check(q_v)
            entry = self._accel.ENTRY
            if entry is not None:  # the hot path: allocation and the kernel call
                out = self._empty(self._shape_out)
                entry(q, self._jit, out)
                return out[0, 0]
            return self._one(q)[0, 0]
        import numpy as np

        return self.poses(np.asarray(q_v, dtype=np.float64).reshape(1, -1))[0, 0]

    def fk(self, q_v: Any, *, q_w0: Any = None, tol_phi: float | None = None) -> FkResult:
        """:func:`mechkin.fk` with this solver's frames: an :class:`FkResult` (m rows)."""
        if not self.is_open:
            return self._closed_fk(q_v, q_w0, tol_phi)
        import numpy as np

        from mechkin.records import FkResult

        if (self._fast and q_w0 is None and type(q_v) is self._ndarray
                and q_v.dtype is self._f64 and q_v.shape == self._shape_v):
            q = q_v.reshape(self._shape_1).copy()  # one configuration: the hot path
            T = self._one(q)
            names = self.frame_names
            poses = {names[0]: T[:, 0]} if len(names) == 1 else {
                n: T[:, k] for k, n in enumerate(names)}
            return FkResult(q, ["converged"], np.zeros(1), np.zeros(1, dtype=int), poses,
                            list(self.mech.joint_names))
        qv = self._check(q_v)
        q = self._q(qv, q_w0)
        m = q.shape[0]
        T = self._poses(q)
        return FkResult(q=q, status=["converged"] * m, residual=np.zeros(m),
                        iterations=np.zeros(m, dtype=int),
                        poses={n: T[:, k] for k, n in enumerate(self.frame_names)},
                        joint_names=list(self.mech.joint_names))

    # ---- inverse kinematics --------------------------------------------------------------
    def ik(self, targets: Any, *, q_v0: Any = None, q_w0: Any = None, batch: bool = False):
        """:func:`mechkin.ik` with this solver's options: one :class:`IkResult` for a (4, 4)
        target, a list for (k, 4, 4) targets (``batch``: all at once, vectorised)."""
        import numpy as np

        T = np.asarray(targets, dtype=np.float64)
        if T.shape == (4, 4) and not batch:
            return self._ik_one(T, q_v0, q_w0)
        return self._ik_many(T, q_v0, q_w0, batch)

    def _closed_fk(self, q_v: Any, q_w0: Any, tol_phi: float | None) -> FkResult:
        """Closed chains: the loop closure of :func:`mechkin.api.fk` (set by the subclass
        :class:`mechkin.api.Solver`, so this module does not import the API)."""
        raise NotImplementedError

    def _ik_many(self, T: Any, q_v0: Any, q_w0: Any, batch: bool) -> list[IkResult]:
        """Several targets: :func:`mechkin.api.ik` (see :meth:`_closed_fk`)."""
        raise NotImplementedError

    def _ik_one(self, T, q_v0, q_w0) -> IkResult:
        """One target: :func:`mechkin.solvers.ik.solve_ik` with the options built once (the
        call :func:`mechkin.ik` makes for its first target)."""
        import numpy as np

        from mechkin.solvers.ik import solve_ik

        mech = self.mech
        if self._ik_opts is None:
            method, weights, restarts, seed = self._ik_args
            num = method if method not in ("auto", "analytic") else "lm"
            self._ik_opts = ik_options(mech, num, weights, restarts, seed)
        opts, w = self._ik_opts
        qv = mech.home[mech.independent].copy() if q_v0 is None else np.asarray(q_v0, float)
        qw = mech.home[mech.dependent].copy() if q_w0 is None else np.asarray(q_w0, float)
        if self._ik_args[0] in ("auto", "analytic"):  # as mechkin.ik: analytic where it applies
            from mechkin.solvers.ik.analytic.dispatch import solve_ik_method

            return solve_ik_method(mech, T, method=self._ik_args[0], q_v0=qv, q_w0=qw,
                                   weights=w, options=opts)
        return solve_ik(mech, T, q_v0=qv, q_w0=qw, weights=w, options=opts)

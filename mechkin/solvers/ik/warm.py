"""Compile (or load from numba's cache) the IK kernels ahead of first use (``mechkin warmup``).

The compiled kernels are specialised on argument types, not on a mechanism: compiling them
once for any open chain (``serial_jit.lm``, ``coupled_jit.lm_coupled`` for one with joint
couplings, the single-solve path ``serial_jit.solve_rows``,
the batch verification ``serial_jit.verify_rows``, the small-batch attempt
``serial_jit.lm_verify`` and the batch's whole-turn step ``serial_jit.nearest_turn_rows``)
and any closed chain (``tree_jit.lm_closed``; the cg-golden point evaluator
``tree_jit.evaluate_one`` serves both) covers every mechanism. Each kernel is run once on a
one-row problem at the mechanism's home pose, through the same wrappers the solvers call; the
solvers hand the kernels writable C arrays (:func:`mechkin.solvers.ik.lm.lm_batch`), so a run
never meets a second signature (a read-only start compiled ``lm_closed`` again: the first
Stewart IK after ``mechkin warmup`` took 3-6 s, issue 29).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports :mod:`mechkin.model`, the
family and, lazily, the compiled kernels (numba); never ``io/``, ``cli/`` or ``tasks/``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik import accel
from mechkin.solvers.ik.kernel import MAX_ITER_CLOSURE, TOL_DQ_CLOSURE, kernel_for

#: A two-joint arm and a four-bar loop: the smallest open and closed chains (the default
#: mechanisms of ``mechkin warmup``).
TINY_OPEN = """name: warmup_2r
units: {length: m, angle: deg}
links:
  - name: base
  - name: l1
  - name: l2
    frames: [{name: tip, xyz: [0.5, 0, 0]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, limits: [-170, 170], home: 20}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [0.6, 0, 0]},
     limits: [-150, 150], home: 40}
independent: [q1, q2]
end_effector: tip
"""
TINY_CLOSED = """name: warmup_fourbar
units: {length: m, angle: deg}
links:
  - name: ground
    frames: [{name: rocker_pivot, xyz: [1.0, 0, 0]}]
  - name: crank
  - name: coupler
    frames: [{name: coupler_end, xyz: [1.0, 0, 0]}]
  - name: rocker
    frames: [{name: rocker_end, xyz: [0.8, 0, 0]}]
joints:
  - {name: q_crank, type: revolute, parent: ground, child: crank, home: 60}
  - {name: q_coupler, type: revolute, parent: crank, child: coupler, origin: {xyz: [0.3, 0, 0]},
     home: -40}
  - {name: q_rocker, type: revolute, parent: rocker_pivot, child: rocker, home: 90}
cuts:
  - {name: pin, frames: [coupler_end, rocker_end], mask: [x, y]}
independent: [q_crank]
end_effector: coupler_end
"""
#: The two-joint arm with a third joint that follows the second (a mimic joint): the coupled
#: open chain's lm in reduced coordinates (:mod:`mechkin.solvers.ik.coupled_jit`).
TINY_COUPLED = TINY_OPEN.replace("name: warmup_2r", "name: warmup_2r_mimic").replace(
    "    frames: [{name: tip, xyz: [0.5, 0, 0]}]\n",
    "  - name: l3\n    frames: [{name: tip, xyz: [0.5, 0, 0]}]\n").replace(
    "independent: [q1, q2]\n",
    "  - {name: q3, type: revolute, parent: l2, child: l3, origin: {xyz: [0.5, 0, 0]}}\n"
    "couplings: [{joint: q3, master: q2, multiplier: 0.5}]\nindependent: [q1, q2]\n")


@dataclass(frozen=True)
class Warmed:
    """One kernel: its name, what it serves, the wall time [s] and whether numba's cache
    held it before (loaded) or it was compiled now."""

    name: str
    role: str
    seconds: float
    was_cached: bool | None


def kernels_for(mech: Mechanism) -> list[tuple[str, str]]:
    """(kernel name, role) of the compiled kernels ``mech``'s IK can use."""
    from mechkin.model.couplings import coupling_map

    closed = mech.is_closed and len(mech.dependent) > 0
    if closed and coupling_map(mech) is not None:  # couplings alone: open chain, reduced
        lms = [("coupled_jit.lm_coupled", "coupled open-chain lm")]
    elif closed:
        lms = [("tree_jit.lm_closed", "closed-chain lm")]
    else:
        lms = [("serial_jit.lm", "open-chain lm"),
               ("serial_jit.solve_rows", "open-chain single solve"),
               ("serial_jit.verify_rows", "open-chain batch verification"),
               ("serial_jit.lm_verify", "open-chain small batch"),
               ("serial_jit.nearest_turn_rows", "open-chain batch whole turns"),
               # analytic IK (method auto): type-specialised, warmed on a built-in 6R arm
               ("finish.solve_one_into", "analytic IK, one pose"),
               ("finish.solve_finish", "analytic IK, every branch of many poses"),
               ("finish.finish_batch", "analytic IK, SCARA and 5R branches"),
               ("sequence.solve_sequence_into", "analytic IK, a sequence of many poses")]
    return [*lms, ("tree_jit.evaluate_one", "cg-golden point evaluation")]


def _dispatcher(name: str):
    from mechkin.solvers.ik import coupled_jit, serial_jit, tree_jit
    from mechkin.solvers.ik.analytic import finish, sequence

    mod, fn = name.split(".")
    return getattr({"serial_jit": serial_jit, "tree_jit": tree_jit, "finish": finish,
                    "coupled_jit": coupled_jit, "sequence": sequence}[mod], fn)


def _runner(mech: Mechanism, name: str) -> Callable[[], object]:
    """A one-row call of kernel ``name`` on ``mech`` at home, through the solvers' wrapper."""
    from mechkin.model.kinematics import frame_poses
    from mechkin.solvers.ik import lm
    from mechkin.solvers.ik.results import IkOptions

    if name.startswith(("finish.", "sequence.")):
        return _analytic_runner(name)
    kern = kernel_for(mech)
    T = np.ascontiguousarray(frame_poses(mech, mech.home[None], [kern.frame])[:, 0])
    qv, qw = mech.home[kern.iv][None].copy(), mech.home[kern.iw][None].copy()
    w = np.ones((1, 6))
    opts = IkOptions()
    if name == "serial_jit.lm":
        return lambda: lm._lm_open_compiled(kern, qv, qw, T, w, opts, False)
    if name == "coupled_jit.lm_coupled":
        return lambda: lm._lm_coupled_compiled(kern, qv, T, w, opts, False, False)
    if name in ("serial_jit.solve_rows", "serial_jit.verify_rows", "serial_jit.lm_verify",
                "serial_jit.nearest_turn_rows"):
        from mechkin.solvers.ik import serial_jit
        from mechkin.solvers.ik.solve import _solve_consts

        c = _solve_consts(kern)
        F0 = kern.chain.first_frame(T)
        q, hist, at, info = np.empty(kern.iv.size), np.empty(6), np.empty(kern.iv.size, bool), \
            np.empty(12)
        if name == "serial_jit.lm_verify":
            n = kern.iv.size
            outs = (np.empty((1, n)), np.empty(1), np.zeros(1, dtype=np.int64),
                    np.zeros(1, dtype=np.bool_), np.zeros(1), np.empty((1, 4)))
            return lambda: serial_jit.lm_verify(qv, F0, w, *c[:11], 1e-30, 0.0, 5, 0,
                                                lm.LM_MU, T, *outs)
        if name == "serial_jit.nearest_turn_rows":  # as solve_ik_batch calls it
            ref = np.empty_like(qv)
            ref[:] = qv
            return lambda: serial_jit.nearest_turn_rows(qv.copy(), ref, c[8], c[9], c[10])
        if name == "serial_jit.verify_rows":
            return lambda: serial_jit.verify_rows(qv, c[5], *c[:5], T, w, np.empty((1, 4)))
        return lambda: serial_jit.solve_rows(
            qv, F0, w[0], *c[:11], 1e-30, 0.0, 5, 0, lm.LM_MU, False, c[11], qv[0], T[0], q,
            hist, at, info)
    if name == "tree_jit.lm_closed":
        from mechkin.solvers.ik import tree_jit

        return lambda: tree_jit.lm_closed_rows(
            kern, qv, qw, T, w, tol_phi=opts.tol_phi, tol_dq=TOL_DQ_CLOSURE,
            max_iter_closure=MAX_ITER_CLOSURE, max_iter=5, mu=lm.LM_MU, history=False,
            passive_band=lm.PASSIVE_BAND, f_abs=1e-30)
    from mechkin.solvers.ik.tree_jit import ClosedEvaluator

    ce = ClosedEvaluator(kern, opts.tol_phi, TOL_DQ_CLOSURE, MAX_ITER_CLOSURE)
    return lambda: ce(qv[0], qw[0], T[0])


#: A 6R arm with a spherical wrist (the analytic kernels are specialised on types only).
TINY_6R = """name: warmup_6r
units: {length: m, angle: deg}
dh_convention: standard
links: [{name: base}, {name: l1}, {name: l2}, {name: l3}, {name: l4}, {name: l5},
        {name: l6, frames: [{name: tool, xyz: [0, 0, 0]}]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, dh: {a: 0, alpha: 90, d: 0.4}}
  - {name: q2, type: revolute, parent: l1, child: l2, dh: {a: 0.5, alpha: 0, d: 0}}
  - {name: q3, type: revolute, parent: l2, child: l3, dh: {a: 0, alpha: 90, d: 0}}
  - {name: q4, type: revolute, parent: l3, child: l4, dh: {a: 0, alpha: -90, d: 0.5}}
  - {name: q5, type: revolute, parent: l4, child: l5, dh: {a: 0, alpha: 90, d: 0}}
  - {name: q6, type: revolute, parent: l5, child: l6, dh: {a: 0, alpha: 0, d: 0.1}}
independent: [q1, q2, q3, q4, q5, q6]
end_effector: tool
"""


def _analytic_runner(name: str) -> Callable[[], object]:
    """A call of analytic kernel ``name`` through its wrapper, on :data:`TINY_6R`."""
    import tempfile
    from pathlib import Path

    from mechkin.model import load_mechanism
    from mechkin.model.kinematics import frame_poses
    from mechkin.solvers.ik.analytic.classify import classify
    from mechkin.solvers.ik.analytic.dispatch import analytic_ik
    from mechkin.solvers.ik.analytic.finish import finish_batch
    from mechkin.solvers.ik.analytic.solutions import analytic_batch

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "warmup_6r.yaml"
        path.write_text(TINY_6R)
        mech = load_mechanism(path)
    chain = classify(mech)
    q = np.array([[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]] * 2)
    T = np.ascontiguousarray(frame_poses(mech, q, [mech.end_effector])[:, 0])
    if name == "finish.solve_one_into":
        return lambda: analytic_ik(mech, chain, T[0], q[0])
    if name == "finish.solve_finish":
        return lambda: analytic_batch(mech, chain, T, q[0])
    if name == "sequence.solve_sequence_into":  # the call of tasks.ik_analytic
        from mechkin.solvers.ik.analytic.sequence import solve_sequence_into

        bufs = (np.empty((2, 6)), np.empty((2, 3)), np.zeros(2, dtype=np.int64))
        return lambda: solve_sequence_into(chain.packed, T, np.ascontiguousarray(q[0]),
                                           np.zeros(2, dtype=bool), 1e-6, 1e-6, True, 0,
                                           *bufs)
    out = (np.empty((1, 2, 4)), np.empty((1, 2)), np.empty((1, 2)), np.empty((1, 2)),
           np.empty(1, dtype=np.int64))
    lo, hi = np.full(4, -np.pi), np.full(4, np.pi)
    return lambda: finish_batch(np.zeros((1, 2, 4)), np.ones(1, dtype=np.int64),
                                np.zeros((1, 2, 2)), np.zeros((1, 4)), lo, hi,
                                np.ones(4, dtype=np.bool_), 1e-8, 1e-8, 1e-3, *out)


def warm(mechs: list[Mechanism]) -> Iterator[tuple[str, str] | Warmed]:
    """Compile or load every kernel the mechanisms use, each once. Yields ``(name, role)``
    before a kernel starts, then its :class:`Warmed` record."""
    accel.quiet = True
    try:
        seen: set[str] = set()
        for mech in mechs:
            for name, role in kernels_for(mech):
                if name in seen:
                    continue
                seen.add(name)
                yield name, role
                run = _runner(mech, name)
                cached = accel.is_cached(_dispatcher(name))
                t0 = time.perf_counter()
                run()
                dt = time.perf_counter() - t0
                kind = {"serial_jit.lm": "open", "tree_jit.lm_closed": "closed",
                        "coupled_jit.lm_coupled": "open"}.get(name)
                if kind:
                    accel.mark_loaded(kind)
                yield Warmed(name, role, dt, cached)
    finally:
        accel.quiet = False

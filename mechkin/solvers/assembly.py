r"""Every assembly mode of a closed chain at given independent joints (kim1995 §5.1, all roots).

The loop closure :math:`\phi_R(q_v, q_w) = 0` (kim1995 Eq. (4)) has, for fixed actuated joints
q_v, a finite set of solutions q_w: the assembly modes (a four-bar's open and crossed
configurations, up to eight plate orientations of lee's spherical mechanism). Newton-Raphson
(:func:`mechkin.model.closure.solve_closure`) finds the one nearest its start; this module runs
it from many seeded starts at once and keeps the distinct converged solutions:

* starts: the given guess, then seeded random q_w, half uniform within the limits (a revolute
  joint without limits in [-pi, pi]; a prismatic one within +-1 characteristic length of home),
  half normal about home (0.5 rad, 10 % of the length);
* verified: ``||phi_R|| < tol_phi`` by forward kinematics at the returned joints;
* distinct: two solutions are one mode when every frame of the mechanism (link frames and named
  frames) is at the same place (``same_tol`` m, relative to the characteristic length) and
  {E} has the same orientation (``same_tol`` rad). Joint values that move no frame (a
  universal joint's second angle pair for the same leg direction, which spins the leg about its
  own axis) therefore do not make a new mode: the modes are the solutions of the forward
  position problem. Each mode is represented by its solution nearest the guess (joint
  distance, revolute joints modulo 2 pi);
* ordered: by that distance from the guess, then lexicographically by q_w;
* flagged: whether every joint of a mode lies within its limits (the kim1995 direct-drive
  arm's crossed parallelogram closes the loop but leaves the passive limits).

Design
------
A solver: may import :mod:`mechkin.model`; never ``io/``, ``cli/``, ``tasks/`` or ``config/``.

References
----------
kim1995_complex_chain_ik §5.1 (loop closure, Eq. (4)); lee_spherical_3dof_parallel §2.3 (the
forward position problem has several assembly modes).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.model.mechanism import Mechanism

ASSEMBLY_STARTS = 256
SAME_TOL = 1e-6
TOL_PHI = 1e-9


@dataclass(frozen=True)
class AssemblyModes:
    """The distinct assembly modes at one q_v.

    q : (k, n) all joints of each mode; residual : (k,) ||phi_R|| verified by forward
    kinematics; distance : (k,) joint distance from the guess (revolute modulo 2 pi);
    starts : how many starts were run; converged : how many of them closed the loops;
    time_s : wall time; within_limits : (k,) whether every joint of the mode lies within its
    limits (a mode outside them is a solution of the equations the mechanism cannot reach).
    """

    q: np.ndarray
    residual: np.ndarray
    distance: np.ndarray
    starts: int
    converged: int
    time_s: float
    within_limits: np.ndarray | None = None  # (k,) bool: every joint within its limits
    #: index of the mode reached from the home assembly by continuation in q_v (the one fk
    #: returns by default, :mod:`mechkin.model.continuation`); None when that path stops
    from_home: int | None = None

    @property
    def count(self) -> int:
        return int(self.q.shape[0])


def wrapped_difference(mech: Mechanism, joints: np.ndarray, a: np.ndarray,
                       b: np.ndarray) -> np.ndarray:
    """a - b (..., k) for joints ``joints`` (k,), revolute differences wrapped into [-pi, pi)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    rev = mech.s[joints] == 0
    return np.where(rev, (d + np.pi) % (2 * np.pi) - np.pi, d)


def characteristic_length(mech: Mechanism) -> float:
    """The largest distance between two frame origins at home (1 m if all coincide)."""
    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    p = forward_kinematics(mech, q0).frames(mech)[0, :, :3, 3]
    size = float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1), initial=0.0))
    return size if size > 1e-9 else 1.0


def mode_key(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """What tells assembly modes apart (m, 3 nf + 9): every frame origin [m] and the rotation of
    {E} (the base if none) at joints q (m, n)."""
    F = forward_kinematics(mech, np.atleast_2d(q)).frames(mech)
    e = mech.end_effector if mech.end_effector is not None else 0
    m = F.shape[0]
    return np.concatenate([F[:, :, :3, 3].reshape(m, -1), F[:, e, :3, :3].reshape(m, 9)],
                          axis=1)


def _starts(mech: Mechanism, q_w0: np.ndarray, k: int, seed: int) -> np.ndarray:
    dep = mech.dependent
    rng = np.random.default_rng(seed)
    L = characteristic_length(mech)
    home = np.where(np.isfinite(mech.home[dep]), mech.home[dep], 0.0)
    prism = mech.s[dep] == 1
    lo = np.where(np.isfinite(mech.lower[dep]), mech.lower[dep],
                  np.where(prism, home - L, -np.pi))
    hi = np.where(np.isfinite(mech.upper[dep]), mech.upper[dep],
                  np.where(prism, home + L, np.pi))
    n_uni = (k - 1) // 2
    uni = rng.uniform(lo, hi, size=(n_uni, dep.size))
    near = home + rng.normal(size=(k - 1 - n_uni, dep.size)) * np.where(prism, 0.1 * L, 0.5)
    return np.vstack([np.asarray(q_w0, float)[None], uni, near])


#: At most this many corners of the dependent joints' limit box are Newton starts.
MAX_CORNERS = 64


def _corner_starts(mech: Mechanism) -> np.ndarray:
    """Corners of the dependent joints' limit box (a joint without limits: home -+ pi/2, or
    -+ half the size for a prismatic one), at most :data:`MAX_CORNERS` (a seeded subset)."""
    import itertools

    dep = mech.dependent
    L = characteristic_length(mech)
    home = np.where(np.isfinite(mech.home[dep]), mech.home[dep], 0.0)
    half = np.where(mech.s[dep] == 1, 0.5 * L, 0.5 * np.pi)
    lo = np.where(np.isfinite(mech.lower[dep]), mech.lower[dep], home - half)
    hi = np.where(np.isfinite(mech.upper[dep]), mech.upper[dep], home + half)
    if dep.size <= 6:
        return np.array(list(itertools.product(*zip(lo, hi, strict=True))), dtype=float)
    pick = np.random.default_rng(0).integers(0, 2, size=(MAX_CORNERS, dep.size)).astype(bool)
    return np.where(pick, hi, lo)


def _from_home(mech: Mechanism, q_v: np.ndarray, starts: np.ndarray, tol_phi: float,
               max_iter: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Configurations at q_v reached by continuation (:mod:`mechkin.model.continuation`) from
    the assembly modes at the home q_v (closed from home and from ``starts``): (q (k, n),
    the one reached from the home assembly itself or None)."""
    from mechkin.model.continuation import continue_closure, home_assembly

    home = np.where(np.isfinite(mech.home), mech.home, 0.0)
    h = home_assembly(mech)
    at_home = solve_closure(mech, np.broadcast_to(home[mech.independent],
                                                  (len(starts), len(mech.independent))),
                            starts, tol_phi=min(tol_phi, 1e-12), max_iter=max_iter)
    Q = np.vstack([h.q[:1], at_home.q])
    ok = np.concatenate([h.ok[:1], at_home.ok])
    Q = Q[ok]
    if Q.shape[0] == 0:
        return np.zeros((0, mech.n)), None
    # one continuation per distinct home mode
    key = mode_key(mech, Q) / np.concatenate([np.full(3 * len(mech.frame_names),
                                                      characteristic_length(mech)), np.ones(9)])
    keep: list[int] = []
    for i in range(len(Q)):
        if not any(np.abs(key[i] - key[j]).max() < 1e-6 for j in keep):
            keep.append(i)
    r = continue_closure(mech, np.broadcast_to(q_v, (len(keep), q_v.size)), Q[keep])
    first = r.q[0] if (h.ok[0] and r.ok[0]) else None
    return r.q[r.ok], first


def assembly_modes(mech: Mechanism, q_v: np.ndarray, *, q_w0: np.ndarray | None = None,
                   starts: int = ASSEMBLY_STARTS, seed: int = 0, tol_phi: float = TOL_PHI,
                   same_tol: float = SAME_TOL, max_iter: int = 40,
                   continuation: bool = True) -> AssemblyModes:
    r"""Every assembly mode found by seeded multi-start Newton-Raphson at one q_v.

    .. math:: q_w^{k+1} = q_w^k - [\partial\phi_R/\partial q_w]^+ \phi_R(q_v, q_w^k)

    from ``starts`` starts (the guess ``q_w0``, default home, first) and the corners of the
    dependent joints' limit box; with ``continuation`` also the modes reached from the home
    assembly and from every mode found at the home q_v by continuation in q_v
    (:mod:`mechkin.model.continuation`); kept where ``||phi_R|| < tol_phi`` and merged into
    modes as in the module docstring. ``from_home`` names the mode reached from the home
    assembly (the one ``fk`` follows).

    Parameters
    ----------
    q_v : array, shape (n_v,)
    q_w0 : array, shape (n_w,), optional
    starts : int
        Newton starts (one batch).
    max_iter : int
        Newton iterations per start (a start that has not closed by then is dropped).
    seed : int
    tol_phi : float
        Accepted loop-closure residual (verified by forward kinematics).
    same_tol : float
        Frame-position [relative to the characteristic length] and {E}-orientation [rad]
        distance below which two solutions are one mode.

    Returns
    -------
    AssemblyModes

    References
    ----------
    kim1995_complex_chain_ik §5.1, Eq. (4).
    """
    t0 = time.perf_counter()
    q_v = np.asarray(q_v, dtype=np.float64).reshape(-1)
    dep = mech.dependent
    guess = (np.where(np.isfinite(mech.home[dep]), mech.home[dep], 0.0) if q_w0 is None
             else np.asarray(q_w0, np.float64).reshape(-1))
    n = mech.n
    if dep.size == 0 or not mech.is_closed:
        q = mech.assemble(q_v[None], guess[None]).reshape(1, n)
        res = closure_residual(mech, forward_kinematics(mech, q))
        r = np.linalg.norm(res, axis=1) if res.shape[1] else np.zeros(1)
        lim = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
        return AssemblyModes(q=q, residual=r, distance=np.zeros(1), starts=1, converged=1,
                             time_s=time.perf_counter() - t0, within_limits=lim)
    Q0 = np.vstack([_starts(mech, guess, max(int(starts), 1), seed), _corner_starts(mech)])
    extra, home_q = np.zeros((0, n)), None
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = solve_closure(mech, np.broadcast_to(q_v, (len(Q0), q_v.size)), Q0,
                            tol_phi=min(tol_phi, 1e-12), max_iter=max_iter)
        q = res.q
        if continuation:
            extra, home_q = _from_home(mech, q_v, _corner_starts(mech), tol_phi, max_iter)
            q = np.vstack([q, extra])
        fin = np.all(np.isfinite(q), axis=1)
        q = q[fin]
        phi = closure_residual(mech, forward_kinematics(mech, q))
        phin = np.linalg.norm(phi, axis=1)
    ok = np.isfinite(phin) & (phin < tol_phi)
    q, phin = q[ok], phin[ok]
    if q.shape[0] == 0:
        return AssemblyModes(q=np.zeros((0, n)), residual=np.zeros(0), distance=np.zeros(0),
                             starts=len(Q0), converged=0, time_s=time.perf_counter() - t0,
                             within_limits=np.zeros(0, dtype=bool))
    dist = np.linalg.norm(wrapped_difference(mech, dep, q[:, dep], guess[None]), axis=1)
    # nearest the guess first, so each mode's representative is its nearest solution
    order = np.lexsort(tuple(np.round(q[:, dep], 9).T[::-1]) + (np.round(dist, 9),))
    q, phin, dist = q[order], phin[order], dist[order]
    key = mode_key(mech, q)
    scale = np.concatenate([np.full(key.shape[1] - 9, characteristic_length(mech)),
                            np.ones(9)])
    key = key / scale
    keep: list[int] = []
    for i in range(len(q)):
        if not any(np.abs(key[i] - key[j]).max() < same_tol for j in keep):
            keep.append(i)
    idx = np.array(keep, dtype=int)
    q = q[idx]
    # revolute joints at the turn nearest the guess where that stays within the limits
    near = guess[None] + wrapped_difference(mech, dep, q[:, dep], guess[None])
    inside = (near >= mech.lower[dep]) & (near <= mech.upper[dep])
    q[:, dep] = np.where(inside, near, q[:, dep])
    lim = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
    out = AssemblyModes(q=q, residual=phin[idx], distance=dist[idx],
                        starts=len(Q0) + len(extra), converged=int(ok.sum()),
                        time_s=time.perf_counter() - t0, within_limits=lim)
    if home_q is not None:
        from dataclasses import replace

        out = replace(out, from_home=mode_of(mech, out, home_q))
    return out


def mode_of(mech: Mechanism, modes: AssemblyModes, q: np.ndarray,
            same_tol: float = 1e-4) -> int | None:
    """Index of the mode of ``modes`` that configuration q (n,) is in (None if none)."""
    if modes.count == 0:
        return None
    key = mode_key(mech, np.vstack([np.asarray(q, float)[None], modes.q]))
    scale = np.concatenate([np.full(key.shape[1] - 9, characteristic_length(mech)),
                            np.ones(9)])
    key = key / scale
    d = np.abs(key[1:] - key[0]).max(axis=1)
    i = int(np.argmin(d))
    return i if d[i] < same_tol else None

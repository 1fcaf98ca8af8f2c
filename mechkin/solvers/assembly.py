r"""Every assembly mode of a closed chain at given independent joints (kim1995 §5.1, all roots).

The loop closure :math:`\phi_R(q_v, q_w) = 0` (kim1995 Eq. (4)) has, for fixed actuated joints
q_v, a finite set of solutions q_w: the assembly modes (a four-bar's open and crossed
configurations, up to eight plate orientations of lee's spherical mechanism). Newton-Raphson
(:func:`mechkin.model.closure.solve_closure`) finds the one nearest its start; this module runs
it from many seeded starts at once and keeps the distinct converged solutions:

* starts: the given guess, then seeded random q_w, half uniform within the limits (a revolute
  joint without limits in [-pi, pi]; a prismatic one within +-1 characteristic length of home),
  half normal about home (0.5 rad, 10 % of the length). Each random start is tried twice: by
  Newton at q_v directly, and after relaxing it to an assembled configuration with the actuated
  joints free too (:func:`relax`: minimum-norm Gauss-Newton on phi(q) = 0 over every joint, the
  actuated ones starting at q_v), then Newton at q_v. A random q_w is far from any closure; the
  relaxed start is a consistent configuration of nearly the requested q_v (for a Stewart
  platform, a platform pose with slightly wrong leg lengths), and Newton at q_v converges from
  it far more often and to many more modes (Dietmaier's 40-posture platform: 37-39 of the 40
  modes from 1024 relaxed starts, 10 from 1024 direct ones);
* explored: from every mode found, :data:`EXPLORE_PER_MODE` perturbed starts (normal,
  :data:`EXPLORE_SIGMA` rad, or that times 0.1 characteristic length for a prismatic joint) run
  Newton deflated at every known mode (:func:`deflated_newton`), round after round until
  :data:`EXPLORE_PATIENCE` rounds in a row find no new mode (at most :data:`EXPLORE_ROUNDS`):
  deflation drives each start away from the mode it began at, to another one, often a
  neighbour with a small basin that plain multi-start Newton rarely reaches (modes lying close
  together near a fold of the forward problem). Dietmaier's platform: all 40 modes with the
  default 256 starts for each of the seeds 0-9, and with ``mechkin info``'s 64 starts for the
  seeds 0-4 (without exploration 21-25 of them, 256 starts, seeds 0-3);
* verified: ``||phi_R|| < tol_phi`` by forward kinematics at the returned joints;
* distinct: two solutions are one mode when every frame of the mechanism (link frames and named
  frames) is at the same place (``same_tol`` m, relative to the characteristic length) and
  {E} has the same orientation (``same_tol`` rad). Joint values that move no frame (a
  universal joint's second angle pair for the same leg direction, which spins the leg about its
  own axis) therefore do not make a new mode: the modes are the solutions of the forward
  position problem. Each mode is represented by its solution nearest the guess (joint
  distance, revolute joints modulo 2 pi) among those within the limits, if any (the same frames
  can be reached with other joint values, e.g. a spherical joint's Euler angles (a + pi,
  pi - b, c + pi), which :func:`spherical_equivalents` substitutes where it is within the
  limits); revolute joints are taken at the turn nearest the guess where that stays within the
  limits;
* ordered: by that distance from the guess, then lexicographically by q_w;
* flagged: whether every joint of a mode lies within its limits (the kim1995 direct-drive
  arm's crossed parallelogram closes the loop but leaves the passive limits).

Design
------
A solver: may import :mod:`mechkin.model`; never ``io/``, ``cli/``, ``tasks/`` or ``config/``.

References
----------
kim1995_complex_chain_ik §5.1 (loop closure, Eq. (4)); lee_spherical_3dof_parallel §2.3 (the
forward position problem has several assembly modes). P. Dietmaier, "The Stewart-Gough platform
of general geometry can have 40 real postures", Advances in Robot Kinematics, 1998 (the test
case of tests/solvers/test_assembly_stewart.py).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mechkin.model.closure import _pinv_solve, solve_closure
from mechkin.model.kinematics import closure_jacobian, closure_residual, forward_kinematics
from mechkin.model.mechanism import Mechanism

ASSEMBLY_STARTS = 256
SAME_TOL = 1e-6
TOL_PHI = 1e-9
#: perturbed starts per newly found mode in each exploration round
EXPLORE_PER_MODE = 4
#: at most this many exploration rounds
EXPLORE_ROUNDS = 12
#: exploration ends after this many rounds in a row that find no new mode
EXPLORE_PATIENCE = 3
#: spread of the exploration starts about a mode [rad; x 0.1 characteristic length for m]
EXPLORE_SIGMA = 0.3
#: Gauss-Newton iterations of :func:`relax`
RELAX_ITER = 30


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


def relax(mech: Mechanism, q: np.ndarray, *, max_iter: int = RELAX_ITER,
          tol_phi: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    r"""Assembled configurations near q (m, n): Gauss-Newton on :math:`\phi_R(q) = 0` over every
    joint, the independent ones included, by minimum-norm steps

    .. math:: \Delta q = -U J^T (J U^2 J^T + \lambda I)^{-1} \phi_R,

    U scaling prismatic columns by the characteristic length, :math:`\lambda` 1e-12 of the
    largest diagonal entry (redundant constraint rows, as a planar loop's out-of-plane rows,
    leave :math:`J J^T` singular), each step at most 0.5 (rad, or x the length).

    Returns (q (m, n), ok (m,) bool: ``||phi_R|| < tol_phi``).
    """
    q = np.array(q, dtype=np.float64)
    m = q.shape[0]
    ok = np.zeros(m, dtype=bool)
    if m == 0:
        return q, ok
    unit = np.where(mech.s == 1, characteristic_length(mech), 1.0)
    act = np.arange(m)
    for it in range(max_iter + 1):
        phi, J = closure_jacobian(mech, forward_kinematics(mech, q[act]))
        nphi = np.linalg.norm(phi, axis=1)
        fin = np.isfinite(nphi)
        done = fin & (nphi < tol_phi)
        ok[act[done]] = True
        keep = fin & ~done
        if it == max_iter or not keep.any():
            break
        act, phi, J = act[keep], phi[keep], J[keep] * unit
        JJ = J @ np.swapaxes(J, 1, 2)
        lam = 1e-12 * np.max(np.diagonal(JJ, axis1=1, axis2=2), axis=1, initial=0.0) + 1e-300
        JJ += lam[:, None, None] * np.eye(JJ.shape[1])
        try:
            y = np.linalg.solve(JJ, phi[..., None])
        except np.linalg.LinAlgError:
            y = np.linalg.pinv(JJ) @ phi[..., None]
        step = (np.swapaxes(J, 1, 2) @ y)[..., 0]
        nst = np.linalg.norm(step, axis=1, keepdims=True)
        q[act] -= unit * step * np.minimum(1.0, 0.5 / np.maximum(nst, 1e-300))
    return q, ok


def spherical_equivalents(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """q (m, n) with the angles (a, b, c) of each spherical joint that leaves its limits replaced
    by the other Euler-angle solution of the same rotation, (a + pi, pi - b, c + pi) (axes
    x-y-z-like) or (a + pi, -b, c + pi) (z-y-z-like), each angle at the turn within its limits,
    where that puts the joint within its limits and moves no frame of a real link (checked by
    forward kinematics). The same assembly, so the within-limits flag does not depend on which
    of the two Newton happened to reach."""
    q = np.array(q, dtype=np.float64)
    groups = [np.array(g.joints) for g in mech.groups if g.type == "spherical"
              and len(g.joints) == 3 and np.all(mech.s[list(g.joints)] == 0)]
    if not groups or len(q) == 0:
        return q
    lo, hi = mech.lower, mech.upper
    real = np.flatnonzero(~np.isin(mech.frame_link, list(mech.virtual_links)))
    tol = 1e-9 * max(1.0, characteristic_length(mech))
    for j in groups:
        rows = np.flatnonzero(np.any((q[:, j] < lo[j] - 1e-9) | (q[:, j] > hi[j] + 1e-9), axis=1))
        for mid in (np.pi, 0.0):
            if rows.size == 0:
                break
            c = q[rows].copy()
            c[:, j] = np.stack([c[:, j[0]] + np.pi, mid - c[:, j[1]], c[:, j[2]] + np.pi], axis=1)
            turn = lo[j] + np.mod(c[:, j] - lo[j], 2.0 * np.pi)
            c[:, j] = np.where(np.isfinite(lo[j]) & (turn <= hi[j]), turn, c[:, j])
            inside = np.all((c[:, j] >= lo[j] - 1e-9) & (c[:, j] <= hi[j] + 1e-9), axis=1)
            F0 = forward_kinematics(mech, q[rows]).frames(mech, real)
            F1 = forward_kinematics(mech, c).frames(mech, real)
            same = np.abs(F1 - F0).max(axis=(1, 2, 3), initial=0.0) < tol
            ok = inside & same
            q[rows[ok]] = c[ok]
            rows = rows[~ok]
    return q


def _distinct(key: np.ndarray, same_tol: float, known: np.ndarray | None = None) -> list[int]:
    """Rows of key (k, d) that differ (max-norm >= same_tol) from every earlier kept row and
    from every row of ``known``, in order."""
    kept = np.zeros((0, key.shape[1])) if known is None else np.asarray(known, float)
    keep: list[int] = []
    for i in range(len(key)):
        if len(kept) and np.abs(kept - key[i]).max(axis=1).min() < same_tol:
            continue
        keep.append(i)
        kept = np.vstack([kept, key[i][None]])
    return keep


def _scaled_key(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    key = mode_key(mech, q)
    scale = np.concatenate([np.full(key.shape[1] - 9, characteristic_length(mech)),
                            np.ones(9)])
    return key / scale


def _closed(mech: Mechanism, q_v: np.ndarray, Q_w: np.ndarray, tol_phi: float,
            max_iter: int) -> np.ndarray:
    """Newton at q_v from dependent-joint starts Q_w (k, n_w): the converged q (j, n)."""
    if len(Q_w) == 0:
        return np.zeros((0, mech.n))
    res = solve_closure(mech, np.broadcast_to(q_v, (len(Q_w), q_v.size)), Q_w,
                        tol_phi=min(tol_phi, 1e-12), max_iter=max_iter)
    return res.q[res.ok]


def _relaxed(mech: Mechanism, q_v: np.ndarray, Q_w: np.ndarray, tol_phi: float,
             max_iter: int) -> np.ndarray:
    """Starts Q_w (k, n_w) relaxed with q_v free (:func:`relax`), then Newton at q_v."""
    if len(Q_w) == 0:
        return np.zeros((0, mech.n))
    q = mech.assemble(np.broadcast_to(q_v, (len(Q_w), q_v.size)), Q_w)
    q, ok = relax(mech, q)
    return _closed(mech, q_v, q[ok][:, mech.dependent], tol_phi, max_iter)


def deflated_newton(mech: Mechanism, q_v: np.ndarray, Q_w: np.ndarray, roots: np.ndarray, *,
                    shift: float = 1.0, max_iter: int = 40,
                    tol_phi: float = 1e-10) -> np.ndarray:
    r"""Newton-Raphson at q_v from starts Q_w (k, n_w), deflated at known roots (r, n_w).

    The deflated system :math:`G(q_w) = M(q_w)\,\phi_R(q_v, q_w)`,
    :math:`M = \prod_j (\|q_w - r_j\|^{-2} + \sigma)` (Farrell, Birkisson and Funke 2015,
    Eq. (3.2), power 2, shift sigma), has the roots of :math:`\phi_R` except the known ones;
    its Newton step is the plain step :math:`\delta = [\partial\phi_R/\partial q_w]^+ \phi_R`
    scaled by :math:`1 / (1 + \nabla \ln M \cdot \delta)` (Sherman-Morrison), at most 0.5
    long. Started beside a known root it converges to another root, often a neighbouring one
    that plain Newton from there would not reach. Distances: revolute joints wrapped into
    [-pi, pi), prismatic ones divided by the characteristic length.

    Returns the converged q_w (j, n_w) (``||phi_R|| < tol_phi``; polish them with
    :func:`mechkin.model.closure.solve_closure`).

    References
    ----------
    P. E. Farrell, A. Birkisson, S. W. Funke, "Deflation techniques for finding distinct
    solutions of nonlinear partial differential equations", SIAM J. Sci. Comput. 37(4), 2015,
    A2026-A2045, §3.
    """
    dep = mech.dependent
    unit = np.where(mech.s[dep] == 1, characteristic_length(mech), 1.0)
    qw = np.array(Q_w, dtype=np.float64)
    roots = np.asarray(roots, np.float64)
    ok = np.zeros(len(qw), dtype=bool)
    act = np.arange(len(qw))
    for _ in range(max_iter + 1):
        if act.size == 0:
            break
        kin = forward_kinematics(mech, mech.assemble(np.broadcast_to(q_v, (act.size, q_v.size)),
                                                     qw[act]))
        phi, J = closure_jacobian(mech, kin)
        nphi = np.linalg.norm(phi, axis=1)
        done = nphi < tol_phi
        ok[act[done]] = True
        keep = ~done & np.isfinite(nphi)
        act, phi, J = act[keep], phi[keep], J[keep][:, :, dep]
        if act.size == 0:
            break
        delta, _ = _pinv_solve(J, phi)
        d = wrapped_difference(mech, dep, qw[act][:, None], roots[None]) / unit  # (m, r, n_w)
        d2 = np.maximum(np.sum(d * d, axis=-1), 1e-300)
        grad = np.sum(-2.0 * d / (d2 * (1.0 + shift * d2))[..., None], axis=1) / unit
        den = 1.0 + np.sum(grad * delta, axis=1)
        step = delta / np.where(np.abs(den) > 1e-12, den, 1e-12)[:, None]
        nst = np.linalg.norm(step / unit, axis=1, keepdims=True)
        qw[act] -= step * np.minimum(1.0, 0.5 / np.maximum(nst, 1e-300))
    return qw[ok]


def _explore(mech: Mechanism, q_v: np.ndarray, q: np.ndarray, rng, tol_phi: float,
             same_tol: float, max_iter: int, rounds: int) -> tuple[np.ndarray, int]:
    """Deflated Newton (:func:`deflated_newton`) from perturbations of every mode found so far,
    every known mode deflated, round after round until :data:`EXPLORE_PATIENCE` rounds in a row
    find no new mode. q (k, n) the solutions so far; returns one solution of each new mode
    (j, n) and the number of starts."""
    dep = mech.dependent
    sigma = np.where(mech.s[dep] == 1, 0.1 * characteristic_length(mech), EXPLORE_SIGMA)
    tried = 0
    if len(q) == 0:
        return np.zeros((0, mech.n)), tried
    key = _scaled_key(mech, q)
    idx = _distinct(key, same_tol)
    modes, known, n0 = q[idx], key[idx], len(idx)
    idle = 0
    for _ in range(rounds):
        S = np.repeat(modes[:, dep], EXPLORE_PER_MODE, axis=0)
        S = S + rng.normal(size=S.shape) * sigma
        tried += len(S)
        got = _closed(mech, q_v, deflated_newton(mech, q_v, S, modes[:, dep],
                                                 max_iter=max_iter), tol_phi, max_iter)
        k = _scaled_key(mech, got) if len(got) else known[:0]
        idx = _distinct(k, same_tol, known)
        idle = 0 if idx else idle + 1
        if idle >= EXPLORE_PATIENCE:
            break
        if not idx:
            continue
        known, modes = np.vstack([known, k[idx]]), np.vstack([modes, got[idx]])
    return modes[n0:], tried


def assembly_modes(mech: Mechanism, q_v: np.ndarray, *, q_w0: np.ndarray | None = None,
                   starts: int = ASSEMBLY_STARTS, seed: int = 0, tol_phi: float = TOL_PHI,
                   same_tol: float = SAME_TOL, max_iter: int = 40,
                   continuation: bool = True, explore: int = EXPLORE_ROUNDS) -> AssemblyModes:
    r"""Every assembly mode found by seeded multi-start Newton-Raphson at one q_v.

    .. math:: q_w^{k+1} = q_w^k - [\partial\phi_R/\partial q_w]^+ \phi_R(q_v, q_w^k)

    from ``starts`` starts (the guess ``q_w0``, default home, first; every random start both
    directly and relaxed, module docstring) and the corners of the dependent joints' limit box;
    then ``explore`` rounds about the modes found; with ``continuation`` also the modes reached
    from the home assembly and from every mode found at the home q_v by continuation in q_v
    (:mod:`mechkin.model.continuation`); kept where ``||phi_R|| < tol_phi`` and merged into
    modes as in the module docstring. ``from_home`` names the mode reached from the home
    assembly (the one ``fk`` follows).

    Parameters
    ----------
    q_v : array, shape (n_v,)
    q_w0 : array, shape (n_w,), optional
    starts : int
        Random Newton starts (one batch, each also relaxed).
    max_iter : int
        Newton iterations per start (a start that has not closed by then is dropped).
    seed : int
    tol_phi : float
        Accepted loop-closure residual (verified by forward kinematics).
    same_tol : float
        Frame-position [relative to the characteristic length] and {E}-orientation [rad]
        distance below which two solutions are one mode.
    explore : int
        At most this many exploration rounds (0: none).

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
    rand = _starts(mech, guess, max(int(starts), 1), seed)
    Q0 = np.vstack([rand, _corner_starts(mech)])
    extra, home_q = np.zeros((0, n)), None
    n_starts = len(Q0) + len(rand) - 1
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        q = np.vstack([_closed(mech, q_v, Q0, tol_phi, max_iter),
                       _relaxed(mech, q_v, rand[1:], tol_phi, max_iter)])
        if continuation:
            extra, home_q = _from_home(mech, q_v, _corner_starts(mech), tol_phi, max_iter)
            q = np.vstack([q, extra])
            n_starts += len(extra)
        if explore > 0:
            q = q[np.all(np.isfinite(q), axis=1)]
            found, tried = _explore(mech, q_v, q, np.random.default_rng(seed + 1), tol_phi,
                                    same_tol, max_iter, int(explore))
            q = np.vstack([q, found])
            n_starts += tried
        fin = np.all(np.isfinite(q), axis=1)
        q = q[fin]
        phi = closure_residual(mech, forward_kinematics(mech, q))
        phin = np.linalg.norm(phi, axis=1)
    ok = np.isfinite(phin) & (phin < tol_phi)
    q, phin = q[ok], phin[ok]
    if q.shape[0] == 0:
        return AssemblyModes(q=np.zeros((0, n)), residual=np.zeros(0), distance=np.zeros(0),
                             starts=n_starts, converged=0, time_s=time.perf_counter() - t0,
                             within_limits=np.zeros(0, dtype=bool))
    # revolute joints at the turn nearest the guess where that stays within the limits
    near = guess[None] + wrapped_difference(mech, dep, q[:, dep], guess[None])
    inside = (near >= mech.lower[dep]) & (near <= mech.upper[dep])
    q[:, dep] = np.where(inside, near, q[:, dep])
    q = spherical_equivalents(mech, q)
    lim = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
    dist = np.linalg.norm(wrapped_difference(mech, dep, q[:, dep], guess[None]), axis=1)
    # within the limits, then nearest the guess first: each mode's representative is its
    # solution within the limits nearest the guess (or, if none is, its nearest)
    order = np.lexsort(tuple(np.round(q[:, dep], 9).T[::-1]) + (np.round(dist, 9), ~lim))
    q, phin, dist, lim = q[order], phin[order], dist[order], lim[order]
    idx = np.array(_distinct(_scaled_key(mech, q), same_tol), dtype=int)
    # modes by distance from the guess, then lexicographically by q_w
    idx = idx[np.lexsort(tuple(np.round(q[idx][:, dep], 9).T[::-1])
                         + (np.round(dist[idx], 9),))]
    out = AssemblyModes(q=q[idx], residual=phin[idx], distance=dist[idx],
                        starts=n_starts, converged=int(ok.sum()),
                        time_s=time.perf_counter() - t0, within_limits=lim[idx])
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

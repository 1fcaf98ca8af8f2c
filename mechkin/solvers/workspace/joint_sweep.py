r"""Joint-space sweeps: where a frame goes when the independent joints sweep a set of samples.

:func:`joint_sweep` takes samples of the independent joints ``q_v`` (m, n_v), closes the loops
of a closed chain (kim1995 §5.1, Newton on ``phi(q_v, q_w) = 0``), and returns per sample the
position of a frame, whether the sample is **reachable** (loop closure converged, every joint
within its limits, everything finite) and, when asked, the dexterity of the reduced frame
Jacobian ``J = J_v + J_w dq_w/dq_v`` (kim1995 Eq. (10); :mod:`mechkin.solvers.workspace.dexterity`).

:func:`point_cloud_volume` measures the reachable positions: the bounding box, the volume of
the occupied voxels (cubes of a given edge) and of the convex hull (an upper bound for
non-convex workspaces).

References
----------
kim1995_complex_chain_ik §5.1, Eq. (10); Yoshikawa (1985), IJRR 4(2).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from mechkin.records.workspace import JointSweepRecord
from mechkin.solvers.workspace.dexterity import (
    characteristic_length,
    dexterity,
    length_bounds,
    normalized_isotropy,
)

__all__ = ["continuation_tree", "joint_sweep", "point_cloud_volume"]


def continuation_tree(q_v: np.ndarray, grid_shape: tuple[int, ...] | None = None,
                      home: np.ndarray | None = None, k: int = 8
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The order in which a sweep solves its samples: each sample's parent is a nearby sample
    solved before it (its loop closure starts there, not at ``home``).

    Parameters
    ----------
    q_v : array, shape (m, n_v)
        The samples.
    grid_shape : tuple of int, optional
        Samples on a C-order grid of this shape (last axis fastest): the parent of multi-index
        ``i`` is ``i - e_j`` with ``j`` the last axis where ``i_j > 0`` (one grid step away);
        sample 0 is the root. None: scattered samples (Monte Carlo), see below.
    home : array, shape (n_v,), optional
        Scattered samples: each connected part of the k-nearest-neighbour graph (distances in
        joint coordinates scaled by their spread) is rooted at its sample nearest ``home``,
        walked breadth first, and every sample takes as parent its nearest neighbour on an
        earlier level.
    k : int
        Neighbours per sample of that graph.

    Returns
    -------
    parent : ndarray of int, shape (m,)
        -1 for a root (solved from home).
    level : ndarray of int, shape (m,)
        Parents have lower levels; samples of one level are solved together.
    """
    qv = np.asarray(q_v, dtype=np.float64)
    m = qv.shape[0]
    if m == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    if grid_shape is not None:
        idx = np.array(np.unravel_index(np.arange(m), grid_shape)).T  # (m, d)
        level = idx.sum(axis=1)
        pos = idx > 0
        last = np.where(pos.any(axis=1), idx.shape[1] - 1 - np.argmax(pos[:, ::-1], axis=1), -1)
        strides = np.array([int(np.prod(grid_shape[j + 1:])) for j in range(len(grid_shape))])
        parent = np.where(last >= 0, np.arange(m) - strides[np.maximum(last, 0)], -1)
        return parent.astype(np.int64), level.astype(np.int64)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components
    from scipy.spatial import cKDTree

    scale = np.ptp(qv, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    x = qv / scale
    kk = min(k, m - 1)
    parent = np.full(m, -1, dtype=np.int64)
    level = np.zeros(m, dtype=np.int64)
    if kk == 0:
        return parent, level
    dist, nb = cKDTree(x).query(x, k=kk + 1)
    dist, nb = dist[:, 1:], nb[:, 1:]
    rows = np.repeat(np.arange(m), kk)
    g = coo_matrix((np.ones(m * kk), (rows, nb.ravel())), shape=(m, m)).tocsr()
    n_comp, label = connected_components(g, directed=False)
    h = (np.zeros(qv.shape[1]) if home is None else np.asarray(home, dtype=np.float64)) / scale
    d_home = np.linalg.norm(x - h, axis=1)
    for c in range(n_comp):
        members = np.flatnonzero(label == c)
        root = int(members[np.argmin(d_home[members])])
        order, pred = breadth_first_order(g, root, directed=False, return_predecessors=True)
        for node in order[1:]:
            level[node] = level[pred[node]] + 1
            parent[node] = pred[node]
    # the nearest neighbour on an earlier level (the BFS predecessor is one of them or
    # a reverse neighbour)
    earlier = level[nb] < level[:, None]
    best = np.where(earlier, dist, np.inf)
    j = np.argmin(best, axis=1)
    has = np.isfinite(best[np.arange(m), j])
    parent = np.where(has, nb[np.arange(m), j], parent)
    return parent, level


PREDICTOR_CAP = 0.25
"""Largest first-order predictor step [rad | m] of the dependent joints; beyond it (a parent near
a singularity, where dq_w/dq_v blows up) the closure starts from the parent's own q_w."""


def _sensitivity_and_mode(mech: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dq_w/dq_v (m, n_w, n_v) and the assembly-mode label sign(det dphi/dq_w) (m,) (0 when
    dphi/dq_w is not square)."""
    from mechkin.model.kinematics import closure_jacobian, forward_kinematics

    _, J = closure_jacobian(mech, forward_kinematics(mech, q))
    Jw, Jv = J[:, :, mech.dependent], J[:, :, mech.independent]
    S = -np.linalg.pinv(Jw) @ Jv
    sign = np.sign(np.linalg.det(Jw)) if Jw.shape[1] == Jw.shape[2] else np.zeros(q.shape[0])
    return S, sign.astype(np.int8)


def _close_rows(mech: Any, qv: np.ndarray, parent: np.ndarray, level: np.ndarray,
                todo: np.ndarray, st: dict[str, np.ndarray], chunk: int, mode_jump: float,
                tick: Callable[[int], None] | None = None) -> None:
    """Close the loops of rows ``todo`` level by level, each from its parent's solution (the
    rows of ``st``: ``q``, ``status``, ``ok``, ``S``, ``mode``, ``mode_change``, ``reseeded``,
    filled in place; parents outside ``todo`` must be solved already).

    Every row's Newton run, reseed, sensitivity and mode test depend on that row and its
    parent only (:func:`mechkin.model.closure.solve_closure` freezes converged rows), so
    the rows may be solved in any grouping of one level: a job solving a subtree gives the
    same bits as the whole sweep in one process.
    """
    from mechkin.model.closure import ClosureStatus, solve_closure
    from mechkin.model.continuation import closure_from_home

    if todo.size == 0:
        return
    q, status, ok, S, mode = st["q"], st["status"], st["ok"], st["S"], st["mode"]
    dep = mech.dependent
    q_w0 = mech.home[dep]
    conv_val = ClosureStatus.CONVERGED.value
    order = todo[np.argsort(level[todo], kind="stable")]
    bounds = np.flatnonzero(np.diff(level[order])) + 1
    for lev in np.split(order, bounds):
        for a in range(0, lev.size, chunk):
            idx = lev[a : a + chunk]
            p = parent[idx]
            use = (p >= 0) & ok[np.maximum(p, 0)]
            guess = np.tile(q_w0, (idx.size, 1))
            pred_step = np.zeros(idx.size)
            if use.any():
                pu = p[use]
                dw = np.einsum("kij,kj->ki", S[pu], qv[idx[use]] - qv[pu])
                big = np.abs(dw).max(axis=1) > PREDICTOR_CAP
                dw[big] = 0.0
                guess[use] = q[pu][:, dep] + dw
                pred_step[use] = np.abs(dw).max(axis=1)  # 0 where capped: no jump test
            res = solve_closure(mech, qv[idx], guess)
            stv = np.array([x.value for x in res.status], dtype=object)
            qq = res.q
            if (~use).any():  # no solved neighbour: continuation from the home assembly
                r0 = closure_from_home(mech, qv[idx[~use]])
                qq[~use] = r0.q
                stv[~use] = [x.value for x in r0.status]
            bad = (stv != conv_val) & use
            if bad.any():  # the neighbour's branch did not close: continue from home
                r2 = closure_from_home(mech, qv[idx[bad]])
                good = np.array([x.value == conv_val for x in r2.status], dtype=bool)
                bi = np.flatnonzero(bad)[good]
                qq[bi] = r2.q[good]
                stv[bi] = conv_val
                st["reseeded"][idx[bi]] = True
            q[idx] = qq
            status[idx] = stv
            done = stv == conv_val
            ok[idx] = done
            if done.any():
                S[idx[done]], mode[idx[done]] = _sensitivity_and_mode(mech, qq[done])
            chk = use & done
            if chk.any():
                pc, ic = p[chk], idx[chk]
                err = np.abs(qq[chk][:, dep] - guess[chk]).max(axis=1)
                ps = pred_step[chk]
                jump = (ps > 0) & (err > mode_jump * ps)
                flip = mode[ic] != mode[pc]
                st["mode_change"][ic] = flip | jump
                # the orientation flipped while the joints followed the predictor: a constraint
                # singularity (change point) crossed on one smooth branch
                st["crossed"][ic] = flip & (ps > 0) & ~jump & (mode[ic] != 0) & (mode[pc] != 0)
            if tick is not None:
                tick(idx.size)


def _evaluate_rows(mech: Any, qv: np.ndarray, frame: int, rows: slice, closed: bool,
                   two_phase: bool, manipulability: bool, st: dict[str, np.ndarray]) -> None:
    """Positions and dexterity of the rows ``rows`` of ``st`` (in place); closed chains
    without continuation close their loops here, from home. Row by row independent."""
    from mechkin.model.closure import ClosureStatus, dependent_sensitivity
    from mechkin.model.continuation import closure_from_home
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian

    a, b = rows.start, rows.stop
    q, status = st["q"], st["status"]
    if closed and not two_phase:  # each sample by continuation from the home assembly
        res = closure_from_home(mech, qv[a:b])
        q[a:b] = res.q
        status[a:b] = [x.value for x in res.status]
    elif not closed:
        q[a:b] = mech.assemble(qv[a:b], np.zeros((b - a, 0)))
        status[a:b] = ClosureStatus.CONVERGED.value
    kin = forward_kinematics(mech, q[a:b])
    st["pos"][a:b] = kin.frames(mech, [frame])[:, 0, :3, 3]
    if manipulability:
        J = frame_jacobian(mech, kin, frame)
        Jr = J[:, :, mech.independent]
        if closed:
            sens = st["S"][a:b] if two_phase else dependent_sensitivity(mech, q[a:b])
            Jr = Jr + J[:, :, mech.dependent] @ sens
        st["J"][a:b] = Jr
        dex = dexterity(Jr)
        st["w"][a:b] = dex["manipulability"]
        st["iso"][a:b] = dex["isotropy"]
        st["iso_pos"][a:b] = dex["isotropy_position"]


def _state(mech: Any, m: int, manipulability: bool) -> dict[str, np.ndarray]:
    nv = len(mech.independent)
    return {"q": np.empty((m, mech.n)), "status": np.empty(m, dtype=object),
            "ok": np.zeros(m, dtype=bool), "S": np.zeros((m, len(mech.dependent), nv)),
            "mode": np.zeros(m, dtype=np.int8), "mode_change": np.zeros(m, dtype=bool),
            "crossed": np.zeros(m, dtype=bool), "reseeded": np.zeros(m, dtype=bool),
            "pos": np.empty((m, 3)),
            "w": np.zeros(m), "iso": np.zeros(m), "iso_pos": np.zeros(m),
            "J": np.zeros((m, 6, nv)) if manipulability else np.zeros((0, 6, nv))}


#: Per-row results of a closure job and of an evaluation job.
_CLOSE_KEYS = ("q", "status", "ok", "S", "mode", "mode_change", "crossed", "reseeded")
_EVAL_KEYS = ("q", "status", "pos", "w", "iso", "iso_pos", "J")


def sweep_job(job: dict[str, Any]) -> dict[str, np.ndarray]:
    """One job of a distributed joint sweep (module level, so it pickles).

    ``job["phase"]``: ``"close"``, the loop closure of whole continuation subtrees (local
    ``parent`` / ``level``; rows ``[0, n_ext)`` are the solved parents from outside the job,
    given by ``ext``); or ``"evaluate"``, positions and dexterity of consecutive blocks of
    ``chunk`` rows (those of one process: the forward kinematics of a batch takes another
    code path from :data:`mechkin.model.kinematics.LARGE_BATCH` rows on, so the blocks must
    be the same for the same bits), with ``q`` and ``S`` of the continuation given.
    """
    mech = job["mechanism"]
    if not hasattr(mech, "dependent"):
        from mechkin.solvers.workspace.sweeps import job_mechanism

        mech = job_mechanism(mech)
    qv = job["q_v"]
    k = qv.shape[0]
    st = _state(mech, k, job["manipulability"])
    if job["phase"] == "close":
        n_ext = int(job["n_ext"])
        for key, val in job["ext"].items():
            st[key][:n_ext] = val
        _close_rows(mech, qv, job["parent"], job["level"], np.arange(n_ext, k), st,
                    job["chunk"], job["mode_jump"])
        return {key: st[key][n_ext:] for key in _CLOSE_KEYS}
    for key in ("q", "S", "status"):
        if key in job:
            st[key][:] = job[key]
    for a in range(0, k, job["chunk"]):
        _evaluate_rows(mech, qv, job["frame"], slice(a, min(k, a + job["chunk"])),
                       job["closed"], job["two_phase"], job["manipulability"], st)
    return {key: st[key] for key in _EVAL_KEYS if key != "J" or job["manipulability"]}


def subtree_jobs(parent: np.ndarray, level: np.ndarray, target: int
                 ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Split a continuation tree into a trunk and jobs of whole subtrees.

    The **trunk** holds every sample whose subtree has more than ``target`` samples (closed
    under parents; solved first, in the calling process); the other samples form subtrees
    hanging from the trunk (or roots), packed in sample order into jobs of about ``target``
    samples. A job needs only the solutions of its subtrees' trunk parents.

    Returns
    -------
    trunk : ndarray of int
    jobs : list of ndarray of int
        The samples of each job (sorted).
    """
    m = parent.size
    size = np.ones(m, dtype=np.int64)
    for i in np.argsort(level, kind="stable")[::-1]:
        if parent[i] >= 0:
            size[parent[i]] += size[i]
    trunk_mask = size > target
    top = np.flatnonzero(~trunk_mask & ((parent < 0) | trunk_mask[np.maximum(parent, 0)]))
    # the top of each hanging subtree labels its samples (parents before children)
    label = np.full(m, -1, dtype=np.int64)
    label[top] = top
    for i in np.argsort(level, kind="stable"):
        if label[i] < 0 and not trunk_mask[i]:
            label[i] = label[parent[i]]
    jobs: list[np.ndarray] = []
    members = np.argsort(label, kind="stable")
    members = members[label[members] >= 0]
    groups = np.split(members, np.flatnonzero(np.diff(label[members])) + 1) if members.size \
        else []
    cur: list[np.ndarray] = []
    n = 0
    for g in groups:
        cur.append(g)
        n += g.size
        if n >= target:
            jobs.append(np.sort(np.concatenate(cur)))
            cur, n = [], 0
    if cur:
        jobs.append(np.sort(np.concatenate(cur)))
    return np.flatnonzero(trunk_mask), jobs


def joint_sweep(mech: Any, q_v: np.ndarray, frame: int, *, chunk: int = 2000,
                manipulability: bool = True, grid_shape: tuple[int, ...] | None = None,
                seed_from: str = "neighbour", mode_jump: float = 2.0,
                progress: Callable[[int, int], None] | None = None,
                length: float | None = None,
                run_jobs: Callable[..., list[Any]] | None = None,
                n_jobs: int = 8, mechanism: Any = None,
                stop: Callable[[], bool] | None = None) -> JointSweepRecord:
    r"""Positions, reachability and dexterity of ``frame`` at the samples ``q_v``.

    For a closed chain the loop closure of every sample starts from a solved neighbour
    (:func:`continuation_tree`), at the first-order predictor
    ``q_w^pred = q_w^p + (dq_w/dq_v)^p (q_v - q_v^p)`` of its parent ``p`` (kim1995 §5.1
    Step 1; the parent's own ``q_w`` when that step exceeds :data:`PREDICTOR_CAP`). With
    ``seed_from="home"`` every sample starts from the home configuration instead, which lets
    neighbouring samples land in different assembly modes without a word. A sample whose
    closure fails from its neighbour is retried from home (``reseeded``).

    A sample is flagged **mode_change** when, relative to its parent, the sign of
    ``det(dphi/dq_w)`` changes (the two lie on different sides of a singularity: different
    assembly modes; square closure Jacobians only), or the dependent joints jump away from
    the predictor by more than ``mode_jump`` times the predicted change,
    ``||q_w - q_w^pred||_inf > mode_jump ||q_w^pred - q_w^p||_inf`` (on one smooth branch the
    predictor error is O(step^2), below the O(step) predicted change; dependent-joint units on
    both sides; not tested where the predictor was capped). A sign change where the joints
    followed the predictor is also flagged **crossed**: one smooth branch through a constraint
    singularity (a change point, where two assembly modes meet).

    Parameters
    ----------
    mech : Mechanism
    q_v : array, shape (m, n_v)
        Independent joint values [rad | m].
    frame : int
        Frame index.
    chunk : int
        Samples per vectorized block.
    manipulability : bool
        Compute the dexterity (Yoshikawa manipulability, isotropy of the full Jacobian and of
        its position rows).
    grid_shape : tuple of int, optional
        The samples are a C-order grid of this shape (neighbours by grid step); None: scattered
        samples (neighbours by a KD-tree).
    seed_from : {"neighbour", "home"}
    mode_jump : float
        Threshold of the jump test (dimensionless ratio).
    progress : callable, optional
        ``progress(done, total)``: samples (closure blocks, then evaluation blocks); with
        ``run_jobs``, jobs (the trunk counts as one).
    length : float, optional
        Characteristic length [m] of the normalized isotropy
        (:func:`mechkin.solvers.workspace.dexterity.normalized_isotropy`); None: the one that best
        conditions the reachable samples
        (:func:`mechkin.solvers.workspace.dexterity.characteristic_length`).
        The Jacobians of all samples are kept for it (48 n_v bytes per sample).
    run_jobs : callable, optional
        ``run_jobs(fn, jobs, progress) -> results in job order`` (``progress(done, total)``
        or None) (e.g. :func:`mechkin.solvers.workspace.sweeps.
        run_jobs` on workers): the sweep runs as about ``n_jobs`` jobs of :func:`sweep_job`.
        Continuation: the trunk of the continuation tree here, then whole subtrees
        (:func:`subtree_jobs`) as closure jobs, each from its trunk parent's solution. Then
        (every kind of sweep) the positions and dexterity as jobs of whole ``chunk`` blocks,
        the blocks of one process. Every sample is solved from the same start, so the record
        is bitwise the same as in one process except that a closure job's level batches hold
        other samples than one process's: the forward kinematics of a batch switches code
        path at :data:`mechkin.model.kinematics.LARGE_BATCH` rows, so a Newton iterate may
        differ in the last bit (the tests' sweeps agree bitwise; a 700 x 700 five-bar grid:
        4e-16 in 439 of 490,000 samples, statuses and mode changes identical). Open chains
        and ``seed_from="home"``: bitwise.
    n_jobs : int
        Evaluation jobs to aim for with ``run_jobs`` (a quarter as many closure jobs).
    mechanism : MechanismSpec, optional
        What the jobs carry to rebuild ``mech`` on a worker (default: ``mech`` pickled).
    stop : callable, optional
        One process: ``stop()`` after every evaluated ``chunk``; when True the record holds
        the samples evaluated so far (a prefix of ``q_v``).

    Returns
    -------
    JointSweepRecord
        Dexterity is 0 at samples that are not reachable.
    """
    from mechkin.model.closure import ClosureStatus

    qv = np.asarray(q_v, dtype=np.float64)
    m = qv.shape[0]
    closed = mech.is_closed and len(mech.dependent) > 0
    two_phase = closed and seed_from == "neighbour"
    st = _state(mech, m, manipulability)
    parent = np.full(m, -1, dtype=np.int64)
    if two_phase:
        parent, level = continuation_tree(qv, grid_shape, mech.home[mech.independent])
    if run_jobs is not None and m > 0:
        _sweep_in_jobs(mech, qv, frame, st, parent, level if two_phase else None, closed,
                       two_phase, manipulability, chunk, mode_jump, progress, run_jobs,
                       n_jobs, mech if mechanism is None else mechanism)
    else:
        total = 2 * m if two_phase else m
        done_n = [0]

        def tick(n: int) -> None:
            done_n[0] += n
            if progress is not None:
                progress(done_n[0], total)

        if progress is not None:
            progress(0, total)
        if two_phase:
            _close_rows(mech, qv, parent, level, np.arange(m), st, chunk, mode_jump, tick)
        for a in range(0, m, chunk):
            b = min(m, a + chunk)
            _evaluate_rows(mech, qv, frame, slice(a, b), closed, two_phase, manipulability,
                           st)
            tick(b - a)
            if stop is not None and b < m and stop():  # the caller's --max-time
                st = {k: v[:b] for k, v in st.items()}
                qv, parent = qv[:b], parent[:b]
                break
    q, status, pos = st["q"], st["status"], st["pos"]
    w_full, iso_full, iso_pos, J_all = st["w"], st["iso"], st["iso_pos"], st["J"]
    converged = status == ClosureStatus.CONVERGED.value
    within = np.all((q >= mech.lower - 1e-9) & (q <= mech.upper + 1e-9), axis=1)
    finite = np.all(np.isfinite(pos), axis=1) & np.all(np.isfinite(q), axis=1)
    reach = converged & within & finite
    pos = np.where(np.isfinite(pos), pos, 0.0)
    q = np.where(np.isfinite(q), q, 0.0)
    for arr in (w_full, iso_full, iso_pos):
        arr[~reach] = 0.0  # not a pose of the mechanism: reported 0, marked by reachable = 0
    dex_out: dict[str, Any] = {}
    if manipulability:
        prismatic = mech.s[mech.independent] == 1
        L = float(length) if length is not None else characteristic_length(
            J_all[reach], prismatic, bounds=length_bounds(mech))
        iso_n = np.where(reach, normalized_isotropy(J_all, L, prismatic), 0.0)
        dex_out = {"manipulability": w_full, "isotropy": iso_full, "isotropy_position": iso_pos,
                   "isotropy_normalized": iso_n, "characteristic_length": L}
    return JointSweepRecord(q_v=qv, q=q, position=pos, status=status, converged=converged,
                            within_limits=within, reachable=reach, seed=parent,
                            mode_change=st["mode_change"], reseeded=st["reseeded"],
                            crossed=st["crossed"], **dex_out)


def _sweep_in_jobs(mech: Any, qv: np.ndarray, frame: int, st: dict[str, np.ndarray],
                   parent: np.ndarray, level: np.ndarray | None, closed: bool, two_phase: bool,
                   manipulability: bool, chunk: int, mode_jump: float,
                   progress: Callable[[int, int], None] | None,
                   run_jobs: Callable[..., list[Any]], n_jobs: int, carried: Any) -> None:
    """The sweep as jobs (see :func:`joint_sweep`), results written into ``st``: with
    continuation, the trunk here and the subtrees as closure jobs; then the evaluation as
    jobs of whole ``chunk`` blocks."""
    m = qv.shape[0]
    n_jobs = max(1, int(n_jobs))
    base = {"mechanism": carried, "frame": frame, "manipulability": manipulability,
            "closed": closed, "two_phase": two_phase, "chunk": chunk, "mode_jump": mode_jump}
    blocks = -(-m // chunk)
    per = -(-blocks // n_jobs) * chunk
    ranges = [np.arange(a, min(m, a + per)) for a in range(0, m, per)]
    close_rows: list[np.ndarray] = []
    close_jobs: list[dict[str, Any]] = []
    if two_phase:
        assert level is not None
        # a quarter of the jobs for the closure: a subtree job solves its levels in
        # batches of its own samples only, so fewer, larger jobs keep them vectorized
        trunk, close_rows = subtree_jobs(parent, level,
                                         max(1, -(-m // max(1, n_jobs // 4))))
        for r in close_rows:
            ext = np.unique(parent[r][(parent[r] >= 0) & ~np.isin(parent[r], r)])
            loc = np.concatenate([ext, r])
            where = {int(g): i for i, g in enumerate(loc)}
            lp = np.array([where.get(int(x), -1) if x >= 0 else -1 for x in parent[loc]],
                          dtype=np.int64)
            lp[: ext.size] = -1
            close_jobs.append({**base, "phase": "close", "q_v": qv[loc], "parent": lp,
                               "level": level[loc], "n_ext": ext.size, "ext": None,
                               "ext_rows": ext})
    total = len(close_jobs) + len(ranges) + int(two_phase)
    done = [0]

    def prog(k: int, _n: int, base_done: int) -> None:
        if progress is not None:
            progress(base_done + k, total)

    if progress is not None:
        progress(0, total)
    if two_phase:
        _close_rows(mech, qv, parent, level, trunk, st, chunk, mode_jump)
        done[0] = 1
        prog(0, 0, done[0])
        for job in close_jobs:  # the trunk parents' solutions, now known
            ext = job.pop("ext_rows")
            job["ext"] = {k: st[k][ext] for k in ("q", "status", "ok", "S", "mode")}
        parts = run_jobs(sweep_job, close_jobs,
                         lambda k, n: prog(k, n, done[0]) if progress is not None else None)
        done[0] += len(close_jobs)
        for r, out in zip(close_rows, parts, strict=True):
            for k, v in out.items():
                st[k][r] = v
    eval_jobs = []
    for r in ranges:
        job = {**base, "phase": "evaluate", "q_v": qv[r]}
        if two_phase:
            job.update(q=st["q"][r], S=st["S"][r], status=st["status"][r])
        eval_jobs.append(job)
    parts = run_jobs(sweep_job, eval_jobs,
                     lambda k, n: prog(k, n, done[0]) if progress is not None else None)
    for r, out in zip(ranges, parts, strict=True):
        for k, v in out.items():
            st[k][r] = v


def point_cloud_volume(P: np.ndarray, voxel: float | None = None
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Bounding box and volumes of a point cloud ``P`` (k, 3) [m].

    Parameters
    ----------
    P : array, shape (k, 3)
    voxel : float, optional
        Voxel edge [m]; default: the largest bounding-box side / 40 (at least 1e-6 m).

    Returns
    -------
    bbox : dict
        ``min_m``, ``max_m``, ``size_m`` ({} for an empty cloud).
    volume : dict
        ``voxel_m3`` (occupied cubes x edge^3), ``voxel_edge_m``, ``occupied_voxels``,
        ``convex_hull_m3`` (0 for degenerate, e.g. planar, clouds).
    """
    volume: dict[str, Any] = {"voxel_m3": 0.0, "voxel_edge_m": None, "convex_hull_m3": 0.0}
    bbox: dict[str, Any] = {}
    if not P.shape[0]:
        return bbox, volume
    lo, hi = P.min(axis=0), P.max(axis=0)
    bbox = {"min_m": lo.tolist(), "max_m": hi.tolist(), "size_m": (hi - lo).tolist()}
    edge = voxel if voxel is not None else max(float((hi - lo).max()) / 40.0, 1e-6)
    cells = np.unique(np.floor((P - lo) / edge).astype(np.int64), axis=0)
    volume = {"voxel_m3": float(cells.shape[0] * edge**3), "voxel_edge_m": edge,
              "occupied_voxels": int(cells.shape[0]), "convex_hull_m3": 0.0}
    try:
        from scipy.spatial import ConvexHull

        if P.shape[0] >= 4:
            volume["convex_hull_m3"] = float(ConvexHull(P).volume)
    except Exception:  # noqa: BLE001 - degenerate (planar) clouds have no hull volume
        volume["convex_hull_m3"] = 0.0
    return bbox, volume

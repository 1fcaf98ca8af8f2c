"""Path plans of :func:`mechkin.model.kinematics.frame_poses`: the joints on the paths from the
base to a set of frames, with the constants folded (``C = B_parent A_child``), and the routes
that evaluate a plan: one configuration as a straight-line function generated per plan (plain
Python floats), a few as batched 4x4 products, many block by block in a column-major layout
(``PLAN_BLOCK`` configurations, below OpenBLAS's threading threshold), and the compiled kernel
of :mod:`mechkin.model.fk_jit` on a plan's packed array. All routes agree to round-off; the
plain-Python and compiled single-configuration routes bit for bit
(tests/model/test_fast_fk.py, tests/model/test_fk_routes.py).

Design
------
Part of :mod:`mechkin.model`; imports numpy and :mod:`mechkin.model.mechanism` only. The public
entry points are in :mod:`mechkin.model.kinematics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism

# Z(q) = c*ZC + s*ZS + ZK (revolute, about z) or ZD*q + I (prismatic, along z)
_ZC = np.diag([1.0, 1.0, 0.0, 0.0])
_ZS = np.zeros((4, 4))
_ZS[0, 1], _ZS[1, 0] = -1.0, 1.0
_ZK = np.diag([0.0, 0.0, 1.0, 1.0])
_ZD = np.zeros((4, 4))
_ZD[2, 3] = 1.0


def _plan_compiled(kern, plan: _PathPlan, qs: np.ndarray) -> np.ndarray:
    """The compiled route on a float64 (m, n) array of any layout (copied to C order)."""
    fl = qs.flags
    if not (fl.c_contiguous and fl.writeable and fl.aligned):
        qs = np.array(qs, dtype=np.float64, order="C")
    out = np.empty((qs.shape[0], plan.k, 4, 4))
    kern(qs, plan.jit, out)
    return out


_F64 = np.dtype(np.float64)

#: From this batch size on, :func:`frame_poses` composes column by column (structure of
#: arrays) instead of with batched 4x4 products.
PLAN_LARGE_BATCH = 128


@dataclass(frozen=True)
class _PathPlan:
    """The joints on the base-to-frame paths of one frame set, with folded constants.

    With ``X_i = T_parent @ A_i @ Z(q_i)`` (the pose before ``B_i``), a child joint continues
    from its parent joint's ``X`` through ``C = B_parent @ A_child`` and a frame on the child
    link of joint i is ``X_i @ (B_i @ offset)`` (kim1995 Eq. (2), constants folded).
    """

    joints: np.ndarray  # (p,) path joints in tree order
    parent: tuple[int, ...]  # per path joint, the step of its parent joint (-1: the base)
    C: np.ndarray  # (p, 4, 4) constant before Z(q)
    rev: np.ndarray  # (p,) bool
    all_rev: bool
    factors: np.ndarray  # (p, nf, 16): C Z(q) = sum_k coef_k factors_k (1, c, s[, d])
    frame_step: tuple[int, ...]  # per frame, the step whose X it continues (-1: the base)
    E: np.ndarray  # (k, 4, 4) constant after X
    last_use: tuple[int, ...]  # per step, the last step (or frame output p) that reads it
    steps: tuple  # per step (joint, revolute, parent step, top 3 rows of C) as Python floats
    frames_py: tuple  # per frame (step, top 3 rows of E) as Python floats
    n: int  # joints of the mechanism (the width of qs)
    k: int  # frames
    jit: np.ndarray  # (p + k, 16): the compiled kernel's plan (mechkin.model.fk_jit)
    shape1: tuple[int, int, int, int]  # (1, k, 4, 4): the output of one configuration

    def __getstate__(self) -> dict:
        """Pickled without the generated single-configuration function (made again on first
        use: mechanisms travel to distributed workers with their cached plans)."""
        state = dict(self.__dict__)
        state.pop("_one", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)


def _path_plan(mech: Mechanism, fi: np.ndarray, key: object = None) -> _PathPlan:
    """The path plan of frames ``fi``, computed once per mechanism and frame set (``key``)."""
    cache = mech.__dict__.get("_fk_plans")
    if cache is None:
        cache = {}
        object.__setattr__(mech, "_fk_plans", cache)
    if key is None:
        key = tuple(fi.tolist())
    plan = cache.get(key)
    if plan is not None:
        return plan
    fi = np.arange(len(mech.frame_names))[fi]  # negative indices as numpy reads them
    links = mech.frame_link[fi]
    need = mech.link_ancestors[links].any(axis=0) if len(fi) else np.zeros(mech.n, bool)
    order = np.concatenate(mech.levels) if mech.levels else np.zeros(0, int)
    joints = np.array([j for j in order if need[j]], dtype=int)
    step_of_link = {int(mech.joint_child_link[j]): i for i, j in enumerate(joints)}
    parent = tuple(step_of_link.get(int(mech.joint_parent_link[j]), -1) for j in joints)
    eye = np.eye(4)
    C = np.array([(mech.B[joints[pi]] if pi >= 0 else eye) @ mech.A[j]
                  for j, pi in zip(joints, parent, strict=True)]).reshape(-1, 4, 4)
    rev = mech.s[joints] == 0
    fz = np.stack([np.where(rev[:, None, None], C @ _ZK, C),
                   np.where(rev[:, None, None], C @ _ZC, 0.0),
                   np.where(rev[:, None, None], C @ _ZS, 0.0),
                   np.where(rev[:, None, None], 0.0, C @ _ZD)], axis=1).reshape(-1, 4, 16)
    all_rev = bool(rev.all())
    factors = np.ascontiguousarray(fz[:, :3] if all_rev else fz)
    frame_step = tuple(step_of_link.get(int(li), -1) for li in links)
    E = np.array([(mech.B[joints[st]] if st >= 0 else eye) @ mech.frame_offset[f]
                  for f, st in zip(fi, frame_step, strict=True)]).reshape(-1, 4, 4)
    p = len(joints)
    last = [-1] * p
    for i, pi in enumerate(parent):
        if pi >= 0:
            last[pi] = i
    for st in frame_step:
        if st >= 0:
            last[st] = p
    steps = tuple((int(j), bool(r), int(pi), tuple(tuple(row) for row in c[:3].tolist()))
                  for j, r, pi, c in zip(joints, rev, parent, C, strict=True))
    frames_py = tuple((st, tuple(tuple(row) for row in e[:3].tolist()))
                      for st, e in zip(frame_step, E, strict=True))
    k = len(frame_step)
    jit = np.zeros((p + k, 16))
    jit[:, :12] = np.concatenate([C[:, :3], E[:, :3]]).reshape(p + k, 12)
    jit[:p, 12], jit[:p, 13], jit[:p, 14] = joints, rev, parent
    jit[p:, 12] = frame_step
    plan = _PathPlan(joints, parent, C, rev, all_rev, factors, frame_step, E, tuple(last),
                     steps, frames_py, mech.n, k, jit, (1, k, 4, 4))
    if len(cache) < 64:
        cache[key] = plan
    return plan


def _mul34(X: tuple, Y: tuple) -> tuple:
    """Product of two affine transforms given by their top 3 rows (tuples of floats)."""
    (a0, a1, a2, a3), (b0, b1, b2, b3), (c0, c1, c2, c3) = X
    (y00, y01, y02, y03), (y10, y11, y12, y13), (y20, y21, y22, y23) = Y
    return ((a0 * y00 + a1 * y10 + a2 * y20, a0 * y01 + a1 * y11 + a2 * y21,
             a0 * y02 + a1 * y12 + a2 * y22, a0 * y03 + a1 * y13 + a2 * y23 + a3),
            (b0 * y00 + b1 * y10 + b2 * y20, b0 * y01 + b1 * y11 + b2 * y21,
             b0 * y02 + b1 * y12 + b2 * y22, b0 * y03 + b1 * y13 + b2 * y23 + b3),
            (c0 * y00 + c1 * y10 + c2 * y20, c0 * y01 + c1 * y11 + c2 * y21,
             c0 * y02 + c1 * y12 + c2 * y22, c0 * y03 + c1 * y13 + c2 * y23 + c3))


_LAST_ROW = (0.0, 0.0, 0.0, 1.0)


def _plan_one(plan: _PathPlan, q: np.ndarray) -> np.ndarray:
    """One configuration in plain Python floats (faster than numpy on 4x4 matrices,
    measured): ``C Z(q)`` mixes C's first two columns (revolute) or shifts its last one by
    q times the third (prismatic), then 3x4 affine products along the path."""
    ql = q.tolist()
    X: list = [None] * len(plan.steps)
    cos, sin, mul = math.cos, math.sin, _mul34
    for i, (j, rev, pi, C) in enumerate(plan.steps):
        v = ql[j]
        (a0, a1, a2, a3), (b0, b1, b2, b3), (c0, c1, c2, c3) = C
        if rev:
            c, s = cos(v), sin(v)
            L = ((a0 * c + a1 * s, a1 * c - a0 * s, a2, a3),
                 (b0 * c + b1 * s, b1 * c - b0 * s, b2, b3),
                 (c0 * c + c1 * s, c1 * c - c0 * s, c2, c3))
        else:
            L = ((a0, a1, a2, a3 + a2 * v), (b0, b1, b2, b3 + b2 * v), (c0, c1, c2, c3 + c2 * v))
        X[i] = L if pi < 0 else mul(X[pi], L)
    flat: list = []
    for st, E in plan.frames_py:
        r0, r1, r2 = mul(X[st], E) if st >= 0 else E
        flat += r0
        flat += r1
        flat += r2
        flat += _LAST_ROW
    return np.array(flat).reshape(1, len(plan.frames_py), 4, 4)


def _term(a, b):
    """The product a * b of two entries (a float constant or a variable name) for generated
    code: exact zeros drop (None), ones pass the other through, constants fold (the same IEEE
    product as at run time)."""
    if isinstance(a, float) and isinstance(b, float):
        return a * b
    if isinstance(b, float):
        a, b = b, a
    if isinstance(a, float):
        if a == 0.0:
            return None
        if a == 1.0:
            return b
        if a == -1.0:
            return f"-{b}"
        return f"{a!r} * {b}"
    return f"{a} * {b}"


def _sum(terms: list, lines: list[str], name: str):
    """Entry ``name`` = the sum of ``terms`` in their order (None: an exact zero, dropped):
    a float constant, a variable name, or a new variable assigned in ``lines``."""
    kept = [t for t in terms if t is not None and not (isinstance(t, float) and t == 0.0)]
    if not kept:
        return 0.0
    if len(kept) == 1 and isinstance(kept[0], float):
        return kept[0]
    if len(kept) == 1 and kept[0].isidentifier():
        return kept[0]
    if all(isinstance(t, float) for t in kept):
        acc = kept[0]
        for t in kept[1:]:
            acc = acc + t
        return acc
    lines.append(f"    {name} = " + " + ".join(t if isinstance(t, str) else repr(t)
                                              for t in kept))
    return name


def _one_function(plan: _PathPlan):
    """Straight-line Python for one configuration of ``plan`` (generated once per plan): the
    products of :func:`_plan_one` in the same order, with C's and E's exact zeros and ones
    folded (D-H constants are mostly 0 and +-1), so the result equals :func:`_plan_one`'s
    (up to the sign of zeros) at a fraction of the cost."""
    lines: list[str] = []
    X: list = []
    for i, (j, rev, pi, C) in enumerate(plan.steps):
        L = [[C[t][b] for b in range(4)] for t in range(3)]
        if rev:
            lines.append(f"    c{i} = cos(q[{j}])")
            lines.append(f"    s{i} = sin(q[{j}])")
            for t in range(3):
                a0, a1 = C[t][0], C[t][1]
                L[t][0] = _sum([_term(a0, f"c{i}"), _term(a1, f"s{i}")], lines, f"l{i}_{t}0")
                L[t][1] = _sum([_term(a1, f"c{i}"), _term(-a0, f"s{i}")], lines, f"l{i}_{t}1")
        else:
            lines.append(f"    d{i} = q[{j}]")
            for t in range(3):
                L[t][3] = _sum([C[t][3], _term(C[t][2], f"d{i}")], lines, f"l{i}_{t}3")
        if pi < 0:
            X.append(L)
            continue
        P = X[pi]
        Xi = [[_sum([_term(P[a][t], L[t][b]) for t in range(3)] + ([P[a][3]] if b == 3 else []),
                    lines, f"x{i}_{a}{b}") for b in range(4)] for a in range(3)]
        X.append(Xi)
    out = []
    for f, (st, E) in enumerate(plan.frames_py):
        if st < 0:
            rows = [list(r) for r in E]
        else:
            P = X[st]
            rows = [[_sum([_term(P[a][t], E[t][b]) for t in range(3)]
                          + ([P[a][3]] if b == 3 else []), lines, f"e{f}_{a}{b}")
                     for b in range(4)] for a in range(3)]
        for r in rows:
            out += [v if isinstance(v, str) else repr(v) for v in r]
        out += ["0.0", "0.0", "0.0", "1.0"]
    src = ("def one(q):\n" + "\n".join(lines) + ("\n" if lines else "")
           + f"    return array([{', '.join(out)}]).reshape(1, {len(plan.frames_py)}, 4, 4)\n")
    env = {"cos": math.cos, "sin": math.sin, "array": np.array}
    exec(compile(src, f"<mechkin path plan, {len(plan.steps)} joints>", "exec"), env)  # noqa: S102
    return env["one"]


def _plan_one_fast(plan: _PathPlan, q: np.ndarray) -> np.ndarray:
    """One configuration through the plan's generated function (made on first use)."""
    fn = plan.__dict__.get("_one")
    if fn is None:
        fn = _one_function(plan)
        object.__setattr__(plan, "_one", fn)
    return fn(q.tolist())


def _plan_small(plan: _PathPlan, qs: np.ndarray) -> np.ndarray:
    """Few configurations: every path joint's ``C Z(q)`` in one product, then 4x4 products."""
    m = qs.shape[0]
    p = len(plan.joints)
    k = len(plan.frame_step)
    q = qs[:, plan.joints]
    if plan.all_rev:
        W = np.empty((m, p, 1, 3))
        W[..., 0, 0] = 1.0
        np.cos(q, out=W[..., 0, 1])
        np.sin(q, out=W[..., 0, 2])
    else:
        W = np.zeros((m, p, 1, 4))
        W[..., 0, 0] = 1.0
        r = plan.rev
        W[:, r, 0, 1] = np.cos(q[:, r])
        W[:, r, 0, 2] = np.sin(q[:, r])
        W[:, ~r, 0, 3] = q[:, ~r]
    L = np.matmul(W, plan.factors).reshape(m, p, 4, 4)
    X: list[np.ndarray | None] = [None] * p
    for i, pi in enumerate(plan.parent):
        X[i] = L[:, i] if pi < 0 else X[pi] @ L[:, i]
    out = np.empty((m, k, 4, 4))
    for f, st in enumerate(plan.frame_step):
        if st < 0:
            out[:, f] = plan.E[f]
        else:
            np.matmul(X[st], plan.E[f], out=out[:, f])
    return out


def _times_const(X: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Column-major affine product: X (4, 3, m) the columns of the top 3 rows of a pose stack,
    C (4, 4) an affine constant -> the columns of X @ C, (4, 3, m).

    Column c of X @ C is sum_k C[k, c] X[k] (C[3] = (0, 0, 0, 1) passes the translation
    through), i.e. C^T @ X.reshape(4, 3m): one wide (4 x 4) @ (4 x 3m) product, faster than
    the (4m x 4) @ (4 x 4) GEMMs of the tree FK or column by column (measured).
    """
    return (C.T @ X.reshape(4, -1)).reshape(X.shape)


#: Configurations per block of :func:`_plan_large`: the block's poses stay in cache, and each
#: constant's (4 x 4) @ (4 x 3 block) product stays below OpenBLAS's threading threshold
#: (m n k <= 2 * 65536 * 4, i.e. block <= 10922: thread-pool GEMMs on these products were 2-5x
#: slower on two cores, measured), so no BLAS threads are started.
PLAN_BLOCK = 8192


def _plan_large(plan: _PathPlan, qs: np.ndarray, link_major: bool = False) -> np.ndarray:
    """Many configurations, block by block: poses kept column-major ((4, 3, b): column, row,
    sample), Z(q) mixes two columns (revolute) or shifts one (prismatic), constants are one
    wide product each; a step's pose is dropped once its last child has read it. Memory
    beyond the result: a few blocks of poses (the joint values, cosines and sines too are
    taken block by block, so the cost stays linear in m)."""
    m = qs.shape[0]
    k = len(plan.frame_step)
    store = np.empty((k, m, 4, 4) if link_major else (m, k, 4, 4))
    out = np.moveaxis(store, 0, 1) if link_major else store  # (m, k, 4, 4) either way
    eye = np.eye(4)
    E_id = [bool(np.array_equal(E, eye)) for E in plan.E]
    rev = plan.rev
    cols = plan.joints
    for a in range(0, m, PLAN_BLOCK):
        b = min(m, a + PLAN_BLOCK)
        ob = out[a:b]
        ob[:, :, 3, :3] = 0.0
        ob[:, :, 3, 3] = 1.0
        qT = qs[a:b, cols].T  # (p, b)
        cT = np.cos(qT)
        sT = np.sin(qT)
        X: list[np.ndarray | None] = [None] * len(plan.joints)
        for i, pi in enumerate(plan.parent):
            if pi < 0:
                Y = np.empty((4, 3, b - a))
                Y[:] = plan.C[i][:3].T[:, :, None]
            else:
                Y = _times_const(X[pi], plan.C[i])
                if plan.last_use[pi] == i:
                    X[pi] = None
            if rev[i]:
                c, s = cT[i], sT[i]
                y0 = Y[0] * c
                y0 += Y[1] * s
                Y[1] *= c
                Y[1] -= Y[0] * s
                Y[0] = y0
            else:
                Y[3] += Y[2] * qT[i]
            X[i] = Y
        for f, st in enumerate(plan.frame_step):
            if st >= 0:
                Y = X[st] if E_id[f] else _times_const(X[st], plan.E[f])
                ob[:, f, :3, :] = np.moveaxis(Y, (0, 1), (2, 1))
            else:
                ob[:, f] = plan.E[f]
    return out

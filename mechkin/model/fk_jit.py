r"""Compiled path-plan forward kinematics (optional accelerator, needs ``numba``).

One kernel, :func:`plan_poses`, evaluates a :class:`mechkin.model.kinematics._PathPlan` for m
configurations: per configuration and path joint ``X_i = X_parent C_i Z(q_i)`` as 3x4 affine
products (kim1995 Eq. (2), constants folded as in the plan), then each requested frame
``X_step E_f``. The operations are those of the plain-Python route
(:func:`mechkin.model.kinematics._plan_one`) in the same order, so both agree to round-off
(tests/model/test_fast_fk.py checks 1e-12 against the tree FK).

The plan comes in as two arrays (few arguments keep numba's dispatch cheap, about 0.3 us):
``steps`` (p + k, 3) int64, per path joint (joint index, 1 revolute / 0 prismatic, parent
step or -1) then per frame (step or -1, 0, 0); ``consts`` (p + k, 3, 4), the top rows of each
``C_i`` then of each ``E_f``. The output ``out`` (m, k, 4, 4) is allocated by the caller.

Importing this module imports numba (about 0.5 s); :mod:`mechkin.model.fk_accel` decides when
that pays and picks the cache folder before numba is imported. ``cache=True``: compiled once
per machine (``mechkin warmup`` can do it ahead, :func:`mechkin.model.fk_accel.warm`).

Design
------
Part of :mod:`mechkin.model`. Imports numpy, numba and :mod:`mechkin.model.fk_accel`; never
``solvers/``, ``io/``, ``cli/`` or ``tasks/``.
"""

from __future__ import annotations

from mechkin.model.fk_accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR (a read-only install: user cache)

import numba  # noqa: E402
import numpy as np  # noqa: E402

#: The one signature (other argument types raise TypeError instead of compiling anew; the
#: caller then normalises them): qs (m, n), steps, consts, out, all C-ordered and writable.
SIGNATURE = "void(float64[:, ::1], int64[:, ::1], float64[:, :, ::1], float64[:, :, :, ::1])"


@numba.njit(SIGNATURE, cache=True, nogil=True)
def plan_poses(qs, steps, consts, out):  # pragma: no cover - compiled (tests run it compiled)
    """Poses out (m, k, 4, 4) of the plan's k frames for configurations qs (m, n)."""
    m = qs.shape[0]
    k = out.shape[1]
    p = steps.shape[0] - k
    X = np.empty((max(p, 1), 3, 4))
    for r in range(m):
        for i in range(p):
            v = qs[r, steps[i, 0]]
            pi = steps[i, 2]
            C = consts[i]
            # L = C Z(q): revolute mixes C's first two columns, prismatic shifts the last one
            if steps[i, 1] != 0:
                c = np.cos(v)
                s = np.sin(v)
                l00 = C[0, 0] * c + C[0, 1] * s
                l01 = C[0, 1] * c - C[0, 0] * s
                l10 = C[1, 0] * c + C[1, 1] * s
                l11 = C[1, 1] * c - C[1, 0] * s
                l20 = C[2, 0] * c + C[2, 1] * s
                l21 = C[2, 1] * c - C[2, 0] * s
                l03, l13, l23 = C[0, 3], C[1, 3], C[2, 3]
            else:
                l00, l01, l10, l11, l20, l21 = C[0, 0], C[0, 1], C[1, 0], C[1, 1], C[2, 0], C[2, 1]
                l03 = C[0, 3] + C[0, 2] * v
                l13 = C[1, 3] + C[1, 2] * v
                l23 = C[2, 3] + C[2, 2] * v
            l02, l12, l22 = C[0, 2], C[1, 2], C[2, 2]
            if pi < 0:
                X[i, 0, 0], X[i, 0, 1], X[i, 0, 2], X[i, 0, 3] = l00, l01, l02, l03
                X[i, 1, 0], X[i, 1, 1], X[i, 1, 2], X[i, 1, 3] = l10, l11, l12, l13
                X[i, 2, 0], X[i, 2, 1], X[i, 2, 2], X[i, 2, 3] = l20, l21, l22, l23
            else:
                for a in range(3):
                    a0 = X[pi, a, 0]
                    a1 = X[pi, a, 1]
                    a2 = X[pi, a, 2]
                    a3 = X[pi, a, 3]
                    X[i, a, 0] = a0 * l00 + a1 * l10 + a2 * l20
                    X[i, a, 1] = a0 * l01 + a1 * l11 + a2 * l21
                    X[i, a, 2] = a0 * l02 + a1 * l12 + a2 * l22
                    X[i, a, 3] = a0 * l03 + a1 * l13 + a2 * l23 + a3
        for f in range(k):
            st = steps[p + f, 0]
            E = consts[p + f]
            for a in range(3):
                if st < 0:
                    for b in range(4):
                        out[r, f, a, b] = E[a, b]
                else:
                    a0 = X[st, a, 0]
                    a1 = X[st, a, 1]
                    a2 = X[st, a, 2]
                    a3 = X[st, a, 3]
                    for b in range(3):
                        out[r, f, a, b] = a0 * E[0, b] + a1 * E[1, b] + a2 * E[2, b]
                    out[r, f, a, 3] = a0 * E[0, 3] + a1 * E[1, 3] + a2 * E[2, 3] + a3
            out[r, f, 3, 0] = 0.0
            out[r, f, 3, 1] = 0.0
            out[r, f, 3, 2] = 0.0
            out[r, f, 3, 3] = 1.0

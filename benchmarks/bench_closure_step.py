"""Per-step cost of the closed-chain Newton step and of one numpy IK evaluation (issue 15.2).

    python benchmarks/bench_closure_step.py [rounds]

kim1995 Stewart platform and direct-drive arm, one configuration near home (legs / motors
moved by 0.01): ``solve_closure`` alone, and the numpy lm evaluation
(:func:`mechkin.solvers.ik.kernel.evaluate`) as it is (the closure's last iterate reused) and
as before (forward kinematics and closure Jacobian recomputed at the solution). Interleaved
rounds, medians, CPU time per call.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.closure import solve_closure  # noqa: E402
from mechkin.model.kinematics import closure_jacobian  # noqa: E402
from mechkin.solvers.ik.kernel import TOL_DQ_CLOSURE, evaluate, kernel_for  # noqa: E402


def old_evaluate(kern, qv, qw, T):
    """evaluate() before the reuse: FK and the closure Jacobian again at the solution."""
    res = solve_closure(kern.mech, qv, qw, tol_phi=1e-12, tol_dq=TOL_DQ_CLOSURE, max_iter=30)
    kin = kern.kinematics(res.q)
    x, Jq = kern.residual_jacobian(kin, T, "euler")
    _, Phi = closure_jacobian(kern.mech, kin)
    Pw, Pv = Phi[:, :, kern.iw], Phi[:, :, kern.iv]
    S = np.linalg.solve(np.swapaxes(Pw, 1, 2) @ Pw, np.swapaxes(Pw, 1, 2) @ Pv)
    return x, Jq[:, :, kern.iv] - Jq[:, :, kern.iw] @ S


def per_call(fn, n: int) -> float:
    t0 = time.process_time()
    for _ in range(n):
        fn()
    return (time.process_time() - t0) / n


def main() -> None:
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    for name in ("kim1995_stewart", "kim1995_direct_drive"):
        mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
        kern = kernel_for(mech)
        q = mech.home[None]
        qv, qw = q[:, kern.iv] + 0.01, q[:, kern.iw].copy()
        T = kern.end_effector(kern.kinematics(q))
        a = evaluate(kern, qv, qw, T)
        b = old_evaluate(kern, qv, qw, T)
        assert np.array_equal(a.x, b[0]) and np.allclose(a.J, b[1], rtol=0, atol=1e-12)
        it = int(solve_closure(mech, qv, qw).iterations[0])
        args = (kern, qv, qw, T)
        fns = {"solve_closure": lambda a=args: solve_closure(a[0].mech, a[1], a[2]),
               "evaluate (now)": lambda a=args: evaluate(*a),
               "evaluate (before)": lambda a=args: old_evaluate(*a)}
        t: dict[str, list[float]] = {k: [] for k in fns}
        for _ in range(rounds):
            for k, fn in fns.items():
                t[k].append(per_call(fn, 50))
        print(f"{name} ({it} Newton iterations from the guess):")
        for k, v in t.items():
            print(f"  {k:18s} {1e3 * statistics.median(v):7.3f} ms")
        now, before = (statistics.median(t[k]) for k in ("evaluate (now)", "evaluate (before)"))
        print(f"  evaluate now / before: {now / before:.2f}")


if __name__ == "__main__":
    main()

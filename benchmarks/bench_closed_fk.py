"""Closed-chain FK from home: continuation (mechkin.fk) vs one Newton solve from home, on the
test models of tests/model/closed_chain_models.py (run on demand:
``PYTHONPATH=. python benchmarks/bench_closed_fk.py``)."""

from __future__ import annotations

import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

import mechkin
from mechkin.model.closure import solve_closure
from tests.model import closed_chain_models as M

CASES = {"xarm_gripper": (M.XARM, M.xarm_closed_form),
         "robotiq_fourbar": (M.ROBOTIQ, M.robotiq_closed_form),
         "cassie_leg": (M.CASSIE, lambda q: M.cassie_closed_form(q, -1.0)),
         "slider_crank": (M.SLIDER, M.slider_closed_form),
         "watt_six_bar": (M.WATT, lambda q: M.watt_closed_form(q, -1.0, -1.0))}


def main() -> None:
    d = Path(tempfile.mkdtemp())
    for name, (text, cf) in CASES.items():
        p = d / f"{name}.yaml"
        p.write_text(text)
        mech = mechkin.load_mechanism(p)
        iv = mech.independent
        lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -np.pi)
        hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], np.pi)
        qv = np.random.default_rng(0).uniform(lo, hi, (1000, len(iv)))
        ref = cf(qv)
        t0 = time.perf_counter()
        new = mechkin.fk(mech, qv)
        t_new = time.perf_counter() - t0
        t0 = time.perf_counter()
        old = solve_closure(mech, qv, mech.home[mech.dependent][None])
        t_old = time.perf_counter() - t0
        for label, q, st, t in (("continuation", new.q, new.status, t_new),
                                ("newton-from-home", old.q,
                                 [s.value for s in old.status], t_old)):
            same = np.abs(M.wrap(q - ref)).max(axis=1) <= 1e-10
            conv = np.array([s == "converged" for s in st])
            print(f"{name:16s} {label:17s} {t:7.3f} s  converged {conv.sum():4d}  "
                  f"home assembly {np.sum(conv & same):4d}  other {np.sum(conv & ~same):4d}  "
                  f"{dict(Counter(st))}")


if __name__ == "__main__":
    main()

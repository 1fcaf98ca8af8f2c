"""``mechkin warmup`` covers the signatures the solvers use (issue 29): a read-only start once
compiled ``tree_jit.lm_closed`` a second time (3-6 s at the first Stewart IK after warmup)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.solvers.ik import IkOptions, warm
from mechkin.solvers.ik.kernel import kernel_for
from mechkin.solvers.ik.lm import lm_batch


def test_a_read_only_start_runs_the_warmed_closed_chain_kernel(tmp_path, monkeypatch):
    pytest.importorskip("numba")
    monkeypatch.setenv("MECHKIN_JIT", "1")
    (tmp_path / "closed.yaml").write_text(warm.TINY_CLOSED)
    mech = load_mechanism(tmp_path / "closed.yaml")
    for _ in warm.warm([mech]):
        pass
    from mechkin.solvers.ik import tree_jit

    sigs = list(tree_jit.lm_closed.signatures)
    assert sigs
    kern = kernel_for(mech)
    T = kern.end_effector(kern.kinematics(mech.home[None]))
    qv = np.broadcast_to(mech.home[kern.iv], (1, kern.iv.size))  # read-only views
    qw = np.broadcast_to(mech.home[kern.iw], (1, kern.iw.size))
    assert not qv.flags.writeable and not qw.flags.writeable
    r = lm_batch(kern, qv, qw, T, np.broadcast_to(np.ones(6), (1, 6)), IkOptions())
    assert r["closed"].all()
    assert list(tree_jit.lm_closed.signatures) == sigs


def test_warmup_lists_every_open_chain_entry_point():
    names = [n for n, _ in warm.kernels_for(load_mechanism(
        Path(__file__).resolve().parents[2] / "mechanisms" / "puma560.yaml"))]
    for n in ("serial_jit.lm", "serial_jit.solve_rows", "serial_jit.verify_rows",
              "serial_jit.lm_verify", "serial_jit.nearest_turn_rows", "tree_jit.evaluate_one"):
        assert n in names

"""IK that succeeds by default: >= 99.5 % of seeded random reachable 6-D poses of the PUMA 560
and the Panda verified (0.1 mm, 1 mrad by forward kinematics), through the entry points and
defaults ``mechkin ik`` uses: IkOptions as :func:`mechkin.cli.ik.run_ik` builds them from a
default ``ik:`` section, each target warm-started from the previous answer (sequential), or all
at once from the start pose (``batch: true``). The compiled back end is used when numba is
installed, numpy otherwise."""

from dataclasses import replace

import numpy as np
import pytest

from mechkin.config.ik_spec import IkSpec
from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, IkStatus, pose_errors, solve_ik, solve_ik_batch

N_POSES = 200
POS_TOL, ORI_TOL = 1e-4, 1e-3  # [m], [rad]
MIN_SUCCESS = 0.995


def _cli_options(spec: IkSpec) -> IkOptions:
    """IkOptions exactly as mechkin.cli.ik.run_ik builds them (SI scenario units, lm)."""
    tol = spec.tolerances
    return IkOptions(
        method="cg-golden" if spec.method == "cg-golden" else "lm", grad_tol=tol.grad,
        max_iter=tol.max_iter, tol_pos=tol.position if tol.position else 1e-6,
        tol_ori=tol.orientation if tol.orientation else 1e-6, restarts=spec.restarts,
        seed=spec.seed, tol_phi=tol.closure, line_tol=tol.line, cg_restart=spec.cg_restart)


def _problem(root, name):
    """The mechanism, default options and random reachable poses as the CLI's random_targets
    makes them (uniform joints within the limits, seed 0, forward kinematics)."""
    mech = load_mechanism(root / "mechanisms" / f"{name}.yaml")
    spec = IkSpec(random_targets={"count": N_POSES})
    # auto: analytic where the arm decomposes, else this lm (tested here: the fallback)
    assert spec.method == "auto" and spec.warm_start and not spec.batch
    rng = np.random.default_rng(spec.random_targets.seed)
    iv = mech.independent
    q = np.repeat(mech.home[None], N_POSES, axis=0)
    q[:, iv] = rng.uniform(mech.lower[iv], mech.upper[iv], size=(N_POSES, len(iv)))
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    return mech, _cli_options(spec), T


def _verified(mech, q, T):
    T_E = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    pe, oe = pose_errors(T_E, T)
    ok = (pe <= POS_TOL) & (oe <= ORI_TOL)
    assert np.all(q >= mech.lower - 1e-9) and np.all(q <= mech.upper + 1e-9)
    return ok


@pytest.mark.parametrize("name", ["puma560", "panda", "ur5"])
def test_sequential_warm_started_defaults_succeed(root, name):
    mech, opts, T = _problem(root, name)
    qv, qw = mech.home[mech.independent].copy(), mech.home[mech.dependent].copy()
    qs, status_ok = [], []
    for Tk in T:
        r = solve_ik(mech, Tk, q_v0=qv, q_w0=qw, options=opts)
        qs.append(r.q)
        status_ok.append(r.ok)
        if r.status is not IkStatus.SINGULAR:
            qv, qw = r.q_v, r.q_w
    ok = _verified(mech, np.array(qs), T)
    assert ok.mean() >= MIN_SUCCESS, f"{name}: {ok.sum()}/{N_POSES} verified"
    assert np.all(np.array(status_ok) <= ok)  # status ok implies verified


@pytest.mark.parametrize("name", ["puma560", "panda", "ur5"])
def test_batch_from_the_start_pose_defaults_succeed(root, name):
    mech, opts, T = _problem(root, name)
    r = solve_ik_batch(mech, T, q_v0=mech.home[mech.independent],
                       q_w0=mech.home[mech.dependent], options=opts)
    ok = _verified(mech, r.q, T)
    assert ok.mean() >= MIN_SUCCESS, f"{name}: {ok.sum()}/{N_POSES} verified"
    assert np.all(r.ok <= ok)


def test_the_warm_start_alone_is_not_enough(root):
    """Why the defaults restart: without restarts about half the warm-started solves fail."""
    mech, opts, T = _problem(root, "puma560")
    bare = replace(opts, restarts=0)
    r = solve_ik_batch(mech, T, q_v0=mech.home[mech.independent], options=bare)
    assert _verified(mech, r.q, T).mean() < 0.9

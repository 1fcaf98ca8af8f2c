"""Workspace maps, gamma ranges and the lee scenario record/outputs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from mechkin.io.csv_out import read_csv
from mechkin.io.workspace_out import write_lee_workspace
from mechkin.solvers.closed_form.lee_spherical import (
    LeeGeometry,
    inverse_position,
    isotropy_index,
    within_stroke,
)
from mechkin.solvers.workspace.maps import (
    PoseEvaluation,
    area_fractions,
    gamma_range,
    gamma_range_from_mask,
    lee_evaluator,
    lee_workspace,
    orientation_maps,
    sigma_statistics,
    volume_fraction,
)

DEG = np.pi / 180.0


def test_orientation_maps_match_pointwise_evaluation():
    g = LeeGeometry(r=0.75, l_max=1.6)  # a short stroke so that some poses are out
    alpha = np.deg2rad(np.linspace(-90, 90, 13))
    beta = np.deg2rad(np.linspace(-60, 80, 11))
    gamma = np.deg2rad([0.0, 20.0, 90.0, 170.0])
    maps = orientation_maps(lee_evaluator(g), alpha, beta, gamma, block=50)
    assert maps.sigma.shape == (4, 13, 11) and maps.actuators.shape == (4, 13, 11, 3)
    i, j, k = 2, 5, 7
    mu = np.array([alpha[j], beta[k], gamma[i]])
    assert_allclose(maps.sigma[i, j, k], isotropy_index(g, mu), rtol=1e-14)
    assert_allclose(maps.actuators[i, j, k], inverse_position(g, mu), rtol=1e-14)
    assert_array_equal(maps.within_limits, within_stroke(g, maps.actuators))
    assert_array_equal(maps.in_workspace, maps.within_limits & (maps.sigma >= 0.01))
    assert (~maps.within_limits).any() and maps.within_limits.any()  # marked, not dropped
    assert np.all(np.isfinite(maps.sigma))  # beta = +-90 deg and the home pose are singular
    assert maps.sigma[0, 6, np.argmin(np.abs(beta))] == pytest.approx(
        isotropy_index(g, [0, beta[np.argmin(np.abs(beta))], 0])
    )


def test_maps_accept_any_evaluator():
    """The generic hook: any batched callable returning a PoseEvaluation."""

    def toy(poses: np.ndarray) -> PoseEvaluation:
        s = np.abs(np.cos(poses[:, 0]) * np.cos(poses[:, 1]))
        return PoseEvaluation(s, poses[:, 2] > 0, poses[:, :2].copy())

    maps = orientation_maps(toy, [0.0, 1.0], [0.0, 0.5, 1.5], [-1.0, 1.0], threshold=0.5)
    assert_array_equal(maps.in_workspace[0], False)
    # cos(1) cos(0.5) = 0.474 < 0.5
    assert_array_equal(maps.in_workspace[1], [[True, True, False], [True, False, False]])
    assert maps.branch is None


def test_gamma_range_from_mask_modes():
    g = np.arange(8.0)
    W = np.array([0, 1, 1, 0, 1, 1, 1, 0], dtype=bool)[:, None]
    lo, hi, n_in, n_runs = gamma_range_from_mask(W, g)
    assert (lo[0], hi[0], n_in[0], n_runs[0]) == (1.0, 6.0, 5, 2)
    lo, hi, *_ = gamma_range_from_mask(W, g, mode="component", gamma_ref=5.2)
    assert (lo[0], hi[0]) == (4.0, 6.0)
    lo, hi, *_ = gamma_range_from_mask(W, g, mode="component", gamma_ref=3.0)
    assert np.isnan(lo[0]) and np.isnan(hi[0])
    # A sign change of det between grid points 4 and 5 splits the second run.
    branch = np.array([1, 1, 1, 1, 1, -1, -1, -1], dtype=np.int8)[:, None]
    lo, hi, _, n_runs = gamma_range_from_mask(W, g, mode="component", gamma_ref=6.0, branch=branch)
    assert (lo[0], hi[0], n_runs[0]) == (5.0, 6.0, 3)
    nothing = np.zeros((8, 1), dtype=bool)
    lo, hi, n_in, n_runs = gamma_range_from_mask(nothing, g)
    assert np.isnan(lo[0]) and np.isnan(hi[0]) and n_in[0] == 0 and n_runs[0] == 0


def test_gamma_range_at_alpha_beta_zero_is_the_stroke_limit():
    """At alpha = beta = 0: l^2 = 2 + r^2 - 2 r cos(gamma) <= l_max^2 bounds gamma (r = 0.75)."""
    g = LeeGeometry(r=0.75)
    grid = np.deg2rad(np.linspace(-180, 180, 7201))  # 0.05 deg
    gr = gamma_range(lee_evaluator(g), [0.0], [0.0], grid)
    bound = np.rad2deg(np.arccos((0.75**2 + 2 - 4) / (2 * 0.75)))  # 163.402 deg
    assert abs(np.rad2deg(gr.gamma_max[0, 0]) - bound) < 0.05
    assert abs(np.rad2deg(gr.gamma_min[0, 0]) + bound) < 0.05
    assert gr.n_runs[0, 0] == 2  # split by the singular home pose gamma = 0
    comp = gamma_range(lee_evaluator(g), [0.0], [0.0], grid, mode="component", gamma_ref=30 * DEG)
    # sigma_KI = sqrt2 sin(gamma) >= 0.01 -> gamma >= 0.405 deg
    assert abs(np.rad2deg(comp.gamma_min[0, 0]) - np.rad2deg(np.arcsin(0.01 / np.sqrt(2)))) < 0.05
    assert comp.gamma_max[0, 0] == gr.gamma_max[0, 0]


def test_fractions_and_statistics():
    W = np.zeros((2, 3, 4), dtype=bool)
    W[0, :, :2] = True
    assert_allclose(area_fractions(W), [0.5, 0.0])
    assert volume_fraction(W) == 0.25
    s = np.linspace(0, 1, 24).reshape(2, 3, 4)
    st = sigma_statistics(s, W)
    assert st["count"] == 6 and st["min"] == 0.0 and st["max"] == s[0, 2, 1]
    assert sigma_statistics(s, np.zeros_like(W)) == {"count": 0}


def test_lee_workspace_record_summary_is_strict_json():
    rec = lee_workspace(
        r=0.5,
        gamma_sets={"text": np.deg2rad([20, 30, 40]), "captions": np.deg2rad([20, 40, 60])},
        n_alpha=21,
        n_beta=17,
        gamma_sweep=(-np.pi, np.pi),
        n_gamma_sweep=37,
        n_alpha_sweep=9,
        n_beta_sweep=9,
    )
    text = json.dumps(rec.summary, allow_nan=False)
    assert '"captions"' in text
    iso = rec.summary["isotropy"]["text"]
    assert [p["gamma_deg"] for p in iso["per_gamma"]] == [20.0, 30.0, 40.0]
    assert iso["per_gamma"][0]["sigma_ki_at_origin"] == pytest.approx(0.483690, abs=5e-7)
    assert 0.0 < iso["volume_fraction"] <= 1.0
    assert rec.isotropy["captions"].sigma.shape == (3, 21, 17)
    assert rec.gamma_range is not None and rec.gamma_range.gamma_min.shape == (9, 9)


def test_run_lee_workspace_writes_every_output(tmp_path):
    out = tmp_path / "lee_fig5"
    rec = lee_workspace(
        r=0.75,
        gamma_sets={"text": np.deg2rad([20, 30, 40])},
        n_alpha=15,
        n_beta=13,
        gamma_sweep=(-np.pi, np.pi),
        n_gamma_sweep=25,
        n_alpha_sweep=7,
        n_beta_sweep=7,
    )
    files = write_lee_workspace(rec, out)
    names = {
        "sigma_ki_text.png",
        "sigma_ki_text.csv",
        "gamma_range.png",
        "gamma_range.csv",
        "summary.json",
    }
    assert set(files) == names
    assert {p.name for p in out.iterdir()} == names
    for name in names:
        assert (out / name).stat().st_size > 0
    assert (out / "sigma_ki_text.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = read_csv(out / "sigma_ki_text.csv")
    assert len(table["sigma_ki"]) == 3 * 15 * 13
    assert_allclose(table["sigma_ki"], rec.isotropy["text"].sigma.ravel())
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["files"]) == names
    assert (
        summary["gamma_range"]["csv_rows"] + summary["gamma_range"]["rows_without_workspace"] == 49
    )

"""lee_spherical_3dof_parallel §3.2: kinematic isotropy index (Eq. 21) and the Fig. 2-5 setting.

The OCR'd paper lost its figures, so the reference values are the closed-form facts recorded
with the paper (PAPER_NOTES.md, lee section; issue 5), typed in with their printed digits and
compared at half a unit of the last digit:

* at alpha = beta = 0, sigma_KI = min(sqrt(2) sin gamma, 1 / (sqrt(2) sin gamma)) for every r,
  0.483690 at gamma = 20 deg;
* the home pose alpha = beta = gamma = 0 is singular: sigma_KI = 0.

Simulation setting of lee §3.2: R = 1, 0.5 <= l_i <= 2, offsets (i - 1) 120 deg (Eqs. 22-23),
the passive chain's spherical joint at (0, 0, 1), workspace threshold sigma_KI >= 0.01.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.solvers.closed_form.lee_spherical import LeeGeometry, isotropy_index
from mechkin.solvers.workspace.maps import lee_evaluator, orientation_maps

FIG_RADII = (0.25, 0.5, 0.75)  # Figs. 3, 4, 5
GAMMAS_TEXT_DEG = (20.0, 30.0, 40.0)  # lee §3.2 text
GAMMAS_CAPTIONS_DEG = (20.0, 40.0, 60.0)  # Fig. 3-5 captions

# sigma_KI(0, 0, gamma) printed to 6 digits: 0.483690 (PAPER_NOTES); the others are the same
# formula min(sqrt2 sin g, 1/(sqrt2 sin g)) at 30, 40 and 60 deg.
SIGMA_AT_ZERO = {20.0: 0.483690, 30.0: 0.707107, 40.0: 0.909039, 60.0: 0.816497}


@pytest.mark.parametrize("r", FIG_RADII)
def test_sigma_ki_at_alpha_beta_zero(r):
    g = LeeGeometry(r=r)
    gam = np.array(sorted(SIGMA_AT_ZERO))
    mu = np.column_stack([0 * gam, 0 * gam, np.deg2rad(gam)])
    assert_allclose(isotropy_index(g, mu), [SIGMA_AT_ZERO[v] for v in gam], atol=5e-7)


@pytest.mark.parametrize("r", FIG_RADII)
def test_home_pose_is_singular(r):
    assert isotropy_index(LeeGeometry(r=r), np.zeros(3)) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("gammas", [GAMMAS_TEXT_DEG, GAMMAS_CAPTIONS_DEG], ids=["text", "captions"])
@pytest.mark.parametrize("r", FIG_RADII)
def test_fig3_to_5_maps_centre_value_and_range(r, gammas):
    """The alpha-beta maps of Figs. 3-5 pass through the formula at their centre, hold no NaN,
    and sigma_KI never exceeds 1 (n_a = n_b odd so that alpha = beta = 0 is a grid point)."""
    alpha = np.deg2rad(np.linspace(-90, 90, 61))
    maps = orientation_maps(lee_evaluator(LeeGeometry(r=r)), alpha, alpha, np.deg2rad(gammas))
    assert np.all(np.isfinite(maps.sigma))
    assert maps.sigma.min() >= 0.0 and maps.sigma.max() <= 1.0 + 1e-12
    assert_allclose(maps.sigma[:, 30, 30], [SIGMA_AT_ZERO[v] for v in gammas], atol=5e-7)
    assert maps.in_workspace[:, 30, 30].all()

"""Named tolerances shared by the tests (STYLE.md §2.8)."""

ATOL_POSE = 1e-9  # FK against published poses [m, -]
ATOL_FD = 1e-6  # analytic vs central finite-difference Jacobians
FD_STEP = 1e-6
TOL_CLOSURE = 1e-12  # ||phi_R|| after loop closure

"""The fk task's singularity record: per-step columns, the summary block and the warning lines
(split from :mod:`mechkin.tasks.fk`; the classes come from :mod:`mechkin.model.singularity`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.tasks.fk_batch import label_counts, singular_masks


def singularity_columns(sing: Any) -> dict[str, Any]:
    """Per-step condition numbers (-1 where the rank is lost or undefined) and the class."""
    def finite(c: Any) -> np.ndarray:  # _finite, vectorised
        c = np.asarray(c, dtype=np.float64)
        return np.where(np.isfinite(c), c, -1.0)

    return {"cond_constraint": finite(sing.cond_constraint),
            "cond_reduced": finite(sing.cond_reduced),
            "singularity": list(map(str, sing.label))}


def singularity_summary(sing: Any, t: np.ndarray) -> dict[str, Any]:
    """Counts of each class, the worst condition numbers and the first singular / near step."""
    counts = label_counts(sing.label)
    is_singular, is_near = singular_masks(sing)
    singular = np.flatnonzero(is_singular)
    near = np.flatnonzero(is_near)

    def worst(c: np.ndarray) -> float | None:
        c = np.asarray(c, float)
        fin = c[np.isfinite(c)]
        if np.any(np.isinf(c)):
            return -1.0
        return float(fin.max()) if fin.size else None

    return {
        "counts": counts,
        "max_cond_constraint": worst(sing.cond_constraint),
        "max_cond_reduced": worst(sing.cond_reduced),
        "first_singular_step": int(singular[0]) if singular.size else None,
        "first_singular_t_s": float(t[singular[0]]) if singular.size else None,
        "first_near_step": int(near[0]) if near.size else None,
        "length_scale_m": float(sing.length_scale),
        "thresholds": {"singular": float(sing.tol_singular), "near": float(sing.tol_near)},
    }


def singularity_messages(s: dict[str, Any], path: Any) -> list[str]:
    """Warning lines when the motion passes a singularity or within the near threshold."""
    out = []
    if s["first_singular_step"] is not None:
        kinds = ", ".join(k for k in s["counts"] if "singularity" in k and "near" not in k)
        out.append(f"{path}: warning: the motion passes a singularity ({kinds}) first at step "
                   f"{s['first_singular_step']} (t = {s['first_singular_t_s']:.6g} s)")
    elif s["first_near_step"] is not None:
        out.append(f"{path}: warning: the motion comes near a singularity (sigma_min/sigma_max "
                   f"< {s['thresholds']['near']:g}) first at step {s['first_near_step']}")
    return out

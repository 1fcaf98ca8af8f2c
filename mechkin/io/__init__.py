"""Results -> files: CSV tables, summary.json, PNG plots and MCAP logs, all written atomically.

This layer takes plain arrays and the small records defined here; it never imports
``mechkin.solvers`` or ``mechkin.model``. The plotting functions are loaded on first use
(``mechkin.io.plot_series``), so commands that draw nothing do not pay for importing matplotlib.
"""

from __future__ import annotations

from typing import Any

from mechkin.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
from mechkin.io.csv_out import format_csv, read_csv, write_csv
from mechkin.io.mcap_out import (
    Box,
    Label,
    Lines,
    MotionLog,
    Scene,
    Spheres,
    poses_in_root,
    skeleton_scene,
    write_mcap,
)
from mechkin.io.output_dir import OutputDir
from mechkin.io.summary import jsonable, summary_json, write_summary

__all__ = [
    "Box",
    "Label",
    "Lines",
    "MotionLog",
    "OutputDir",
    "Scene",
    "Spheres",
    "Stick",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "format_csv",
    "jsonable",
    "plot_convergence",
    "plot_series",
    "plot_stick_3d",
    "poses_in_root",
    "read_csv",
    "skeleton_scene",
    "summary_json",
    "write_csv",
    "write_mcap",
    "write_summary",
]

_PLOTS = ("Stick", "plot_convergence", "plot_series", "plot_stick_3d")


def __getattr__(name: str) -> Any:
    if name in _PLOTS:
        from mechkin.io import plots

        return getattr(plots, name)
    raise AttributeError(f"module 'mechkin.io' has no attribute {name!r}")

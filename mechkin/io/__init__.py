"""Results -> files: CSV tables, summary.json, PNG plots and MCAP logs, all written atomically.

This layer takes plain arrays and the small records defined here; it never imports
``mechkin.solvers`` or ``mechkin.model``. The names below are loaded on first use
(``mechkin.io.plot_series``), so commands that draw nothing do not pay for importing
matplotlib, and runs without an MCAP file none for mcap and protobuf.
"""

from __future__ import annotations

from typing import Any

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

#: where each name lives: loaded on first use, so a run imports only the writers it uses (no
#: MCAP or protobuf code without an MCAP file, no matplotlib without plots)
_WHERE = {
    "atomic_path": "atomic", "atomic_write_bytes": "atomic", "atomic_write_text": "atomic",
    "format_csv": "csv_out", "read_csv": "csv_out", "write_csv": "csv_out",
    "Box": "mcap_out", "Label": "mcap_out", "Lines": "mcap_out", "MotionLog": "mcap_out",
    "Scene": "mcap_out", "Spheres": "mcap_out", "poses_in_root": "mcap_out",
    "skeleton_scene": "mcap_out", "write_mcap": "mcap_out",
    "OutputDir": "output_dir",
    "jsonable": "summary", "summary_json": "summary", "write_summary": "summary",
    "Stick": "plots", "plot_convergence": "plots", "plot_series": "plots",
    "plot_stick_3d": "plots",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        value = getattr(importlib.import_module(f"mechkin.io.{_WHERE[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mechkin.io' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)

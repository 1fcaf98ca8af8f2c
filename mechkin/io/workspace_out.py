"""The files of a workspace run (every kind of ``workspace:`` section), from its records.

:func:`write` is the writer of the workspace :class:`~mechkin.records.Report`
(``report.data`` is a :class:`~mechkin.records.workspace.WorkspaceOutput`):

* ``lee_spherical``: per gamma set ``NAME`` ``sigma_ki_NAME.png`` and ``sigma_ki_NAME.csv``
  (one row per grid pose: ``alpha_deg, beta_deg, gamma_deg, l1_m, l2_m, l3_m, sigma_ki,
  within_stroke, in_workspace``); with a gamma range ``gamma_range.png`` and
  ``gamma_range.csv`` (``alpha_deg, beta_deg, n_gamma_in, n_runs, gamma_min_deg,
  gamma_max_deg``, only rows where gamma_min is defined; their count is in summary.json).
  With a pose list ``sigma_ki_poses.csv`` (one row per listed pose, the same columns).
  Lengths are in units of the base radius ``R`` (written ``_m``).
* ``design``: ``design_sigma_ki_NAME.png`` (a row per value, a column per gamma),
  ``design_gamma_range.png``, ``design_comparison.csv`` and per value the CSV grids above
  under ``PARAM_VALUE/`` (e.g. ``r_0.25/sigma_ki_text.csv``).
* ``task_space``: ``task_points.csv`` (one row per target pose: position, quaternion (w, x,
  y, z), status, reachable, errors, iterations, independent joints, dexterity incl.
  ``isotropy_normalized``) and
  ``task_space.png``.
* ``joint_sweep``: ``points.csv`` (one row per sample: independent joints, position, status,
  within_limits, reachable, seed_sample (the solved neighbour its loop closure started from,
  -1: home), mode_change, reseeded, dexterity) and ``workspace_slices.png``.

Task-space and joint-sweep runs also write ``workspace.mcap`` and ``workspace.layout.json``
(:mod:`mechkin.io.workspace_mcap`: the robot at home and the map as a point cloud coloured by
isotropy); lee_spherical and design maps are over orientation angles and write none.

Imports: records, io.atomic, io.report, io.workspace_plots and io.workspace_mcap (lazily).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from mechkin.io.output_dir import OutputDir
from mechkin.records import OutputFlags, Report
from mechkin.records.workspace import (
    DesignSweepRecord,
    JointSweepRecord,
    LeeWorkspaceRecord,
    TaskSpaceRecord,
    WorkspaceOutput,
)

__all__ = ["write", "write_lee_workspace"]


def _deg(x: np.ndarray) -> np.ndarray:
    """Radians -> degrees rounded to 1e-9 deg, so 30 deg is written 30.0, not 29.999999999999996."""
    return np.round(np.rad2deg(x), 9)


def write(od: OutputDir, report: Report, plots: bool) -> None:
    """Write the CSVs and PNGs of a workspace report into ``od`` (summary.json is written by
    :func:`mechkin.io.report.write_report`)."""
    out: WorkspaceOutput = report.data
    csv = report.outputs.csv
    plots = plots and report.outputs.plots
    if out.kind == "lee_spherical":
        _write_lee_files(od, out.record, plots=plots, csv=csv)
    elif out.kind == "design":
        _write_design(od, out.record, plots=plots, csv=csv)
    elif out.kind == "task_space":
        _write_task_space(od, out, plots=plots, csv=csv)
    elif out.kind == "joint_sweep":
        _write_joint_sweep(od, out, plots=plots, csv=csv)
    else:
        raise ValueError(f"unknown workspace output kind {out.kind!r}")
    if report.outputs.mcap and out.kind in ("task_space", "joint_sweep"):
        from mechkin.io.workspace_mcap import write_workspace_mcap

        write_workspace_mcap(od, out)


def write_lee_workspace(record: LeeWorkspaceRecord, out_dir: str | os.PathLike[str], *,
                        plots: bool = True, csv: bool = True,
                        extra_summary: dict[str, Any] | None = None) -> list[str]:
    """Write the files of one lee record and summary.json (``record.summary`` with
    ``extra_summary`` merged in) into ``out_dir``, atomically; return the names written."""
    rep = Report(task="workspace", scenario=str(record.summary.get("mechanism", "lee")),
                 summary={**record.summary, **(extra_summary or {})}, writer="workspace",
                 data=WorkspaceOutput("lee_spherical", record),
                 outputs=OutputFlags(csv=csv, plots=plots, mcap=False))
    from mechkin.io.report import write_report

    return list(write_report(rep, out_dir, plots=plots)["files"])


# --------------------------------------------------------------------------- lee


def _write_lee_files(od: OutputDir, record: LeeWorkspaceRecord, *, plots: bool, csv: bool,
                     prefix: str = "") -> None:
    """PNGs and CSV grids of one lee record into ``od`` (names prefixed by ``prefix``)."""
    geom = record.geometry
    for name, maps in record.isotropy.items():
        gam_txt = "/".join(f"{g:g}" for g in _deg(maps.gamma))
        if plots:
            from mechkin.io.workspace_plots import plot_isotropy_maps

            plot_isotropy_maps(
                od.path_for(f"{prefix}sigma_ki_{name}.png"),
                maps.alpha,
                maps.beta,
                maps.gamma,
                maps.sigma,
                maps.within_limits,
                threshold=maps.threshold,
                title=f"lee: $\\sigma_{{KI}}$ over $\\alpha$-$\\beta$, r = {geom.r:g}, "
                f"$\\gamma$ = {gam_txt}° ({name})",
            )
        if csv:
            G, A, B = np.meshgrid(maps.gamma, maps.alpha, maps.beta, indexing="ij")
            cols: dict[str, np.ndarray] = {
                "alpha_deg": _deg(A).ravel(),
                "beta_deg": _deg(B).ravel(),
                "gamma_deg": _deg(G).ravel(),
            }
            if maps.actuators is not None:
                for i in range(maps.actuators.shape[-1]):
                    cols[f"l{i + 1}_m"] = maps.actuators[..., i].ravel()
            cols["sigma_ki"] = maps.sigma.ravel()
            cols["within_stroke"] = maps.within_limits.ravel()
            cols["in_workspace"] = maps.in_workspace.ravel()
            od.write_table(f"{prefix}sigma_ki_{name}", cols)
    pl = record.poses
    if pl is not None and csv:
        cols = {"pose": np.arange(pl.poses.shape[0]), "alpha_deg": _deg(pl.poses[:, 0]),
                "beta_deg": _deg(pl.poses[:, 1]), "gamma_deg": _deg(pl.poses[:, 2])}
        for i in range(pl.actuators.shape[-1]):
            cols[f"l{i + 1}_m"] = pl.actuators[:, i]
        cols.update(sigma_ki=pl.sigma, within_stroke=pl.within_limits,
                    in_workspace=pl.in_workspace)
        od.write_table(f"{prefix}sigma_ki_poses", cols)
    gr = record.gamma_range
    if gr is not None:
        if plots:
            from mechkin.io.workspace_plots import plot_gamma_range

            plot_gamma_range(
                od.path_for(f"{prefix}gamma_range.png"),
                gr.alpha,
                gr.beta,
                gr.gamma_min,
                gr.gamma_max,
                title=f"lee Fig. 2: $\\gamma_{{min}}$, $\\gamma_{{max}}$ ({gr.mode}), "
                f"r = {geom.r:g}, $\\sigma_{{KI}}$ ≥ {gr.threshold:g}, legs within stroke",
            )
        if csv:
            A, B = np.meshgrid(gr.alpha, gr.beta, indexing="ij")
            d = gr.defined
            od.write_table(f"{prefix}gamma_range",
                {
                    "alpha_deg": _deg(A[d]),
                    "beta_deg": _deg(B[d]),
                    "n_gamma_in": gr.n_in[d],
                    "n_runs": gr.n_runs[d],
                    "gamma_min_deg": _deg(gr.gamma_min[d]),
                    "gamma_max_deg": _deg(gr.gamma_max[d]),
                },
            )


def _value_dir(parameter: str, value: float) -> str:
    return f"{parameter}_{value:g}/"


def _write_design(od: OutputDir, sweep: DesignSweepRecord, *, plots: bool, csv: bool) -> None:
    par, vals, recs = sweep.parameter, sweep.values, sweep.records
    if plots:
        from mechkin.io.workspace_plots import plot_design_gamma_range, plot_design_isotropy

        for name in recs[0].isotropy:
            plot_design_isotropy(
                od.path_for(f"design_sigma_ki_{name}.png"), par, vals,
                [r.isotropy[name] for r in recs],
                title=f"lee design sweep over {par}: $\\sigma_{{KI}}$ ({name})",
            )
        first = recs[0].gamma_range
        if first is not None:
            plot_design_gamma_range(
                od.path_for("design_gamma_range.png"), par, vals,
                [r.gamma_range for r in recs],
                title=f"lee design sweep over {par}: $\\gamma_{{min}}$, "
                      f"$\\gamma_{{max}}$ ({first.mode})",
            )
    if sweep.comparison:
        keys = list(dict.fromkeys(k for row in sweep.comparison for k in row))
        od.write_table("design_comparison", {
            k: [("" if row.get(k) is None else row.get(k, "")) for row in sweep.comparison]
            for k in keys
        })
    if csv:
        for v, rec in zip(vals, recs, strict=True):
            _write_lee_files(od, rec, plots=False, csv=True, prefix=_value_dir(par, v))


# --------------------------------------------------------------------------- task space


def _write_task_space(od: OutputDir, out: WorkspaceOutput, *, plots: bool, csv: bool) -> None:
    from mechkin.spatial.rotations import quat_from_matrix

    rec: TaskSpaceRecord = out.record
    if csv:
        m = rec.reachable.size
        quat = quat_from_matrix(rec.T_P[:, :3, :3]) if m else np.zeros((0, 4))
        cols: dict[str, Any] = {"pose": np.arange(m), "x_m": rec.T_P[:, 0, 3],
                                "y_m": rec.T_P[:, 1, 3], "z_m": rec.T_P[:, 2, 3]}
        for k, c in enumerate("wxyz"):
            cols[f"q{c}"] = quat[:, k]
        cols.update(status=rec.status, reachable=rec.reachable,
                    position_error_m=rec.position_error,
                    orientation_error_rad=rec.orientation_error, iterations=rec.iterations)
        for k, name in enumerate(out.joint_columns):
            cols[name] = rec.q_v[:, k]
        cols.update(isotropy=rec.isotropy, isotropy_position=rec.isotropy_position,
                    condition_number=rec.condition_number, manipulability=rec.manipulability)
        if rec.isotropy_normalized is not None:
            cols["isotropy_normalized"] = rec.isotropy_normalized
        od.write_table("task_points", cols)
    if plots and rec.reachable.size:
        from mechkin.io.workspace_plots import plot_task_space

        plot_task_space(od.path_for("task_space.png"), rec, title=out.title)


# --------------------------------------------------------------------------- joint sweep


def _write_joint_sweep(od: OutputDir, out: WorkspaceOutput, *, plots: bool, csv: bool) -> None:
    rec: JointSweepRecord = out.record
    m = rec.reachable.size
    if csv:
        cols: dict[str, Any] = {"sample": np.arange(m)}
        for i, name in enumerate(out.joint_columns):
            cols[name] = rec.q_v[:, i]
        cols.update(x_m=rec.position[:, 0], y_m=rec.position[:, 1], z_m=rec.position[:, 2],
                    status=rec.status, within_limits=rec.within_limits,
                    reachable=rec.reachable)
        if rec.seed is not None:
            cols.update(seed_sample=rec.seed, mode_change=rec.mode_change,
                        reseeded=rec.reseeded)
        if rec.isotropy is not None:
            cols.update(manipulability=rec.manipulability, isotropy=rec.isotropy,
                        isotropy_position=rec.isotropy_position)
            if rec.isotropy_normalized is not None:
                cols["isotropy_normalized"] = rec.isotropy_normalized
        od.write_table("points", cols)
    P = rec.position[rec.reachable]
    if plots and P.shape[0]:
        from mechkin.io.workspace_plots import plot_point_cloud

        colour = rec.isotropy_position[rec.reachable] if rec.isotropy_position is not None \
            else None
        plot_point_cloud(od.path_for("workspace_slices.png"), P, colour, out.slices,
                         title=out.title)

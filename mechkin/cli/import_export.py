"""``mechkin import ROBOT.urdf|.xml`` and ``mechkin export MECH.yaml``: robot files <-> mechanism
YAML (DESIGN.md: cli/; typer only, the readers and writers are imported inside the commands).

``import`` reads a URDF (yourdfpy) or an MJCF (MuJoCo's compiler) with its sidecar
(``ROBOT.mechkin.yaml`` or ``--sidecar``) into the mechanism YAML format; ``export`` writes any
mechanism's spanning tree as URDF with the cuts as mechkin extension elements.
"""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.common import handle_errors


def import_cli(
    robot: Path = typer.Argument(..., help="Robot file: URDF (.urdf, .xml <robot>) or MJCF "
                                           "(.xml <mujoco>, .mjcf)"),
    out: Path | None = typer.Option(None, "--out", "-o",
                                    help="Mechanism YAML to write [default: stdout]"),
    sidecar: Path | None = typer.Option(
        None, "--sidecar", help="Loop closures etc. (cuts, independent, end_effector, home) "
        "[default: ROBOT.mechkin.yaml beside the robot file, if there]"),
) -> None:
    """Import a URDF or MJCF robot file as a mechanism YAML (closed chains: via the sidecar)."""
    _import(robot, out, sidecar)


@handle_errors
def _import(robot: Path, out: Path | None, sidecar: Path | None) -> None:
    from mechkin.config.tree_import import spec_to_yaml_text
    from mechkin.config.urdf import is_urdf
    from mechkin.errors import ConfigError

    if not robot.exists():
        raise ConfigError(f"{robot}: file not found")
    if is_urdf(robot):
        from mechkin.config.urdf import read_urdf_spec

        spec, doc = read_urdf_spec(robot, sidecar)
    elif robot.suffix.lower() in (".xml", ".mjcf"):
        from mechkin.config.mjcf import read_mjcf_spec

        spec, doc = read_mjcf_spec(robot, sidecar)
    else:
        raise ConfigError(f"{robot}: expected a .urdf, .xml or .mjcf robot file")
    # build it once, so a file that imports is a file every command accepts
    from mechkin.model.build import build_mechanism

    build_mechanism(spec, doc)  # problems located in the robot file
    text = spec_to_yaml_text(spec, f"# imported by mechkin import from {robot.name}\n")
    if out is None:
        typer.echo(text, nl=False)
        return
    from mechkin.io.atomic import atomic_write_text

    atomic_write_text(out, text)
    typer.echo(f"wrote {out}", err=True)


def export_cli(
    mechanism: Path = typer.Argument(..., help="Mechanism file (YAML, URDF or MJCF)"),
    out: Path | None = typer.Option(None, "--out", "-o",
                                    help="URDF to write [default: stdout]"),
) -> None:
    """Export a mechanism's spanning tree as URDF with visuals; cuts as mechkin:cut elements."""
    _export(mechanism, out)


@handle_errors
def _export(mechanism: Path, out: Path | None) -> None:
    from mechkin.io.urdf_out import robot_urdf
    from mechkin.model import load_mechanism
    from mechkin.tasks.robot import robot_description

    # the same generated visuals as the MCAP logs' URDF (mechkin.tasks.robot)
    text = robot_urdf(robot_description(load_mechanism(mechanism)))
    if out is None:
        typer.echo(text, nl=False)
        return
    from mechkin.io.atomic import atomic_write_text

    atomic_write_text(out, text)
    typer.echo(f"wrote {out}", err=True)

"""Read and validate a mechanism file -> (SI spec, YamlDoc).

The suffix picks the reader: ``.urdf`` (or ``.xml`` with a ``<robot>`` root) -> the URDF
importer, ``.xml`` with a ``<mujoco>`` root or ``.mjcf`` -> the MJCF importer, anything else
-> mechanism YAML. Importers produce the same spec; their sidecar is ``ROBOT.mechkin.yaml``.
"""

from __future__ import annotations

from pathlib import Path

from mechkin.config.load import YamlDoc, read_yaml
from mechkin.config.schema import MechanismSpec, validate_model
from mechkin.config.units import mechanism_to_si

ROBOT_SUFFIXES = (".urdf", ".xml", ".mjcf")


def is_robot_file(path: str | Path) -> bool:
    """True for a URDF or MJCF mechanism (read by an importer, not as YAML)."""
    return Path(path).suffix.lower() in ROBOT_SUFFIXES


def read_mechanism_spec(path: str | Path, doc: YamlDoc | None = None
                        ) -> tuple[MechanismSpec, YamlDoc]:
    """:func:`_read_mechanism_spec`, then joint names whose table columns would collide with a
    task's own columns are refused (:mod:`mechkin.config.columns`)."""
    from mechkin.config.columns import check_joint_columns

    spec, doc = _read_mechanism_spec(path, doc)
    check_joint_columns(spec, doc)
    return spec, doc


def _read_mechanism_spec(path: str | Path, doc: YamlDoc | None = None
                         ) -> tuple[MechanismSpec, YamlDoc]:
    """Parse, validate (unknown keys, types, finiteness) and convert to SI.

    ``doc``: the file already parsed by :func:`mechkin.config.load.read_yaml` (read once).
    URDF and MJCF files go through their importers (:mod:`mechkin.config.urdf`,
    :mod:`mechkin.config.mjcf`)."""
    if doc is None and is_robot_file(path):
        from mechkin.config.urdf import is_urdf

        if is_urdf(path):
            from mechkin.config.urdf import read_urdf_spec

            return read_urdf_spec(path)
        from mechkin.config.mjcf import read_mjcf_spec

        return read_mjcf_spec(path)
    if doc is None:
        doc = read_yaml(path)
    spec = validate_model(doc, MechanismSpec, doc.data)
    return mechanism_to_si(spec), doc

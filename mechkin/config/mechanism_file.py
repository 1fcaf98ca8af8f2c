"""Read and validate a mechanism file -> (SI spec, YamlDoc)."""

from __future__ import annotations

from pathlib import Path

from mechkin.config.load import YamlDoc, read_yaml
from mechkin.config.schema import MechanismSpec, validate_model
from mechkin.config.units import mechanism_to_si


def read_mechanism_spec(path: str | Path, doc: YamlDoc | None = None
                        ) -> tuple[MechanismSpec, YamlDoc]:
    """Parse, validate (unknown keys, types, finiteness) and convert to SI.

    ``doc``: the file already parsed by :func:`mechkin.config.load.read_yaml` (read once)."""
    if doc is None:
        doc = read_yaml(path)
    spec = validate_model(doc, MechanismSpec, doc.data)
    return mechanism_to_si(spec), doc

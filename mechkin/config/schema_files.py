"""The JSON Schemas of mechanism and scenario files, shipped inside the package.

``mechkin/schemas/{mechanism,scenario}.schema.json`` are generated from the pydantic specs
(:func:`generate`) and committed, so ``mechkin schema`` and editors read them without importing
pydantic. Regenerate after changing a spec::

    python -m mechkin.config.schema_files

(``tests/config/test_schema_files.py`` fails when a shipped file is stale.)
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from pathlib import Path

KINDS = ("mechanism", "scenario")
DIALECT = "https://json-schema.org/draft/2020-12/schema"


def file_name(kind: str) -> str:
    return f"{kind}.schema.json"


def schema_text(kind: str) -> str:
    """The shipped schema of ``kind`` (``mechanism`` | ``scenario``) as JSON text."""
    return resources.files("mechkin.schemas").joinpath(file_name(kind)).read_text("utf-8")


def generate(kind: str) -> str:
    """The schema of ``kind`` generated from the pydantic specs (JSON text, newline-ended)."""
    if kind == "mechanism":
        from mechkin.config.schema import MechanismSpec

        schema = MechanismSpec.model_json_schema()
    elif kind == "scenario":
        from mechkin.config.scenario import scenario_json_schema

        schema = scenario_json_schema()
    else:
        raise ValueError(f"kind: expected one of {KINDS}, got {kind!r}")
    schema["$schema"] = DIALECT
    return json.dumps(schema, indent=2) + "\n"


def write(directory: str | Path) -> list[Path]:
    """Write both schema files into ``directory``; return their paths."""
    out = []
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    for kind in KINDS:
        p = d / file_name(kind)
        p.write_text(generate(kind), encoding="utf-8")
        out.append(p)
    return out


if __name__ == "__main__":  # pragma: no cover - maintenance entry point
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parents[1] / "schemas"
    for p in write(target):
        print(p)

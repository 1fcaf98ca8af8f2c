"""The JSON Schemas of mechanism and scenario files, shipped inside the package.

``mechkin/schemas/{mechanism,scenario}.schema.json`` are generated from the pydantic specs
(:func:`generate`) and committed, so ``mechkin schema`` and editors read them without importing
pydantic. Regenerate after changing a spec::

    python -m mechkin.config.schema_files

(``tests/config/test_schema_files.py`` fails when a shipped file is stale.)

:func:`document` adds what editors show on hover and check as you type: a ``description`` of
every property (units, defaults, the paper's names;
:data:`mechkin.config.schema_docs.FIELD_DOCS`), ``examples`` of the main
keys and the cross-field rules JSON Schema can express (:data:`RULES`: ``dh`` and ``origin``
not together, ``task: fk`` needs ``fk:``, an ``expect`` entry needs ``value`` or ``min``/``max``,
...). The pydantic validators stay the authority; these rules only mirror them.
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from pathlib import Path

from mechkin.config.schema_docs import EXAMPLES, FIELD_DOCS

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
    schema = document(schema)
    schema["$schema"] = DIALECT
    return json.dumps(schema, indent=2) + "\n"


def write(directory: str | Path, fresh: bool = True) -> list[Path]:
    """Write both schema files into ``directory``; return their paths.

    ``fresh``: generate them from the specs (imports pydantic); else copy the shipped ones
    (``mechkin schema --write DIR``, no pydantic import)."""
    out = []
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    for kind in KINDS:
        p = d / file_name(kind)
        p.write_text(generate(kind) if fresh else schema_text(kind), encoding="utf-8")
        out.append(p)
    return out


def _present(*keys: str) -> dict:
    """Subschema: every key of ``keys`` is given and not null."""
    return {"required": list(keys), "properties": {k: {"not": {"type": "null"}} for k in keys}}


def _not_both(a: str, b: str) -> dict:
    return {"not": _present(a, b)}


def _when(key: str, values: list, then: dict) -> dict:
    return {"if": {"required": [key], "properties": {key: {"enum": values}}}, "then": then}


def _given_none(*keys: str) -> dict:
    """Subschema: none of ``keys`` is written at all (not even as null)."""
    return {"not": {"anyOf": [{"required": [k]} for k in keys]}}


# the key groups of WorkspaceSpec._check (written keys count, as pydantic's model_fields_set)
_WS_LEE = ("parameters", "alpha", "beta", "isotropy_maps", "gamma_range", "design")
_WS_SWEEP = ("joints", "samples", "frame", "voxel", "slices", "seed_from", "mode_jump")
_WS_TASK = ("positions", "orientation", "weights", "restarts", "max_iter")

# Cross-field rules that JSON Schema can express, mirroring the pydantic validators.
RULES: dict[str, list[dict]] = {
    "JointSpec": [
        _not_both("dh", "origin"), _not_both("dh", "axis"),
        _when("type", ["universal", "spherical"], {"not": {"anyOf": [_present("dh"),
                                                                     _present("axis")]}}),
        _when("type", ["revolute", "prismatic"], {"not": _present("axes")}),
    ],
    "VisualSpec": [
        {"oneOf": [_present("mesh"), _present("box"), _present("cylinder"), _present("sphere")]},
        {"if": _present("scale"), "then": _present("mesh")},
    ],
    "ExpectSpec": [
        {"anyOf": [_present("value"), _present("min"), _present("max")]},
        {"not": {"allOf": [_present("value"), {"anyOf": [_present("min"), _present("max")]}]}},
    ],
    "MotionSpec": [
        _when("type", ["constant"], _present("value")),
        _when("type", ["ramp"], _present("from", "to")),
        _when("type", ["sinusoid"], _present("amplitude", "frequency")),
    ],
    "BaseSpec": [
        {"oneOf": [_present("pose"), _present("motion"), _present("table"), _present("csv")]},
    ],
    "FkSpec": [
        {"oneOf": [_present("motion"), _present("table"), _present("csv")]},
        {"if": _present("motion"), "then": _present("time")},
        {"if": _present("assembly_at"),
         "then": {"required": ["assembly"], "properties": {"assembly": {"const": "all"}}}},
    ],
    "TrackSpec": [
        {"if": {"not": {"required": ["objective"], "properties": {"objective": {"const":
                                                                                "time"}}}},
         "then": _present("conveyor")},
    ],
    "GammaRangeSpec": [_when("mode", ["component"], _present("ref"))],
    "ExecutorSpec": [
        _when("kind", ["dask"], _present("address")),
        {"if": {"not": {"required": ["kind"], "properties": {"kind": {"const": "dask"}}}},
         "then": {"not": _present("address")}},
    ],
    "PositionAxisSpec": [
        {"oneOf": [_present("value"), _present("range")]}, _not_both("value", "n"),
    ],
    "LegTaskSpec": [_not_both("position", "below_hip")],
    "BipedSpec": [
        {"oneOf": [_present("sequence"), _present("mode")]},
        {"if": _present("sequence"), "then": {"not": {"anyOf": [_present("legs"),
                                                                _present("name")]}}},
    ],
    "WorkspaceSpec": [
        _not_both("poses", "poses_csv"),
        _when("kind", ["lee_spherical"], {"allOf": [
            _given_none(*_WS_SWEEP, *_WS_TASK, "characteristic_length"),
            {"properties": {"method": {"enum": ["closed_form", "svd", None]}}}]}),
        _when("kind", ["joint_sweep"], {"allOf": [
            _given_none(*_WS_LEE, *_WS_TASK),
            {"not": {"anyOf": [_present("poses"), _present("poses_csv")]}},
            {"required": ["method"], "properties": {"method": {"enum": ["grid",
                                                                        "monte_carlo"]}}},
            _when("method", ["monte_carlo"], _present("samples")),
            _when("method", ["grid"], {"not": _present("samples")})]}),
        _when("kind", ["task_space"], _given_none(*_WS_LEE, "joints", "voxel", "slices",
                                                  "manipulability", "seed_from", "mode_jump")),
    ],
    "ScenarioSpec": [
        _when("task", ["fk"], _present("fk")),
        _when("task", ["ik"], {"oneOf": [_present("ik"), _present("biped")]}),
        _when("task", ["track"], _present("track")),
        _when("task", ["workspace"], _present("workspace")),
        _when("task", ["fk", "ik"], _present("mechanism")),
    ] + [
        _when("task", [t], {"not": {"anyOf": [_present(s) for s in
                                              ("fk", "ik", "biped", "track", "workspace")
                                              if s not in own]}})
        for t, own in (("fk", ("fk",)), ("ik", ("ik", "biped")), ("track", ("track",)),
                       ("workspace", ("workspace",)))
    ],
}


def document(schema: dict) -> dict:
    """Add descriptions, defaults, examples and cross-field rules to a generated schema.

    Raises ValueError when a model property has no entry in :data:`FIELD_DOCS` or an entry
    names no property (the table must follow the specs)."""
    models = {schema["title"]: schema, **schema.get("$defs", {})}
    for name, model in models.items():
        props = model.get("properties", {})
        docs = FIELD_DOCS.get(name, {})
        stale = sorted(set(docs) - set(props))
        missing = sorted(k for k in props if k not in docs and not props[k].get("description"))
        if stale or missing:
            raise ValueError(f"{name}: FIELD_DOCS stale {stale}, missing {missing}")
        for key, prop in props.items():
            text = prop.get("description") or docs[key]
            if docs.get(key) and prop.get("description") and docs[key] != text:
                text = docs[key]
            default = prop.get("default")
            if default is not None and "Default" not in text:
                text += f" Default: {json.dumps(default)}."
            prop["description"] = text
            if key in EXAMPLES.get(name, {}):
                prop["examples"] = EXAMPLES[name][key]
        if not model.get("description"):
            model["description"] = f"{model.get('title', name)}."
        rules = RULES.get(name)
        if rules:
            model["allOf"] = list(model.get("allOf", [])) + rules
    return schema


if __name__ == "__main__":  # pragma: no cover - maintenance entry point
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parents[1] / "schemas"
    for p in write(target):
        print(p)

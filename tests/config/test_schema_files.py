"""The shipped JSON Schemas equal the ones generated from the specs (regenerate with
``python -m mechkin.config.schema_files``)."""

from __future__ import annotations

import json

import pytest

from mechkin.config import schema_files


@pytest.mark.parametrize("kind", schema_files.KINDS)
def test_shipped_schema_is_current(kind):
    shipped = schema_files.schema_text(kind)
    assert json.loads(shipped) == json.loads(schema_files.generate(kind)), (
        f"mechkin/schemas/{kind}.schema.json is stale: run python -m mechkin.config.schema_files")


def test_write_puts_both_files(tmp_path):
    paths = schema_files.write(tmp_path)
    assert sorted(p.name for p in paths) == ["mechanism.schema.json", "scenario.schema.json"]
    for p in paths:
        assert json.loads(p.read_text())["$schema"].startswith("https://json-schema.org/")

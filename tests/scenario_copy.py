"""A bundled scenario copied into a test's folder, for tests that edit one."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def local_scenario(tmp_path: Path, name: str, *edits: tuple[str, str]) -> Path:
    """A copy of ``scenarios/<name>.yaml`` in ``tmp_path`` with its mechanism path made
    absolute and the text edits ``(old, new)`` applied (each ``old`` must occur)."""
    s = (ROOT / "scenarios" / f"{name}.yaml").read_text()
    s = s.replace("../mechanisms/", f"{ROOT / 'mechanisms'}/")
    for a, b in edits:
        assert a in s, a
        s = s.replace(a, b)
    p = tmp_path / f"{name}.yaml"
    p.write_text(s)
    return p

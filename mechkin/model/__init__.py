"""spec -> immutable Mechanism; batched FK, Jacobians, loop closure (kim1995 §2, §5.1)."""

from __future__ import annotations

import contextlib
from functools import lru_cache
from pathlib import Path

from mechkin.model.mechanism import Cut, JointGroup, Mechanism


def load_mechanism(path: str | Path) -> Mechanism:
    """Read, validate and build a mechanism file (raises ConfigError on bad input).

    YAML, or URDF / MJCF through the importers (``mechkin.config.mechanism_file``)."""
    p = Path(path)
    try:
        key, mtime = str(p.resolve()), p.stat().st_mtime_ns
    except (OSError, ValueError):  # missing, a NUL byte, a name too long: read_yaml says which
        key, mtime = str(p), 0
    if p.suffix.lower() in (".urdf", ".xml", ".mjcf"):  # URDF / MJCF: the sidecar counts too
        side = p.with_name(p.stem + ".mechkin.yaml")
        with contextlib.suppress(OSError, ValueError):
            mtime = (mtime, side.stat().st_mtime_ns if side.exists() else 0)
    return _load_cached(key, mtime)


@lru_cache(maxsize=32)
def _load_cached(path: str, mtime) -> Mechanism:
    from mechkin.config.mechanism_file import read_mechanism_spec
    from mechkin.model.build import build_mechanism

    spec, doc = read_mechanism_spec(path)
    return build_mechanism(spec, doc)


__all__ = ["Cut", "JointGroup", "Mechanism", "load_mechanism"]

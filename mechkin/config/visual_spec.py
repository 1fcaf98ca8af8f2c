"""The ``visuals:`` key of a link: what a viewer draws for it (a URDF ``<visual>``).

``links: [{name: upper_arm, visuals: [{mesh: package://ur_description/meshes/upperarm.dae,
xyz: [0, 0, 0.1], rpy: [0, 0, 1.5708], rgba: [0.7, 0.7, 0.7, 1]}]}]`` -- one geometry per entry:
``mesh`` (a URI: ``package://``, ``file://``, ``http(s)://``; or a path, relative to the
mechanism file), ``box`` (full sizes x, y, z), ``cylinder`` ([radius, length] along z) or
``sphere`` (radius); placed by ``xyz`` + ``rpy`` in the link frame; ``scale`` of a mesh
(dimensionless: the mesh file keeps its own unit); ``rgba`` in 0..1. ``mechkin import`` writes
these from a URDF's ``<visual>`` elements and an MJCF file's geoms; a link without visuals is
drawn with geometry generated from the kinematics (:mod:`mechkin.tasks.robot`). mechkin never
opens a mesh file: it is referenced by URI in the URDF of the MCAP logs and of
``mechkin export``.

Imports: pydantic and the standard library only (``mechkin.config.schema`` imports this).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

_Num = Annotated[float, Field(strict=True, allow_inf_nan=False)]
_Pos = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0)]
_Vec3 = Annotated[list[_Num], Field(min_length=3, max_length=3)]
_Pos3 = Annotated[list[_Pos], Field(min_length=3, max_length=3)]
_Unit = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=1)]

#: URI schemes a mesh may be given in (a URDF viewer resolves these); anything else is a path
MESH_SCHEMES = ("package", "file", "http", "https")
_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.\-]*)://")
GEOMETRIES = ("mesh", "box", "cylinder", "sphere")


class VisualSpec(BaseModel):
    """A visual element of a link: one geometry (mesh, box, cylinder or sphere), its pose in
    the link frame and its colour."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    mesh: Annotated[str, Field(min_length=1, max_length=4096)] | None = None
    scale: _Vec3 | None = None
    box: _Pos3 | None = None
    cylinder: Annotated[list[_Pos], Field(min_length=2, max_length=2)] | None = None
    sphere: _Pos | None = None
    xyz: _Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: _Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rgba: Annotated[list[_Unit], Field(min_length=4, max_length=4)] | None = None

    @field_validator("mesh", mode="after")
    @classmethod
    def _mesh_uri(cls, v: str | None) -> str | None:
        if v is None:
            return v
        if any(ord(c) < 32 for c in v):
            raise ValueError("expected a URI or path without control characters")
        m = _SCHEME.match(v)
        if m and m.group(1).lower() not in MESH_SCHEMES:
            raise ValueError(f"expected a {', '.join(s + '://' for s in MESH_SCHEMES)} URI or "
                             f"a path, got the scheme {m.group(1)!r}")
        if m and len(v) == len(m.group(0)):
            raise ValueError(f"expected a path after {m.group(0)!r}")
        return v

    @model_validator(mode="after")
    def _one_geometry(self) -> VisualSpec:
        given = [g for g in GEOMETRIES if getattr(self, g) is not None]
        if len(given) != 1:
            raise ValueError("expected exactly one geometry of mesh, box, cylinder, sphere, got "
                             + (", ".join(given) if given else "none"))
        if self.scale is not None and self.mesh is None:
            raise ValueError("scale goes with mesh")
        if self.scale is not None and 0.0 in self.scale:  # negative: mirrored (URDF allows)
            raise ValueError(f"scale: expected nonzero numbers, got {self.scale}")
        return self


def mesh_uri(mesh: str, base_dir: str | Path | None) -> str:
    """A mesh reference as a URI: ``package://``, ``file://`` and ``http(s)://`` as given; a
    path (absolute, or relative to ``base_dir``, default the working directory) as a
    ``file://`` URI. Pure string work: the file is never opened or even looked at."""
    if _SCHEME.match(mesh):
        return mesh
    p = mesh if os.path.isabs(mesh) else os.path.join(os.fspath(base_dir or os.getcwd()), mesh)
    return Path(os.path.normpath(os.path.abspath(p))).as_uri()

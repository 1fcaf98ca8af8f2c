"""The visual elements a mechanism file gives its links (``links[].visuals``,
:mod:`mechkin.config.visual_spec`), as the built mechanism carries them.

They are not kinematics: the model only keeps them, in SI, with mesh references turned into
URIs (a path relative to the mechanism file becomes a ``file://`` URI; no mesh file is opened),
for the URDF in the MCAP logs and ``mechkin export`` (:mod:`mechkin.tasks.robot`).

Imports: config (the spec, the URI rule), spatial.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mechkin.config.schema import MechanismSpec
from mechkin.config.visual_spec import mesh_uri
from mechkin.spatial.transforms import transform_from_xyz_rpy

__all__ = ["LinkVisual", "link_visuals_of"]


@dataclass(frozen=True, eq=False)
class LinkVisual:
    """One visual of a link: ``shape`` mesh | box | cylinder | sphere; ``T`` (4, 4) its pose in
    the link frame; ``size`` mesh scale (3,), box sizes (3,) [m], cylinder (radius, length) [m],
    sphere (radius,) [m]; ``rgba`` or None (the mesh's own colours); ``uri`` of a mesh."""

    link: str
    shape: str
    T: np.ndarray
    size: tuple[float, ...]
    rgba: tuple[float, float, float, float] | None = None
    uri: str = ""


def link_visuals_of(spec: MechanismSpec, source: Path | None) -> tuple[LinkVisual, ...]:
    """The ``visuals`` of every link of the SI ``spec``; mesh paths relative to ``source``'s
    folder (the working directory without a source file)."""
    base = source.parent if source is not None else None
    out = []
    for link in spec.links:
        for v in link.visuals:
            T = transform_from_xyz_rpy(v.xyz, v.rpy)
            if v.mesh is not None:
                shape, size = "mesh", tuple(v.scale or (1.0, 1.0, 1.0))
            elif v.box is not None:
                shape, size = "box", tuple(v.box)
            elif v.cylinder is not None:
                shape, size = "cylinder", tuple(v.cylinder)
            else:
                shape, size = "sphere", (float(v.sphere),)
            out.append(LinkVisual(link.name, shape, T, tuple(float(x) for x in size),
                                  tuple(float(x) for x in v.rgba) if v.rgba else None,
                                  mesh_uri(v.mesh, base) if v.mesh is not None else ""))
    return tuple(out)

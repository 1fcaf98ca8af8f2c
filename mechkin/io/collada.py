"""Extruded polygons as COLLADA meshes in ``data:`` URIs, for URDF ``<mesh>`` visuals of plates.

URDF has no polygon primitive. A plate (:class:`mechkin.records.robot.Visual` of shape
``prism``) becomes a COLLADA 1.4.1 document with ``<up_axis>Z_UP</up_axis>`` (so viewers do
not rotate it: Foxglove and Lichtblick rotate Y-up meshes only, RViz reads the axis too),
triangles with face normals, base64-encoded in a ``data:model/vnd.collada+xml`` URI that the
URDF embeds: the MCAP stays one file. (Lichtblick ``renderables/Urdfs.ts`` accepts ``data:``
URLs, ``ModelCache.ts`` picks the COLLADA loader by that media type.)

The polygon is triangulated as a fan around its centroid, right for convex and star-shaped
polygons (the drawing's hulls are convex; declared plates list their points in order).

Imports: numpy and the standard library only.
"""

from __future__ import annotations

import base64

import numpy as np

MEDIA_TYPE = "model/vnd.collada+xml"
__all__ = ["MEDIA_TYPE", "prism_collada", "prism_data_uri", "prism_triangles"]


def prism_triangles(polygon: np.ndarray, thickness: float) -> np.ndarray:
    """Triangles (t, 3, 3) of ``polygon`` (p, 2) in the xy plane extruded to z = +-t/2,
    counter-clockwise seen from outside."""
    P = np.asarray(polygon, dtype=float)
    c = P.mean(axis=0)
    area = 0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if area < 0:  # make the polygon counter-clockwise about +z
        P = P[::-1]
    h = 0.5 * float(thickness)
    top = np.c_[P, np.full(len(P), h)]
    bot = np.c_[P, np.full(len(P), -h)]
    ct, cb = np.r_[c, h], np.r_[c, -h]
    tris = []
    for i in range(len(P)):
        j = (i + 1) % len(P)
        tris.append((ct, top[i], top[j]))
        tris.append((cb, bot[j], bot[i]))
        tris.append((bot[i], bot[j], top[j]))
        tris.append((bot[i], top[j], top[i]))
    return np.asarray(tris)


def prism_collada(polygon: np.ndarray, thickness: float) -> str:
    """The COLLADA document of the extruded polygon (see the module docstring)."""
    tris = prism_triangles(polygon, thickness)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 0, n / np.where(norm > 0, norm, 1.0), 0.0)
    pos = " ".join(f"{x:.9g}" for x in tris.reshape(-1))
    nrm = " ".join(f"{x:.6g}" for x in n.reshape(-1))
    t = len(tris)
    idx = " ".join(f"{3 * k + v} {k}" for k in range(t) for v in range(3))
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n'
        '<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
        "<asset><unit name=\"meter\" meter=\"1\"/><up_axis>Z_UP</up_axis></asset>"
        '<library_geometries><geometry id="plate" name="plate"><mesh>'
        f'<source id="plate-pos"><float_array id="plate-pos-a" count="{9 * t}">{pos}'
        f'</float_array><technique_common><accessor source="#plate-pos-a" count="{3 * t}" '
        'stride="3"><param name="X" type="float"/><param name="Y" type="float"/>'
        '<param name="Z" type="float"/></accessor></technique_common></source>'
        f'<source id="plate-nrm"><float_array id="plate-nrm-a" count="{3 * t}">{nrm}'
        f'</float_array><technique_common><accessor source="#plate-nrm-a" count="{t}" '
        'stride="3"><param name="X" type="float"/><param name="Y" type="float"/>'
        '<param name="Z" type="float"/></accessor></technique_common></source>'
        '<vertices id="plate-vtx"><input semantic="POSITION" source="#plate-pos"/></vertices>'
        f'<triangles count="{t}"><input semantic="VERTEX" source="#plate-vtx" offset="0"/>'
        '<input semantic="NORMAL" source="#plate-nrm" offset="1"/>'
        f"<p>{idx}</p></triangles></mesh></geometry></library_geometries>"
        '<library_visual_scenes><visual_scene id="scene"><node id="plate-node">'
        '<instance_geometry url="#plate"/></node></visual_scene></library_visual_scenes>'
        '<scene><instance_visual_scene url="#scene"/></scene></COLLADA>\n'
    )


def prism_data_uri(polygon: np.ndarray, thickness: float) -> str:
    """``data:model/vnd.collada+xml;base64,...`` of :func:`prism_collada`."""
    doc = prism_collada(polygon, thickness).encode("utf-8")
    return f"data:{MEDIA_TYPE};base64,{base64.b64encode(doc).decode('ascii')}"

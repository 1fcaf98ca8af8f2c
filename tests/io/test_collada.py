"""Plates as extruded polygons in URDF meshes (mechkin.io.collada): the data URI decodes to a
COLLADA document, Z up, whose triangles close a solid of the polygon's area times the
thickness with every face normal pointing out."""

from __future__ import annotations

import base64
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from mechkin.io.collada import MEDIA_TYPE, prism_data_uri

NS = {"c": "http://www.collada.org/2005/11/COLLADASchema"}


def _triangles(uri: str) -> tuple[np.ndarray, np.ndarray, str]:
    head, b64 = uri.split(",", 1)
    assert head == f"data:{MEDIA_TYPE};base64"
    root = ET.fromstring(base64.b64decode(b64))
    up = root.find("c:asset/c:up_axis", NS).text
    mesh = root.find(".//c:mesh", NS)
    arrays = {a.get("id"): np.array(a.text.split(), float)
              for a in mesh.findall(".//c:float_array", NS)}
    pos = arrays["plate-pos-a"].reshape(-1, 3)
    nrm = arrays["plate-nrm-a"].reshape(-1, 3)
    tri = mesh.find("c:triangles", NS)
    idx = np.array(tri.find("c:p", NS).text.split(), int).reshape(int(tri.get("count")), 3, 2)
    return pos[idx[..., 0]], nrm[idx[:, 0, 1]], up


@pytest.mark.parametrize("clockwise", [False, True])
def test_prism_is_a_closed_outward_solid(clockwise):
    # a hexagon like the Stewart plates, and a non-regular convex pentagon
    for poly in (np.c_[np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3)],
                 np.array([[0.0, 0.0], [2.0, -0.5], [3.0, 1.0], [1.5, 2.5], [-0.5, 1.5]])):
        if clockwise:
            poly = poly[::-1]
        t = 0.05
        tris, normals, up = _triangles(prism_data_uri(poly, t))
        assert up == "Z_UP"
        area = 0.5 * abs(np.sum(poly[:, 0] * np.roll(poly[:, 1], -1)
                                - np.roll(poly[:, 0], -1) * poly[:, 1]))
        # divergence theorem: V = 1/6 sum a . (b x c) for a closed, outward-oriented surface
        vol = np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])).sum() / 6
        assert vol == pytest.approx(area * t, rel=1e-6)
        # every edge shared by two triangles, in opposite directions (watertight)
        edges = {}
        for k, tr in enumerate(np.round(tris, 9)):
            for a, b in ((0, 1), (1, 2), (2, 0)):
                edges.setdefault((tuple(tr[a]), tuple(tr[b])), []).append(k)
        assert all((b, a) in edges for a, b in edges)
        # normals point away from the solid's centre
        centre = tris.reshape(-1, 3).mean(axis=0)
        assert np.all(np.einsum("ij,ij->i", normals, tris.mean(axis=1) - centre) > 0)
        assert np.allclose(np.abs(tris[..., 2]), t / 2)

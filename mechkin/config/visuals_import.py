"""The visual elements of an imported robot file, carried to ``links[].visuals`` (issue 27).

Importers call one hook after reading their bodies: :func:`attach_urdf_visuals` (a URDF's
``<visual>`` elements, from yourdfpy's parse) or :func:`attach_mjcf_visuals` (an MJCF file's
geoms). Each entry lands on the ``TreeLink`` of its body as ``{"T": (4, 4) pose in the body
frame, one geometry key, "scale"?, "rgba"?}``; ``mechkin.config.tree_import.tree_to_spec``
moves the entries of bodies that become named frames onto their link (poses composed).

- meshes are referenced, never opened: ``package://``, ``file://`` and ``http(s)://`` URIs as
  the file gives them, a path (relative to the robot file, or absolute) as a ``file://`` URI
  (:func:`mechkin.config.visual_spec.mesh_uri`); a mesh file that is not on disk is still
  referenced (a viewer shows it missing);
- URDF: ``box``, ``cylinder``, ``sphere``, ``mesh`` (with ``scale``), the material colour (the
  visual's own ``<color>`` or the robot-level ``<material>`` of that name); ``<collision>`` is
  not drawn; meshes in other URI schemes (``data:``, ``model://``) are left out with a note,
  and so are the visuals ``mechkin export`` generated (``<visual name="mechkin_generated">``:
  a re-imported export is drawn as the original was);
- MJCF: the geoms MuJoCo's viewer shows by default (groups 0-2, alpha > 0): ``mesh`` (the
  asset's file and ``scale``, relative to ``meshdir``), ``box``, ``cylinder``, ``sphere``, and
  ``capsule`` as a cylinder and two spheres; planes, ellipsoids, height fields and SDFs are
  left out. Poses come from MuJoCo's compiler (defaults, ``euler`` in degrees, ``fromto``,
  ``<frame>`` all applied) run on a copy of the model whose mesh geoms are small spheres (the
  compiler would move a mesh geom to the mesh's centre of mass; the sphere keeps the pose the
  file wrote), so no mesh file is read for the visuals either; the colour is the geom's
  ``rgba``, else its material's.

May import: config, errors, numpy, mujoco (passed in).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.config.load import note_once
from mechkin.config.visual_spec import MESH_SCHEMES, mesh_uri

__all__ = ["attach_mjcf_visuals", "attach_urdf_visuals"]

_MARK = "__mechkin_visual_"
GENERATED = "mechkin_generated"  # mechkin.io.urdf_out.GENERATED (config does not import io)
#: a URI scheme (two letters at least: ``C:\\`` is a Windows path)
_ANY_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.\-]+):")


def _by_name(links: list[Any]) -> dict[str, Any]:
    return {lk.name: lk for lk in links}


def attach_urdf_visuals(links: list[Any], robot: Any, path: Path) -> None:
    """Put the ``<visual>`` elements of yourdfpy's ``robot`` on the TreeLinks of the same name."""
    colours = {m.name: m.color.rgba for m in (robot.materials or ())
               if m.name and m.color is not None and m.color.rgba is not None}
    tree_links = _by_name(links)
    skipped: dict[str, int] = {}
    for lk in robot.links:
        target = tree_links.get(lk.name)
        if target is None:
            continue
        for v in lk.visuals or ():
            g = v.geometry
            if g is None or v.name == GENERATED:  # mechkin export's own geometry
                continue
            e: dict[str, Any] = {"T": np.asarray(v.origin if v.origin is not None
                                                 else np.eye(4), dtype=float)}
            if g.mesh is not None and g.mesh.filename:
                scheme = _ANY_SCHEME.match(str(g.mesh.filename))
                if scheme and scheme.group(1).lower() not in MESH_SCHEMES:
                    skipped[scheme.group(1)] = skipped.get(scheme.group(1), 0) + 1
                    continue
                e["mesh"] = mesh_uri(str(g.mesh.filename), path.parent)
                if g.mesh.scale is not None:
                    s = np.broadcast_to(np.asarray(g.mesh.scale, dtype=float), (3,))
                    if not np.allclose(s, 1.0):
                        e["scale"] = [float(x) for x in s]
            elif g.box is not None:
                e["box"] = [float(x) for x in g.box.size]
            elif g.cylinder is not None:
                e["cylinder"] = [float(g.cylinder.radius), float(g.cylinder.length)]
            elif g.sphere is not None:
                e["sphere"] = float(g.sphere.radius)
            else:
                continue
            m = v.material
            rgba = None
            if m is not None:
                rgba = m.color.rgba if m.color is not None else colours.get(m.name)
            if rgba is not None and np.all(np.isfinite(rgba)):
                e["rgba"] = [float(min(max(x, 0.0), 1.0)) for x in rgba]
            if usable(e):
                target.visuals.append(e)
            else:
                skipped["degenerate"] = skipped.get("degenerate", 0) + 1
    if skipped:
        what = ", ".join(f"{n} {k}" + ("" if k == "degenerate" else ":")
                         for k, n in sorted(skipped.items()))
        note_once(path, f"{path.name}: note: left out {what} <visual> elements (mechkin draws "
                         "boxes, cylinders, spheres of positive size and meshes by "
                         f"{', '.join(s + '://' for s in MESH_SCHEMES)} URI or path)\n")


def usable(e: dict[str, Any]) -> bool:
    """Whether an entry fits ``links[].visuals``: finite pose, sizes > 0, scale finite and
    nonzero (a mirrored mesh has a negative one)."""
    if not np.all(np.isfinite(e["T"])):
        return False
    sizes = e.get("box", e.get("cylinder", [e["sphere"]] if "sphere" in e else []))
    scale = e.get("scale", [1.0])
    mesh = e.get("mesh", "-")
    if len(mesh) > 4096 or any(ord(c) < 32 for c in mesh):  # visual_spec's limits
        return False
    return (all(np.isfinite(x) and x > 0 for x in sizes)
            and all(np.isfinite(x) and x != 0 for x in scale))


def attach_mjcf_visuals(links: list[Any], mujoco: Any, path: Path, bodies: list[str]) -> None:
    """Put the visible geoms of the MJCF file on the TreeLinks of their bodies (``bodies``: the
    importer's body names by MuJoCo body id). A file whose copy does not compile gets no
    visuals (one note): the kinematics never depend on them."""
    try:
        model, meshes, skip = _visual_model(mujoco, path)
    except Exception as exc:  # noqa: BLE001 - visuals are optional; the import goes on
        why = " ".join(str(exc).split())[:200]
        note_once(path, f"{path.name}: note: no visuals imported ({why})\n")
        return
    if model.nbody != len(bodies):
        return
    G = mujoco.mjtGeom
    tree_links = _by_name(links)
    obj = mujoco.mjtObj.mjOBJ_GEOM
    default_rgba = np.array([0.5, 0.5, 0.5, 1.0])
    for g in range(model.ngeom):
        target = tree_links.get(bodies[int(model.geom_bodyid[g])])
        name = mujoco.mj_id2name(model, obj, g) or ""
        rgba = np.asarray(model.geom_rgba[g], dtype=float)
        mat = int(model.geom_matid[g])
        if mat >= 0 and np.allclose(rgba, default_rgba):
            rgba = np.asarray(model.mat_rgba[mat], dtype=float)
        if (target is None or name in skip or int(model.geom_group[g]) > 2
                or not rgba[3] > 0):
            continue
        T = np.eye(4)
        T[:3, 3] = model.geom_pos[g]
        T[:3, :3] = _quat_matrix(model.geom_quat[g])
        size = [float(x) for x in model.geom_size[g]]
        typ = int(model.geom_type[g])
        base = {"rgba": [float(min(max(x, 0.0), 1.0)) for x in rgba]}
        if name in meshes:
            uri, scale = meshes[name]
            e = {"T": T, "mesh": uri} | base
            if not np.allclose(scale, 1.0):
                e["scale"] = [float(x) for x in scale]
            _add(target, e)
        elif typ == G.mjGEOM_BOX:
            _add(target, {"T": T, "box": [2.0 * x for x in size]} | base)
        elif typ == G.mjGEOM_SPHERE:
            _add(target, {"T": T, "sphere": size[0]} | base)
        elif typ in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
            _add(target, {"T": T, "cylinder": [size[0], 2.0 * size[1]]} | base)
            if typ == G.mjGEOM_CAPSULE:  # URDF has no capsule: two end spheres
                for sign in (-1.0, 1.0):
                    Te = T.copy()
                    Te[:3, 3] = T[:3, 3] + sign * size[1] * T[:3, 2]
                    _add(target, {"T": Te, "sphere": size[0]} | base)


def _add(target: Any, e: dict[str, Any]) -> None:
    if usable(e):
        target.visuals.append(e)


def _visual_model(mujoco: Any, path: Path) -> tuple[Any, dict[str, tuple[str, list[float]]],
                                                    set[str]]:
    """(the compiled copy, {geom name: (mesh URI, scale)}, names of geoms not to draw)."""
    spec = mujoco.MjSpec.from_file(str(path))
    G = mujoco.mjtGeom
    mesh_dir = Path(spec.modelfiledir or path.parent)
    if spec.meshdir:
        mesh_dir = mesh_dir / spec.meshdir
    files = {}
    for m in spec.meshes:
        if m.file:  # a mesh given by its vertices has no file to reference
            f = Path(m.file).name if spec.strippath else m.file
            files[m.name] = (mesh_uri(f, mesh_dir), [float(x) for x in m.scale])
    taken = {g.name for g in spec.geoms if g.name}
    meshes: dict[str, tuple[str, list[float]]] = {}
    skip: set[str] = set()
    for i, g in enumerate(spec.geoms):
        if g.type not in (G.mjGEOM_MESH, G.mjGEOM_SDF, G.mjGEOM_HFIELD) and not g.meshname:
            continue
        if not g.name:
            g.name = _MARK + str(i)
            while g.name in taken:
                g.name += "_"
        if g.type == G.mjGEOM_MESH and g.meshname in files:
            meshes[g.name] = files[g.meshname]
        else:
            skip.add(g.name)
        g.type = G.mjGEOM_SPHERE  # keeps the pose the file wrote (see the module docstring)
        g.size = [0.01, 0.0, 0.0]
        g.meshname = ""
        g.hfieldname = ""
    for mat in spec.materials:
        mat.textures = [""] * len(mat.textures)
    for kind in ("meshes", "textures", "hfields", "skins"):
        for x in list(getattr(spec, kind)):
            spec.delete(x)
    return spec.compile(), meshes, skip


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

"""Geometry for stick drawings of a mechanism (kim1995 Figs. 2, 4, 6 style).

DESIGN. A link is drawn through the points where it meets other bodies: its *hub* (the point of
the joint that carries it; the origin for the base), the points of the joints it carries, its
link origin and its named frames (tool points, cut frames). A joint's point is the origin of its
axis frame ``W = T_base_parent A Z(q)`` (:meth:`Kinematics.axes`), so a prismatic joint's point
slides with ``q``. Links are segments from the hub to each other point -- joint to joint along
the tree, never spokes from the base origin. A *plate* (a body with three or more joints, like
the Stewart base and moving plates) is a filled polygon instead: declared in the mechanism file
(``drawing: plates:``, through named frames or joints, in the written order) or, when nothing is
declared for the link and ``drawing.auto_plates`` holds, the convex hull of its hub, joint
points and cut frames when it closes a loop (has a cut frame) or carries three joints, and
those points are not collinear and lie in one plane. Points of a plated link that lie off the
plate hang from the hub when the hub is on the plate, else from the nearest plate vertex.

Everything the layout needs (which point connects to which, the hull order) is fixed in the
link frame, so it is worked out once per mechanism at home and cached on it; a batch of
configurations then costs one gather of joint points and frame origins.

Imports: model.kinematics, model.mechanism, spatial.transforms (config only for the type of
the ``drawing:`` spec).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mechkin.model.kinematics import Kinematics, forward_kinematics
from mechkin.model.mechanism import Mechanism

__all__ = ["PlateLayout", "StickDrawing", "frame_tree", "plate_layouts", "plate_polygons",
           "resolve_plates", "skeleton_segments", "stick_drawing"]

Ref = tuple[str, int]  # ("frame", frame index), ("joint", joint index), ("centroid", plate)
_REL = 1e-6  # relative tolerance (of the link's size) for coplanar / collinear / coincident


@dataclass(frozen=True)
class PlateLayout:
    """A plate of one link: a polygon through ``refs`` (in drawing order)."""

    name: str
    link: int
    refs: tuple[Ref, ...]
    declared: bool


@dataclass(frozen=True)
class StickDrawing:
    """The drawing of m configurations, every point in the base frame [m].

    segments : (m, s, 2, 3) link segments, joint to joint.
    plates : name -> (m, p, 3) polygon vertices in drawing order.
    joints : (m, n, 3) joint points (origins of the joint axis frames).
    frames : (m, nf, 4, 4) every frame's pose (for triads of the end effector).
    """

    segments: np.ndarray
    plates: dict[str, np.ndarray]
    joints: np.ndarray
    frames: np.ndarray


# --------------------------------------------------------------------------- declared plates


def _home_kin(mech: Mechanism) -> Kinematics:
    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    return forward_kinematics(mech, q0)


def _positions(mech: Mechanism, kin: Kinematics, refs: list[Ref] | tuple[Ref, ...],
               frames: np.ndarray | None = None,
               plates: tuple[PlateLayout, ...] | list[PlateLayout] = ()) -> np.ndarray:
    """Points (m, k, 3) of ``refs`` (``("centroid", k)``: the mean vertex of ``plates[k]``)."""
    if frames is None:
        frames = kin.frames(mech)[..., :3, 3]
    jo = kin.axes()[1]
    if not refs:
        return np.zeros((kin.q.shape[0], 0, 3))

    def one(kind: str, i: int) -> np.ndarray:
        if kind == "frame":
            return frames[:, i]
        if kind == "joint":
            return jo[:, i]
        return _positions(mech, kin, plates[i].refs, frames).mean(axis=1)

    return np.stack([one(kind, i) for kind, i in refs], axis=1)


def _ref_links(mech: Mechanism, ref: Ref) -> set[int]:
    """Links a point is fixed on: a frame's link; a joint's child link, and its parent link
    unless it is prismatic (the point slides on the parent)."""
    kind, i = ref
    if kind == "frame":
        return {int(mech.frame_link[i])}
    out = {int(mech.joint_child_link[i])}
    if mech.s[i] == 0:
        out.add(int(mech.joint_parent_link[i]))
    return out


def resolve_plates(mech: Mechanism, drawing: Any, problems: Any) -> Mechanism:
    """The mechanism with the declared plates of ``drawing`` (a DrawingSpec) resolved.

    Each name is a frame (link or named frame) or else a joint (a compound joint by its
    written name: the point of its first axis). The points of one plate must lie on one link
    and not on one line at home. Problems go to ``problems`` (``add(key_path, msg)``,
    ``raise_if_any()``) as located ConfigErrors."""
    from mechkin.config.load import short, short_list

    frame_idx = {n: i for i, n in enumerate(mech.frame_names)}
    joint_idx = {n: i for i, n in enumerate(mech.joint_names)}
    for g in mech.groups:
        joint_idx.setdefault(g.name, g.joints[0])
    kin = _home_kin(mech)
    out: list[tuple[str, int, tuple[Ref, ...]]] = []
    seen: set[str] = set()
    for p, plate in enumerate(drawing.plates):
        kp = ("drawing", "plates", p)
        if plate.name in seen:
            problems.add(kp + ("name",), f"duplicate plate {short(plate.name)}")
            continue
        seen.add(plate.name)
        refs: list[Ref] = []
        ok = True
        for k, nm in enumerate(plate.frames):
            if nm in frame_idx:
                ref: Ref = ("frame", frame_idx[nm])
            elif nm in joint_idx:
                ref = ("joint", joint_idx[nm])
            else:
                problems.add(kp + ("frames", k), f"unknown frame or joint {short(nm)} (frames: "
                             f"{short_list(list(mech.frame_names))}; joints: "
                             f"{short_list([g.name for g in mech.groups])})")
                ok = False
                continue
            if ref in refs or nm in plate.frames[:k]:
                problems.add(kp + ("frames", k), f"{short(nm)} is listed twice")
                ok = False
            refs.append(ref)
        if not ok:
            continue
        common = set.intersection(*(_ref_links(mech, r) for r in refs))
        if not common:
            where = ", ".join(f"{nm} on {mech.link_names[min(_ref_links(mech, r))]}"
                              for nm, r in zip(plate.frames, refs, strict=True))
            problems.add(kp + ("frames",), f"the points of a plate must be fixed on one link, "
                         f"got {where}")
            continue
        pts = _positions(mech, kin, refs)[0]
        size = max(float(np.ptp(pts, axis=0).max()), 1e-12)
        sv = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
        if sv[1] <= _REL * size:
            problems.add(kp + ("frames",), "the points lie on one line at home: no polygon")
            continue
        out.append((plate.name, min(common), tuple(refs)))
    problems.raise_if_any()
    return replace(mech, plates=tuple(out), auto_plates=bool(drawing.auto_plates))


# --------------------------------------------------------------------------- layout


def _hull_order(pts: np.ndarray) -> list[int] | None:
    """Indices of the convex hull of planar points (k, 3), counter-clockwise in their best-fit
    plane; None when they are collinear or not coplanar."""
    size = max(float(np.ptp(pts, axis=0).max()), 1e-12)
    c = pts - pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(c, full_matrices=False)
    if len(sv) < 2 or sv[1] <= _REL * size * np.sqrt(len(pts)):
        return None
    if len(sv) > 2 and np.abs(c @ vt[2]).max() > _REL * size:
        return None
    uv = c @ vt[:2].T
    # Andrew's monotone chain
    order = sorted(range(len(uv)), key=lambda i: (round(uv[i, 0], 12), round(uv[i, 1], 12)))

    def cross(o: int, a: int, b: int) -> float:
        return float((uv[a, 0] - uv[o, 0]) * (uv[b, 1] - uv[o, 1])
                     - (uv[a, 1] - uv[o, 1]) * (uv[b, 0] - uv[o, 0]))

    tol = (_REL * size) ** 2
    lower: list[int] = []
    for i in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], i) <= tol:
            lower.pop()
        lower.append(i)
    upper: list[int] = []
    for i in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], i) <= tol:
            upper.pop()
        upper.append(i)
    hull = lower[:-1] + upper[:-1]
    return hull if len(hull) >= 3 else None


def _on_polygon(p: np.ndarray, poly: np.ndarray, size: float) -> bool:
    """Whether point p (3,) lies in the (planar, convex or not) polygon (k, 3)."""
    c = poly.mean(axis=0)
    _, _, vt = np.linalg.svd(poly - c, full_matrices=False)
    tol = _REL * max(size, 1e-12) * 10
    if len(vt) > 2 and abs(float((p - c) @ vt[2])) > tol:
        return False
    uv = (poly - c) @ vt[:2].T
    x, y = (p - c) @ vt[:2].T
    inside = False
    k = len(uv)
    for i in range(k):
        (x1, y1), (x2, y2) = uv[i], uv[(i + 1) % k]
        # on an edge
        ex, ey = x2 - x1, y2 - y1
        t = ((x - x1) * ex + (y - y1) * ey) / max(ex * ex + ey * ey, 1e-300)
        if 0 <= t <= 1 and np.hypot(x1 + t * ex - x, y1 + t * ey - y) <= tol:
            return True
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * ex / (y2 - y1):
            inside = not inside
    return inside


def _link_points(mech: Mechanism) -> list[tuple[Ref, list[Ref], list[Ref]]]:
    """Per link: (hub, other points, joint-like points for the hull: joints and cut frames)."""
    cut_frames = {c.a for c in mech.cuts} | {c.b for c in mech.cuts}
    out = []
    for L in range(mech.n_links):
        pj = int(mech.link_parent_joint[L])
        hub: Ref = ("joint", pj) if pj >= 0 else ("frame", L)
        others: list[Ref] = [("joint", int(j)) for j in np.flatnonzero(mech.joint_parent_link == L)]
        hull_pts: list[Ref] = [hub] + list(others)
        others.append(("frame", L))
        for f in range(mech.n_links, len(mech.frame_names)):
            if mech.frame_link[f] == L:
                others.append(("frame", f))
                if f in cut_frames:
                    hull_pts.append(("frame", f))
        if L in cut_frames and L != 0:
            hull_pts.append(("frame", L))
        out.append((hub, others, hull_pts))
    return out


def _layout(mech: Mechanism) -> tuple[tuple[PlateLayout, ...], tuple[tuple[Ref, Ref], ...]]:
    """(plates, segment end pairs) of ``mech``, worked out at home and cached on it."""
    cache = mech.__dict__.get("_drawing_layout")
    if cache is not None:
        return cache
    kin = _home_kin(mech)
    frames0 = kin.frames(mech)[..., :3, 3]

    def pos(refs: list[Ref] | tuple[Ref, ...]) -> np.ndarray:
        return _positions(mech, kin, refs, frames0)[0]

    plates = [PlateLayout(nm, link, refs, True) for nm, link, refs in mech.plates]

    def pos_any(r: Ref) -> np.ndarray:
        return _positions(mech, kin, [r], frames0, plates)[0, 0]

    declared_links = {p.link for p in plates}
    pairs: list[tuple[Ref, Ref]] = []
    for L, (hub, others, hull_pts) in enumerate(_link_points(mech)):
        mine = [p for p in plates if p.link == L]
        # a body closing loops (a cut frame) or carrying three joints, not a bracket of two
        n_cut = sum(1 for r in hull_pts[1:] if r[0] == "frame")
        if (not mine and mech.auto_plates and L not in declared_links
                and (n_cut >= 1 or len(hull_pts) - 1 - n_cut >= 3)):
            uniq: list[Ref] = []
            for r in hull_pts:
                if r not in uniq:
                    uniq.append(r)
            # drop coincident points (a compound joint's axes share one point)
            P = pos(uniq)
            size = max(float(np.ptp(P, axis=0).max()), 1e-12) if len(P) else 1.0
            keep = [i for i in range(len(uniq))
                    if not any(np.linalg.norm(P[i] - P[k]) <= _REL * size for k in range(i))]
            if len(keep) >= 3:
                order = _hull_order(P[keep])
                if order is None and len(keep) >= 4 and keep[0] == 0:
                    keep = keep[1:]  # the hub off the plane (a post under a plate)
                    order = _hull_order(P[keep])
                if order is not None:
                    p = PlateLayout(f"{mech.link_names[L]}", L,
                                    tuple(uniq[keep[i]] for i in order), False)
                    plates.append(p)
                    mine = [p]
        everyone = [hub] + [r for r in others if r != hub]
        if not mine:
            pairs.extend((hub, r) for r in everyone[1:])
            continue
        polys = [(p, pos(p.refs)) for p in mine]
        size = max(float(np.ptp(np.concatenate([pp for _, pp in polys]), axis=0).max()), 1e-12)

        def on_plate(r: Ref, polys: list = polys, size: float = size) -> bool:
            return (any(r in p.refs for p, _ in polys)
                    or any(_on_polygon(pos([r])[0], pp, size) for _, pp in polys))

        hub_on = on_plate(hub)
        x_hub = pos([hub])[0]
        for r in everyone:
            if on_plate(r) or (r != hub and np.linalg.norm(pos([r])[0] - x_hub) <= _REL * size):
                continue  # on the plate, or at the hub (drawn with it)
            if hub_on:  # off the plate, from the hub (a post on a base plate)
                pairs.append((hub, r))
                continue
            if r == hub:  # the hub off the plate: a post to the plate's centre
                pairs.append((("centroid", plates.index(mine[0])), hub))
                continue
            x = pos([r])[0]
            best = min(((p.refs[i], float(np.linalg.norm(pp[i] - x))) for p, pp in polys
                        for i in range(len(p.refs))), key=lambda t: t[1])
            pairs.append((best[0], r))
    # one segment per pair of places (a frame at a joint's point gives the same segment twice)
    ends = [(pos_any(a), pos_any(b)) for a, b in pairs] if pairs else []
    uniq_pairs = _distinct_segments(pairs, ends)
    cache = (tuple(plates), tuple(uniq_pairs))
    object.__setattr__(mech, "_drawing_layout", cache)
    return cache


def _distinct_segments(pairs: list[tuple[Ref, Ref]],
                       ends: list[tuple[np.ndarray, np.ndarray]]) -> list[tuple[Ref, Ref]]:
    """``pairs`` without the segments whose two ends are ``np.allclose`` to an earlier kept
    segment's (either direction); zero-length segments are all kept. Linear: the kept
    segments' first ends sit in a hash grid of cells as wide as allclose's tolerance here, so
    only the 27 cells around an end are compared (a 2000-joint chain: 4000 pairs, not 8e6)."""
    if not pairs:
        return []
    allp = np.array([x for ab in ends for x in ab], dtype=float).reshape(len(ends) * 2, -1)
    cell = 1e-8 + 1e-5 * float(np.abs(allp).max())  # >= allclose(atol, rtol * |y|) here
    grid: dict[tuple[int, ...], list[int]] = {}
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    out: list[tuple[Ref, Ref]] = []
    offsets = list(itertools.product((-1, 0, 1), repeat=allp.shape[1]))

    def key(x: np.ndarray) -> tuple[int, ...]:
        return tuple(int(v) for v in np.floor(x / cell))

    def near(x: np.ndarray) -> list[int]:
        k = key(x)
        return [i for d in offsets for i in grid.get(tuple(a + b for a, b in zip(k, d,
                                                                              strict=True)), ())]

    for pr, (xa, xb) in zip(pairs, ends, strict=True):
        if not np.allclose(xa, xb) and (
                any(np.allclose(xa, kept[i][0]) and np.allclose(xb, kept[i][1])
                    for i in near(xa))
                or any(np.allclose(xa, kept[i][1]) and np.allclose(xb, kept[i][0])
                       for i in near(xb))):
            continue
        grid.setdefault(key(xa), []).append(len(kept))
        kept.append((xa, xb))
        out.append(pr)
    return out


# --------------------------------------------------------------------------- drawings


def stick_drawing(mech: Mechanism, kin: Kinematics) -> StickDrawing:
    """Links (joint to joint), plates and joint points of the configurations ``kin``.

    Segments whose ends coincide in every configuration are left out."""
    plates, pairs = _layout(mech)
    T_f = kin.frames(mech)
    origins = T_f[..., :3, 3]
    m = kin.q.shape[0]
    if pairs:
        a = _positions(mech, kin, [p[0] for p in pairs], origins, plates)
        b = _positions(mech, kin, [p[1] for p in pairs], origins, plates)
        seg = np.stack([a, b], axis=2)
        length = np.linalg.norm(seg[:, :, 1] - seg[:, :, 0], axis=-1).max(axis=0) if m else None
        if length is not None:
            seg = seg[:, length > 1e-12]
    else:
        seg = np.zeros((m, 0, 2, 3))
    polys = {p.name: _positions(mech, kin, p.refs, origins) for p in plates}
    return StickDrawing(segments=seg, plates=polys, joints=kin.axes()[1], frames=T_f)


def plate_layouts(mech: Mechanism) -> tuple[PlateLayout, ...]:
    """The plates of ``mech`` (declared, then convex hulls), each on its link."""
    return _layout(mech)[0]


def plate_polygons(mech: Mechanism, kin: Kinematics) -> dict[str, np.ndarray]:
    """Plate name -> vertices (m, p, 3) in drawing order (declared plates, then hulls)."""
    plates, _ = _layout(mech)
    origins = kin.frames(mech)[..., :3, 3]
    return {p.name: _positions(mech, kin, p.refs, origins) for p in plates}


def skeleton_segments(mech: Mechanism, kin: Kinematics) -> np.ndarray:
    """Segments (m, s, 2, 3) in the base frame: the links joint to joint and every plate's
    outline (for line scenes such as the MCAP ``/scene``).

    Every frame and joint point is a segment end or lies inside a plate outline, so the summed
    segment lengths bound the distance of any frame from the base (used by ik's reach test)."""
    d = stick_drawing(mech, kin)
    seg = [d.segments]
    for poly in d.plates.values():
        seg.append(np.stack([poly, np.roll(poly, -1, axis=1)], axis=2))
    return np.concatenate(seg, axis=1)


def frame_tree(mech: Mechanism, kin: Kinematics) -> tuple[str, list[str], list[str], np.ndarray]:
    """(root, names, parents, T_parent_child (m, k, 4, 4)) of every link and named frame, for /tf:
    the URDF's spanning tree (:func:`mechkin.model.urdf_tree.urdf_frame_tree`), so the URDF
    in the MCAP and /tf agree link by link (a link hangs from its joint's parent link, through
    ``<link>_dh`` where the URDF has one; a named frame from its link).
    """
    from mechkin.model.urdf_tree import urdf_frame_tree

    return urdf_frame_tree(mech, kin)

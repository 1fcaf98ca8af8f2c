"""File units -> SI (m, rad), once, at the boundary (DESIGN.md: config/)."""

from __future__ import annotations

import math
from typing import Any

from mechkin.config.schema import MechanismSpec

LENGTH = {"m": 1.0, "mm": 1e-3}
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}


def length_factor(unit: str) -> float:
    return LENGTH[unit]


def angle_factor(unit: str) -> float:
    return ANGLE[unit]


def _scale(v: Any, f: float) -> Any:
    if v is None:
        return None
    if isinstance(v, list):
        return [_scale(x, f) for x in v]
    return float(v) * f


def mechanism_to_si(spec: MechanismSpec) -> MechanismSpec:
    """The same mechanism with every length in m and every angle in rad.

    Joint offsets, limits and home values are angles for revolute-type joints and lengths for
    prismatic ones (velocity limits: per s); torque limits stay N m (N); inertia tensors scale
    with length squared.
    """
    L = length_factor(spec.units.length)
    A = angle_factor(spec.units.angle)
    d = spec.model_dump()
    d["units"] = {"length": "m", "angle": "rad"}
    for link in d["links"]:
        for fr in link["frames"]:
            fr["xyz"] = _scale(fr["xyz"], L)
            fr["rpy"] = _scale(fr["rpy"], A)
        if link.get("inertial"):
            link["inertial"]["com"] = _scale(link["inertial"]["com"], L)
            link["inertial"]["inertia"] = _scale(link["inertial"]["inertia"], L * L)
        for v in link.get("visuals") or ():  # a mesh's scale is dimensionless
            v["xyz"], v["rpy"] = _scale(v["xyz"], L), _scale(v["rpy"], A)
            for key in ("box", "cylinder", "sphere"):
                if v.get(key) is not None:
                    v[key] = _scale(v[key], L)
    for j in d["joints"]:
        f = L if j["type"] == "prismatic" else A
        if j.get("dh"):
            dh = j["dh"]
            dh["a"], dh["d"] = dh["a"] * L, dh["d"] * L
            dh["alpha"], dh["theta"] = dh["alpha"] * A, dh["theta"] * A
        if j.get("origin"):
            j["origin"]["xyz"] = _scale(j["origin"]["xyz"], L)
            j["origin"]["rpy"] = _scale(j["origin"]["rpy"], A)
        j["offset"] = _scale(j["offset"], f)
        j["home"] = _scale(j["home"], f)
        j["limits"] = _scale(j["limits"], f)
        j["velocity_limit"] = _scale(j.get("velocity_limit"), f)
    if d.get("base_pose"):
        d["base_pose"]["xyz"] = _scale(d["base_pose"]["xyz"], L)
        d["base_pose"]["rpy"] = _scale(d["base_pose"]["rpy"], A)
    if d.get("couplings"):
        kinds = {j["name"]: j["type"] for j in d["joints"]}

        def factor(name: str) -> float:  # a compound joint's components are revolute
            return L if kinds.get(name) == "prismatic" else A

        for c in d["couplings"]:
            c["offset"] = c["offset"] * factor(c["joint"])
            c["multiplier"] = c["multiplier"] * factor(c["joint"]) / factor(c["master"])
    if d.get("gravity"):
        d["gravity"] = _scale(d["gravity"], L)
    return MechanismSpec.model_validate(d)

"""Schemas of the files users write (pydantic v2, unknown keys forbidden, numbers finite).

These models describe the files exactly as written (file units); ``mechkin.config.units``
converts them to SI once. ``mechkin schema mechanism|scenario`` prints their JSON Schemas.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from mechkin.config.drawing_spec import DrawingSpec
from mechkin.config.load import YamlDoc, format_key_path
from mechkin.config.visual_spec import VisualSpec
from mechkin.errors import ConfigError

Num = Annotated[float, Field(strict=True, allow_inf_nan=False)]
PosNum = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0)]
NonNegNum = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0)]
Vec3 = Annotated[list[Num], Field(min_length=3, max_length=3)]
Name = Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_.\-]*$")]
AxisName = Literal["x", "y", "z", "rx", "ry", "rz"]


#: joints of a floating base's virtual chain (``base: floating``): world x, y, z, then
#: R = Rz(yaw) Ry(pitch) Rx(roll) (URDF roll-pitch-yaw, as ``base_pose.rpy``)
FLOATING_JOINTS = ("base_x", "base_y", "base_z", "base_yaw", "base_pitch", "base_roll")


class Spec(BaseModel):
    """Base of every file schema: frozen, unknown keys are errors."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class Units(Spec):
    """Units of the numbers in this file; converted to SI (m, rad) once on loading."""

    length: Literal["m", "mm"] = "m"
    angle: Literal["rad", "deg"] = "rad"


class FrameSpec(Spec):
    """A named frame fixed on a link, placed by xyz + rpy (URDF roll-pitch-yaw) in the link
    frame."""

    name: Name
    xyz: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


class InertiaByName(Spec):
    """The inertia tensor by URDF's names (``<inertia ixx= ixy= ixz= iyy= iyz= izz=/>``)."""

    ixx: Num
    ixy: Num
    ixz: Num
    iyy: Num
    iyz: Num
    izz: Num


class InertialSpec(Spec):
    """Rigid-body parameters of a link, in the link frame.

    ``inertia`` about the centre of mass, in kg (length unit)^2: six numbers in the order
    [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (MuJoCo's fullinertia order), or by URDF's names
    ``{ixx, ixy, ixz, iyy, iyz, izz}`` (stored in the positional order).
    """

    mass: NonNegNum
    com: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    inertia: Annotated[list[Num], Field(min_length=6, max_length=6)] | InertiaByName = Field(
        default_factory=lambda: [0.0] * 6
    )

    @field_validator("inertia", mode="after")
    @classmethod
    def _positional(cls, v: Any) -> Any:
        if isinstance(v, InertiaByName):  # URDF names -> [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
            return [v.ixx, v.iyy, v.izz, v.ixy, v.ixz, v.iyz]
        return v


class LinkSpec(Spec):
    name: Name
    description: str | None = None
    frames: list[FrameSpec] = Field(default_factory=list)
    inertial: InertialSpec | None = None
    visuals: list[VisualSpec] = Field(default_factory=list)  # what viewers draw (visual_spec)


class DHSpec(Spec):
    """D-H parameters of the link the joint drives (convention from the file's ``dh_convention``).

    For a revolute joint ``theta`` is the constant offset added to q; for a prismatic joint ``d``
    is the offset added to q.
    """

    a: Num = 0.0
    alpha: Num = 0.0
    d: Num = 0.0
    theta: Num = 0.0


class OriginSpec(Spec):
    """Placement of the joint frame on its parent: translation xyz, then roll-pitch-yaw."""

    xyz: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


Limits = Annotated[list[Num], Field(min_length=2, max_length=2)]


class JointSpec(Spec):
    """A joint between a parent (link or named frame) and a child link.

    ``revolute``/``prismatic`` are 1-DOF; ``universal`` and ``spherical`` expand to 2 and 3
    revolute joints with concurrent axes (``axes``, successive body axes; default x-y and
    x-y-z), named ``<name>_1``, ``<name>_2``, ``<name>_3``. For compound joints ``offset``,
    ``limits``, ``home``, ``velocity_limit`` and ``torque_limit`` take one entry per axis (or
    one for every axis).

    ``velocity_limit`` (angle unit per s; length unit per s for prismatic joints) and
    ``torque_limit`` (N m; N for prismatic joints, as a track scenario's ``limits.qd`` and
    ``limits.torque``) are the joint's symmetric rate limits as its robot file gives them (URDF
    ``<limit velocity= effort=>``); ``mechkin export`` and the URDF in MCAPs write them. A
    track scenario does not take them as defaults: its ``limits:`` are the only ones it plans
    with.
    """

    name: Name
    type: Literal["revolute", "prismatic", "universal", "spherical"]
    parent: Name
    child: Name
    description: str | None = None
    dh: DHSpec | None = None
    origin: OriginSpec | None = None
    axis: Vec3 | None = None
    axes: list[Vec3] | None = None
    offset: Num | list[Num] = 0.0
    limits: Limits | list[Limits] | None = None
    home: Num | list[Num] = 0.0
    velocity_limit: PosNum | list[PosNum] | None = None
    torque_limit: PosNum | list[PosNum] | None = None

    @model_validator(mode="after")
    def _check_placement(self) -> JointSpec:
        if self.dh is not None and self.origin is not None:
            raise ValueError("give either dh or origin, not both")
        if self.dh is not None and self.type in ("universal", "spherical"):
            raise ValueError(f"a {self.type} joint is placed by origin, not dh")
        if self.dh is not None and self.axis is not None:
            raise ValueError("axis goes with origin; a D-H joint moves about/along z")
        if self.axes is not None and self.type not in ("universal", "spherical"):
            raise ValueError("axes is for universal and spherical joints; use axis")
        if self.axis is not None and self.type in ("universal", "spherical"):
            raise ValueError("use axes (one per revolute) for universal and spherical joints")
        n = {"universal": 2, "spherical": 3}.get(self.type, 1)
        if self.axes is not None and len(self.axes) != n:
            raise ValueError(f"a {self.type} joint has {n} axes, got {len(self.axes)}")
        for key in ("offset", "home", "velocity_limit", "torque_limit"):
            v = getattr(self, key)
            if n == 1 and isinstance(v, list):
                raise ValueError(f"{key}: expected one number for a {self.type} joint")
            if n > 1 and isinstance(v, list) and len(v) != n:
                raise ValueError(f"{key}: expected {n} numbers for a {self.type} joint")
        lim = self.limits
        if lim is not None:
            pairs = lim if (lim and isinstance(lim[0], list)) else [lim]
            if len(pairs) not in (1, n):
                raise ValueError(f"limits: expected one [lo, hi] pair (for every axis) or {n}, "
                                 f"got {len(pairs)}")
            for lo_hi in pairs:
                if len(lo_hi) != 2:  # type: ignore[arg-type]
                    raise ValueError(f"limits: expected a [lo, hi] pair, got {lo_hi}")
                if not lo_hi[0] < lo_hi[1]:  # type: ignore[index]
                    raise ValueError(f"limits: expected lo < hi, got {lo_hi}")
        return self


class CutSpec(Spec):
    """A cut link (kim1995 §2): two frames on two branches of the tree that must coincide.

    Six equations (relative position in frame a, vector part of the relative Euler parameters),
    or the subset named in ``mask``.
    """

    name: Name
    frames: Annotated[list[Name], Field(min_length=2, max_length=2)]
    mask: list[AxisName] | None = None
    description: str | None = None


class CouplingSpec(Spec):
    """A linear joint coupling (URDF ``<mimic>``, MJCF ``<equality><joint>``):
    ``joint = multiplier * master + offset``.

    The coupled ``joint`` is dependent: its row ``q_joint - multiplier q_master - offset`` is a
    constraint row of phi, solved with the loop closure. ``offset`` is in the coupled joint's
    unit (angle for revolute, length for prismatic); ``multiplier`` is in joint unit per master
    unit (file units).
    """

    joint: Name
    master: Name
    multiplier: Num = 1.0
    offset: Num = 0.0


class MechanismSpec(Spec):
    """A mechanism file: links, joints, cuts, independent joints, end effector, and optionally
    the ``closed_form`` (stewart, direct_drive, lee_spherical) that solves its inverse
    kinematics."""

    name: Name
    description: str | None = None
    notes: str | None = None
    units: Units = Field(default_factory=Units)
    dh_convention: Literal["standard", "modified"] = "standard"
    # the fixed link (default: the first link), or ``floating``: the first link moves, carried
    # by a 6-DOF virtual chain from the world (base_x, base_y, base_z, base_yaw, ..._roll)
    base: Name | None = None
    base_pose: OriginSpec | None = None  # home pose of a floating base (xyz, rpy)
    links: Annotated[list[LinkSpec], Field(min_length=1)]
    joints: list[JointSpec] = Field(default_factory=list)
    cuts: list[CutSpec] = Field(default_factory=list)
    couplings: list[CouplingSpec] = Field(default_factory=list)
    independent: list[Name] | None = None
    end_effector: Name | None = None
    gravity: Vec3 | None = None  # in the file's length unit per s^2 (default -9.81 m/s^2 z)
    drawing: DrawingSpec | None = None  # plates of the stick drawings (mechkin.model.drawing)
    closed_form: Literal["stewart", "direct_drive", "lee_spherical"] | None = Field(
        default=None,
        description="closed-form inverse kinematics that fits this structure; its parameters "
                    "are read from the geometry (mechkin.solvers.closed_form.recognise)")


def pydantic_problems(
    doc: YamlDoc, exc: ValidationError, prefix: tuple = (), model: type[BaseModel] | None = None
) -> list[str]:
    """Turn a pydantic ValidationError into ``file:line: key.path: message`` lines.

    Unions report one error per branch; only the first is kept for each key path, except that
    a list given to a number-or-list key reports its elements' errors.
    """
    out: list[str] = []
    seen_union: set[tuple] = set()
    errors = exc.errors(include_url=False)
    # a list given where a number or a list is allowed: report its elements, not "a number"
    lists = {tuple(e["loc"][:i]) for e in errors for i, x in enumerate(e["loc"])
             if _is_union_tag(x) and x.startswith("list[") and len(e["loc"]) > i + 1}
    for err in errors:
        raw = err["loc"]
        tag_at = next((i for i, x in enumerate(raw) if _is_union_tag(x)), None)
        loc = prefix + tuple(x for x in raw if not _is_union_tag(x))
        if tag_at is not None:
            key = prefix + tuple(raw[:tag_at])
            if tuple(raw[:tag_at]) in lists and not raw[tag_at].startswith("list["):
                continue
            if key in seen_union:
                continue
            seen_union.add(key)
        msg = err["msg"]
        typ = err["type"]
        if typ == "extra_forbidden":
            msg = "unknown key"
            keys = _keys_at(model, loc[len(prefix):-1]) if model is not None else []
            if keys:
                msg += f" (valid keys: {', '.join(keys)})"
        elif typ == "missing":
            msg = "required key is missing"
        elif "input" in err and typ not in ("value_error", "assertion_error"):
            s = repr(err["input"])
            if len(s) > 60:
                s = s[:57] + "..."
            msg = f"{msg}, got {s}"
            hint = number_hint(err["input"])
            if hint:
                msg = f"{msg}; {hint}"
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
        out.append(f"{doc.path}:{doc.line_of(loc)}: {format_key_path(loc)}: {msg}")
    return list(dict.fromkeys(out))


def number_hint(value: Any) -> str | None:
    """``did you mean the number 1e-6? write 1.0e-6`` for a string YAML read from a number
    written without a decimal point before its exponent (YAML 1.1), else None."""
    if not isinstance(value, str) or len(value) > 40:
        return None
    text = value.strip()
    try:
        x = float(text)
    except ValueError:
        return None
    if not math.isfinite(x) or text.lower() in ("nan", "inf", "infinity"):
        return None
    mant, e, exp = text.lower().partition("e")
    if e and exp[:1] not in "+-":
        exp = "+" + exp  # YAML 1.1 reads 1.0e6 as a string too
    fixed = (mant if "." in mant else f"{mant}.0") + (f"e{exp}" if e else "")
    return f"did you mean the number {text}? write {fixed}"


def _is_union_tag(x: Any) -> bool:
    """A pydantic union branch in an error location (``float``, ``list[float]``,
    ``constrained-str``, ``function-after[...]``), never a YAML key of a mechkin file."""
    return isinstance(x, str) and ("[" in x or x in ("float", "int", "str", "bool")
                                   or x.startswith(("constrained-", "function-"))
                                   or x in _spec_names())


def _spec_names() -> set[str]:
    """The names of the spec models (a union of models tags its branches with them)."""
    out: set[str] = set()
    todo = [Spec]
    while todo:
        c = todo.pop()
        for sub in c.__subclasses__():
            if sub.__name__ not in out:
                out.add(sub.__name__)
                todo.append(sub)
    return out


def _submodels(annotation: Any) -> list[type[BaseModel]]:
    import typing

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    found: list[type[BaseModel]] = []
    for arg in typing.get_args(annotation):
        found += _submodels(arg)
    return found


def _keys_at(model: type[BaseModel] | None, path: tuple) -> list[str]:
    """Valid keys of the mapping at ``path`` inside ``model`` (for 'unknown key' messages)."""
    current: list[type[BaseModel]] = [model] if model is not None else []
    for part in path:
        if isinstance(part, int):
            continue
        nxt: list[type[BaseModel]] = []
        for m in current:
            f = m.model_fields.get(part)
            if f is not None:
                nxt += _submodels(f.annotation)
        current = nxt
    return list(current[0].model_fields) if current else []


def validate_model(doc: YamlDoc, model: type[Spec], data: Any, prefix: tuple = ()) -> Any:
    """Validate ``data`` against ``model``; raise ConfigError listing every problem."""
    if not isinstance(data, dict):
        raise ConfigError(
            f"{doc.path}:{doc.line_of(prefix)}: {format_key_path(prefix)}: expected a mapping "
            f"of keys, got {type(data).__name__}"
        )
    try:
        with _no_pydantic_plugins():
            return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(pydantic_problems(doc, exc, prefix, model)) from None


@contextlib.contextmanager
def _no_pydantic_plugins() -> Iterator[None]:
    """Build the (deferred) validators of the specs without pydantic's plugin search: its first
    use reads the entry points of every installed distribution (20-50 ms of a ``mechkin``
    call), for plugins that file schemas have no use for. As typer builds its adapters; a
    ``PYDANTIC_DISABLE_PLUGINS`` set by the user is left alone."""
    import os

    if "PYDANTIC_DISABLE_PLUGINS" in os.environ:
        yield
        return
    os.environ["PYDANTIC_DISABLE_PLUGINS"] = "1"
    try:
        yield
    finally:
        os.environ.pop("PYDANTIC_DISABLE_PLUGINS", None)

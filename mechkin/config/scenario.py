"""Scenario files: the task, the mechanism, the inputs, outputs wanted and ``expect:`` checks.

The common part is validated here; each task's own section (``fk:``, ``ik:``, ``track:``,
``workspace:``) is validated by the model registered for it in ``TASK_SECTIONS``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from mechkin.config.load import YamlDoc, note_once, read_yaml, short, short_str, short_tail
from mechkin.config.schema import Name, Num, PosNum, Spec, Units, Vec3, validate_model
from mechkin.errors import ConfigError

# ---- fk ---------------------------------------------------------------------------------------


class TimeSpec(Spec):
    """A uniform time grid [s]: start, stop (inclusive) and step."""

    start: Num = 0.0
    stop: PosNum
    step: PosNum


class MotionSpec(Spec):
    """Motion of one independent joint (values in the file's units; t in s).

    constant: value. ramp: from -> to, linear over the time span. sinusoid:
    offset + amplitude * sin(2 pi frequency t + phase).
    """

    type: Literal["constant", "ramp", "sinusoid"]
    value: Num | None = None
    start: Num | None = Field(default=None, alias="from")
    to: Num | None = None
    offset: Num = 0.0
    amplitude: Num | None = None
    frequency: Num | None = None
    phase: Num = 0.0

    @model_validator(mode="after")
    def _check(self) -> MotionSpec:
        need = {"constant": ("value",), "ramp": ("start", "to"),
                "sinusoid": ("amplitude", "frequency")}[self.type]
        missing = [("from" if k == "start" else k) for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"a {self.type} motion needs {', '.join(missing)}")
        return self


class ToleranceSpec(Spec):
    """Newton-Raphson tolerances of the loop closure (kim1995 §5.1: epsilon_v, epsilon_w)."""

    phi: PosNum = 1e-12
    dq: PosNum = 1e-12
    max_iter: Annotated[int, Field(strict=True, ge=1, le=10000)] = 50


#: The six coordinates of a base pose: translation (file length unit) and URDF roll-pitch-yaw
#: (file angle unit; R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes, as mechanism frames).
BASE_COORDS = ("x", "y", "z", "roll", "pitch", "yaw")
BaseCoord = Literal["x", "y", "z", "roll", "pitch", "yaw"]


class BasePoseSpec(Spec):
    """A constant base pose: ``xyz`` (file length unit) and URDF ``rpy`` (file angle unit)."""

    xyz: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


class BaseSpec(Spec):
    """``fk: base:``: the pose of the mechanism's base frame {0} in a world frame, T_0(t)
    (kim1995 §5.1 Step 1, the homogeneous transform of the base frame in the inertial frame).

    Give exactly one of: ``pose`` (constant ``xyz`` + ``rpy``), ``motion`` (a generator per
    coordinate ``x``, ``y``, ``z``, ``roll``, ``pitch``, ``yaw``, the same ``constant`` / ``ramp``
    / ``sinusoid`` forms as the joints, evaluated at the fk times; coordinates not given stay
    0), ``table`` (columns ``t`` and any of the six coordinates) or ``csv`` (a file with
    ``t_s`` and any of ``x_m|x_mm``, ..., ``roll_rad|roll_deg``, ...). A table or CSV is
    interpolated at the fk times by a not-a-knot cubic spline (quadratic / linear / constant
    for 3 / 2 / 1 rows), and its times must cover the fk times. ``frame``: name of the world
    frame in the MCAP frame tree.
    """

    pose: BasePoseSpec | None = None
    motion: dict[BaseCoord, MotionSpec] | None = None
    table: dict[Name, list[Num]] | None = None
    csv: str | None = None
    frame: Name = "world"

    @model_validator(mode="after")
    def _one_source(self) -> BaseSpec:
        given = [k for k in ("pose", "motion", "table", "csv") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of pose, motion, table or csv, got "
                             f"{', '.join(given) or 'none'}")
        return self


class FkSpec(Spec):
    """``fk:`` section: the motion of the independent joints.

    Give exactly one of: ``time`` + ``motion`` (generators per joint), ``table`` (columns ``t``
    and one per independent joint), or ``csv`` (a file with a ``t_s`` column and one column per
    independent joint named ``<joint>_rad``, ``<joint>_deg``, ``<joint>_m`` or ``<joint>_mm``).

    ``assembly``: ``one`` (default) or ``all``: also every assembly mode of the loop closure at
    the first configuration of the motion (and at each ``assembly_at`` configuration of the
    independent joints, by name in the file's units), by seeded multi-start Newton-Raphson
    from ``assembly_starts`` starts; the motion itself follows the mode of ``initial_guess``.

    ``base``: a moving (or displaced) base T_0(t) (:class:`BaseSpec`); frame poses, twists and
    accelerations are then reported in its world frame.

    ``base_pose``: the constant pose (``xyz`` + URDF ``rpy``, file units) of a floating base
    (``base: floating``, an MJCF free joint): the six base joints ``base_x`` .. ``base_roll``
    take it at every step (name them in the motion, table or CSV instead for a moving or
    per-row base; a base joint not given rests at the mechanism's home base pose).
    """

    time: TimeSpec | None = None
    motion: dict[Name, MotionSpec] | None = None
    table: dict[Name, list[Num]] | None = None
    csv: str | None = None
    initial_guess: dict[Name, Num] | None = None
    tolerances: ToleranceSpec = Field(default_factory=ToleranceSpec)
    snapshots: Annotated[int, Field(strict=True, ge=1, le=12)] = 4
    assembly: Literal["one", "all"] = "one"
    assembly_starts: Annotated[int, Field(strict=True, ge=1, le=100_000)] = 256
    assembly_at: list[dict[Name, Num]] | None = None
    base: BaseSpec | None = None
    base_pose: BasePoseSpec | None = None

    @model_validator(mode="after")
    def _one_source(self) -> FkSpec:
        given = [k for k in ("motion", "table", "csv") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of motion (with time), table or csv, "
                             f"got {', '.join(given) or 'none'}")
        if self.motion is not None and self.time is None:
            raise ValueError("motion needs time: {start, stop, step}")
        if self.assembly_at is not None and self.assembly != "all":
            raise ValueError("assembly_at needs assembly: all")
        return self


# ---- common -----------------------------------------------------------------------------------


class OutputsSpec(Spec):
    """What a run writes: CSV tables (``csv``), PNG plots (``plots``), an MCAP log (``mcap``);
    ``table`` is the format of the tables: ``csv`` (text, the default), ``npz`` (numpy, one
    array per column) or ``parquet`` (needs pyarrow: ``pip install "mechkin[parquet]"``)."""

    csv: bool = True
    plots: bool = True
    mcap: bool = True
    table: Literal["csv", "npz", "parquet"] = Field(
        "csv", description="format of the tables: csv (text), npz (numpy arrays, one per CSV "
        "column, same names) or parquet (needs pyarrow)")

    @field_validator("table")
    @classmethod
    def _table_writer_installed(cls, v: str) -> str:
        if v == "parquet":
            import importlib.util

            try:
                found = importlib.util.find_spec("pyarrow") is not None
            except (ImportError, ValueError, AttributeError):
                found = False
            if not found:
                raise ValueError('parquet tables need pyarrow, which is not installed: pip '
                                 'install "mechkin[parquet]" (or use table: npz)')
        return v


class ExpectSpec(Spec):
    """A reference value checked after the run: ``key`` is a dot path into summary.json
    (``targets.0.q_v.q1``). Either ``value`` (a number or list) with an absolute ``tol``, or
    bounds ``min`` and/or ``max``; ``unit`` is the unit of the numbers when not SI (deg, mm).
    A key ending in ``status`` takes a word as ``value`` (``{key: status, value: unreachable}``):
    a scenario that asserts a failure passes when it fails that way."""

    key: Annotated[str, Field(min_length=1)]
    value: Num | list[Num] | Annotated[str, Field(min_length=1, max_length=64)] | None = None
    tol: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0)] = 0.0
    min: Num | None = None
    max: Num | None = None
    unit: Literal["rad", "deg", "m", "mm", "s", "1"] | None = None
    source: str | None = None

    @model_validator(mode="after")
    def _value_or_bounds(self) -> ExpectSpec:
        if self.value is None and self.min is None and self.max is None:
            raise ValueError("give value (with tol) or min/max")
        if self.value is not None and (self.min is not None or self.max is not None):
            raise ValueError("give value (with tol) or min/max, not both")
        if isinstance(self.value, str):
            from mechkin.config.schema import number_hint

            hint = number_hint(self.value)
            if hint:
                raise ValueError(f"value: {hint}")
            if self.key.split(".")[-1] != "status":
                raise ValueError(f"value: a word ({self.value[:40]!r}) is compared only with a "
                                 "status key (key: status or key: targets.0.status); give a "
                                 "number here")
            if self.tol or self.unit is not None:
                raise ValueError("a status value takes no tol or unit")
        return self


class ScenarioSpec(Spec):
    name: Name
    task: Literal["fk", "ik", "track", "workspace"]
    description: str | None = None
    mechanism: str | None = None
    units: Units = Field(default_factory=Units)
    fk: dict[str, Any] | None = None
    ik: dict[str, Any] | None = None
    track: dict[str, Any] | None = None
    workspace: dict[str, Any] | None = None
    biped: dict[str, Any] | None = None
    outputs: OutputsSpec = Field(default_factory=OutputsSpec)
    expect: list[ExpectSpec] = Field(default_factory=list)


TASK_SECTIONS: dict[str, type[Spec]] = {"fk": FkSpec}
# the sections each task accepts (exactly one must be present): an ik scenario is either general
# precision points (``ik:``) or the biped's closed-form classes (``biped:``, hwang2023)
SECTIONS_OF_TASK = {"fk": ("fk",), "ik": ("ik", "biped"), "track": ("track",),
                    "workspace": ("workspace",)}
ALL_SECTIONS = ("fk", "ik", "biped", "track", "workspace")
MECHANISM_OPTIONAL = {"track", "workspace"}


def register_task_section(section: str, model: type[Spec]) -> None:
    """Register the schema of a section (task modules add theirs without touching this file)."""
    TASK_SECTIONS[section] = model


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: common spec, its task section, resolved mechanism path."""

    spec: ScenarioSpec
    section: Any
    doc: YamlDoc
    mechanism_path: Path | None
    section_name: str = ""

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def path(self) -> Path:
        return self.doc.path


#: The module that registers each built-in section on import (loaded when a scenario has that
#: section, so a run builds only the models of its own task).
SECTION_MODULES = {"ik": "mechkin.config.ik_spec", "track": "mechkin.config.track_spec",
                   "workspace": "mechkin.config.workspace_spec",
                   "biped": "mechkin.config.biped_spec"}


def _register_builtin_sections(*sections: str) -> None:
    """Import the spec modules that register the built-in sections (all of them, or only those
    of ``sections``), lazily, to keep import light."""
    import importlib

    for sec in sections or tuple(SECTION_MODULES):
        mod = SECTION_MODULES.get(sec)
        if mod is None or sec in TASK_SECTIONS:
            continue
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if exc.name != mod:
                raise


def load_scenario(path: str | Path, doc: YamlDoc | None = None) -> Scenario:
    """Read and validate a scenario file (raises ConfigError listing every problem).

    ``doc``: the file already parsed by :func:`mechkin.config.load.read_yaml` (read once)."""
    if doc is None:
        doc = read_yaml(path)
    spec = validate_model(doc, ScenarioSpec, doc.data)
    problems: list[str] = []
    allowed = SECTIONS_OF_TASK[spec.task]
    present = [k for k in allowed if getattr(spec, k) is not None]
    if len(present) != 1:
        want = " or ".join(f"'{k}:'" for k in allowed)
        problems.append(f"{doc.where((spec.task,))}: a {spec.task} scenario needs exactly one "
                        f"{want} section")
    section_name = present[0] if present else spec.task
    section = getattr(spec, section_name)
    for other in ALL_SECTIONS:
        if other not in allowed and getattr(spec, other) is not None:
            problems.append(f"{doc.where((other,))}: section '{other}' does not belong in a "
                            f"{spec.task} scenario")
    mech_path = None
    if spec.mechanism is None:
        if spec.task not in MECHANISM_OPTIONAL:
            problems.append(f"{doc.where(('mechanism',))}: required key is missing")
    else:
        try:
            mech_path = (doc.path.parent / spec.mechanism).resolve()
            found = mech_path.is_file()
        except (OSError, ValueError):  # a NUL byte, a name too long, a loop of links
            mech_path, found = doc.path.parent / spec.mechanism, False
        if not found:
            problems.append(f"{doc.where(('mechanism',))}: mechanism file not found: "
                            f"{short_str(spec.mechanism)} (resolved to "
                            f"{short_tail(mech_path, 80)})")
    if problems:
        raise ConfigError(problems)
    _register_builtin_sections(section_name)
    model = TASK_SECTIONS.get(section_name)
    if model is None:
        raise ConfigError(f"{doc.where((section_name,))}: section {short(section_name)} is not "
                          "available in this version")
    parsed = validate_model(doc, model, section, prefix=(section_name,))
    if spec.units.angle == "rad":
        _note_degrees_read_as_radians(doc, section, (section_name,))
    return Scenario(spec=spec, section=parsed, doc=doc, mechanism_path=mech_path,
                    section_name=section_name)


def scenario_json_schema() -> dict[str, Any]:
    """JSON Schema of scenario files, with each task section's schema filled in."""
    _register_builtin_sections()
    schema = ScenarioSpec.model_json_schema()
    props = schema.get("properties", {})
    defs = schema.setdefault("$defs", {})
    # the built-in sections in a fixed order (they register as scenarios are loaded), then
    # any registered by other modules
    order = ["fk", *SECTION_MODULES] + [k for k in TASK_SECTIONS
                                        if k != "fk" and k not in SECTION_MODULES]
    for task in order:
        model = TASK_SECTIONS[task]
        sub = model.model_json_schema(ref_template="#/$defs/{model}")
        defs.update(sub.pop("$defs", {}))
        defs[model.__name__] = sub
        props[task] = {"anyOf": [{"$ref": f"#/$defs/{model.__name__}"}, {"type": "null"}]}
    return schema


def _note_degrees_read_as_radians(doc: YamlDoc, node: Any, at: tuple) -> None:
    """One note for the first orientation angle (``rpy``, ``euler.angles``) above 2 pi in a
    file whose angle unit is rad (the default): ``rpy: [180, 0, 0]`` is then 180 rad, almost
    surely meant in degrees. A note, not a refusal: the numbers are valid."""
    stack = [(at, node)]
    while stack:
        path, v = stack.pop()
        if isinstance(v, dict):
            for k, w in reversed(v.items()):  # popped in the file's order
                if k in ("rpy", "angles") and isinstance(w, list):
                    big = [x for x in w if isinstance(x, (int, float)) and not isinstance(x, bool)
                           and abs(x) > 2 * math.pi + 1e-9]
                    if big:
                        note_once(doc.path, f"{doc.where((*path, k))}: note: {big[0]:g} is read "
                                  "as radians (the file's angle unit is rad, the default); if "
                                  "you meant degrees, set 'units: {angle: deg}'")
                        return
                stack.append(((*path, k), w))
        elif isinstance(v, list) and len(v) <= 100_000:
            stack.extend(((*path, i), w) for i, w in reversed(list(enumerate(v))))

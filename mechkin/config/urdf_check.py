"""URDF elements checked before yourdfpy reads them, so a malformed file is refused with the
file's path, the real line and name of the offending element and the fix (issue 25 item 5).

yourdfpy parses a whole ``<robot>`` at once and raises bare Python errors (``'name'``,
``could not convert string to float``, ``'NoneType' object has no attribute 'get'``) with no
place in the file. :func:`element_problems` checks, on the raw XML with lxml's line numbers,
what mechkin reads from each element: names, joint type, parent and child, origins, axes,
limits, mimic numbers, inertials. :func:`locate_rejection` is the fallback for anything else
yourdfpy refuses: each ``<link>``, ``<joint>`` and ``<material>`` is parsed alone with
yourdfpy's own element parser to find the one that fails. :func:`nonfinite_numbers` (URDF and
MJCF) flags every numeric attribute that is not all finite numbers, at its element.

One line per problem: ``file:line: joint[j2].origin.xyz: expected 3 numbers, got '0.3 0';
fix: ...``; an element without a name is labelled by its place (``joint (unnamed, 2.)``).

Imports: the standard library; yourdfpy in :func:`locate_rejection` (the elements are lxml's).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def _label(e: Any, k: int) -> str:
    name = e.get("name")
    return f"{e.tag}[{name}]" if name else f"{e.tag} (unnamed, {k}.)"


def _numbers(text: str | None, n: int) -> list[float] | None:
    """n finite numbers from a whitespace-separated attribute, else None."""
    try:
        v = [float(x) for x in (text or "").split()]
    except ValueError:
        return None
    return v if len(v) == n and all(math.isfinite(x) for x in v) else None


def _vector(out: list[str], path: Path, e: Any, attr: str, n: int, example: str,
            key: str) -> None:
    """An optional n-number attribute ``attr`` of element e (absent: yourdfpy's default);
    ``key`` the label of the message."""
    if e is None or e.get(attr) is None:
        return
    if _numbers(e.get(attr), n) is None:
        what = f"{n} finite numbers" if n > 1 else "a finite number"
        out.append(f"{path}:{e.sourceline}: {key}: expected {what}, got "
                   f"{_short(e.get(attr))}; fix: e.g. {attr}=\"{example}\"")


def _short(s: str | None) -> str:
    s = "" if s is None else s
    return repr(s if len(s) <= 40 else s[:37] + "...")


def _origin(out: list[str], path: Path, label: str, e: Any) -> None:
    o = e.find("origin")
    _vector(out, path, o, "xyz", 3, "0 0 0.1", f"{label}.origin.xyz")
    _vector(out, path, o, "rpy", 3, "0 0 1.5708", f"{label}.origin.rpy")


def _link_problems(path: Path, e: Any, k: int) -> list[str]:
    out: list[str] = []
    label = _label(e, k)
    if not e.get("name"):
        out.append(f"{path}:{e.sourceline}: {label}: missing name=\"...\"; fix: give every "
                   "<link> a unique name, e.g. <link name=\"forearm\">")
    inertial = e.find("inertial")
    if inertial is None:
        return out
    _origin(out, path, f"{label}.inertial", inertial)
    m = inertial.find("mass")
    if m is not None:
        v = _numbers(m.get("value", "0"), 1)
        if v is None or v[0] < 0:
            out.append(f"{path}:{m.sourceline}: {label}.inertial.mass.value: expected a "
                       f"finite number >= 0 [kg], got {_short(m.get('value'))}; fix: e.g. "
                       "<mass value=\"1.5\"/>")
    inertia = inertial.find("inertia")
    if inertia is not None:
        for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            _vector(out, path, inertia, a, 1, "0.01", f"{label}.inertial.inertia.{a}")
    return out


def _joint_problems(path: Path, e: Any, k: int, links: set[str]) -> list[str]:
    out: list[str] = []
    label = _label(e, k)
    line = e.sourceline
    if not e.get("name"):
        out.append(f"{path}:{line}: {label}: missing name=\"...\"; fix: give every <joint> a "
                   "unique name, e.g. <joint name=\"elbow\" type=\"revolute\">")
    typ = e.get("type")
    if typ is None:
        out.append(f"{path}:{line}: {label}.type: missing type=\"...\"; fix: type=\"revolute\", "
                   "\"continuous\", \"prismatic\" or \"fixed\"")
    elif typ not in JOINT_TYPES:
        out.append(f"{path}:{line}: {label}.type: {_short(typ)[1:-1]} joints are not supported "
                   "(mechkin joints: revolute, continuous, prismatic, fixed); fix: "
                   "type=\"revolute\", \"continuous\", \"prismatic\" or \"fixed\"")
    for end in ("parent", "child"):
        p = e.find(end)
        if p is None or not p.get("link"):
            at = line if p is None else p.sourceline
            eg = "base_link" if end == "parent" else "link1"
            out.append(f"{path}:{at}: {label}.{end}: missing <{end} link=\"...\"/>; fix: name "
                       f"the {end} link, e.g. <{end} link=\"{eg}\"/>")
        elif links and p.get("link") not in links:
            out.append(f"{path}:{p.sourceline}: {label}.{end}: unknown link "
                       f"{_short(p.get('link'))} (no <link name=...> has that name); fix: "
                       "declare the link or correct the name")
    _origin(out, path, label, e)
    axis = e.find("axis")
    if axis is not None and axis.get("xyz") is not None:
        v = _numbers(axis.get("xyz"), 3)
        if v is None or (typ not in ("fixed", None) and not any(v)):
            out.append(f"{path}:{axis.sourceline}: {label}.axis.xyz: expected 3 finite numbers, "
                       f"not all zero, got {_short(axis.get('xyz'))}; fix: e.g. "
                       "<axis xyz=\"0 0 1\"/>")
    lim = e.find("limit")
    if lim is not None:
        bad = [f"{a}={_short(lim.get(a))}" for a in ("lower", "upper", "effort", "velocity")
               if lim.get(a) is not None and _numbers(lim.get(a), 1) is None]
        lo, hi = (_numbers(lim.get(a), 1) for a in ("lower", "upper"))
        if bad:
            out.append(f"{path}:{lim.sourceline}: {label}.limit: expected finite numbers, got "
                       f"{', '.join(bad)}; fix: e.g. <limit lower=\"-1.57\" upper=\"1.57\" "
                       "effort=\"10\" velocity=\"1\"/>")
        elif lo and hi and lo[0] > hi[0] and typ in ("revolute", "prismatic"):
            out.append(f"{path}:{lim.sourceline}: {label}.limit: expected lower <= upper, got "
                       f"lower={lo[0]:g}, upper={hi[0]:g}; fix: swap them")
    mimic = e.find("mimic")
    if mimic is not None:
        for a in ("multiplier", "offset"):
            _vector(out, path, mimic, a, 1, "1.0", f"{label}.mimic.{a}")
    return out


def element_problems(root: Any, path: Path) -> list[str]:
    """Every problem of the URDF's ``<link>`` and ``<joint>`` elements that mechkin reads or
    yourdfpy would refuse (module docstring), one located line each."""
    out: list[str] = []
    links = {e.get("name") for e in root.findall("link") if e.get("name")}
    for tag in ("link", "joint"):
        seen: dict[str, int] = {}
        for k, e in enumerate(root.findall(tag), start=1):
            out += (_link_problems(path, e, k) if tag == "link"
                    else _joint_problems(path, e, k, links))
            name = e.get("name")
            if name and name in seen:
                out.append(f"{path}:{e.sourceline}: {tag}[{name}]: duplicate name (the <{tag}> "
                           f"on line {seen[name]} has it too); fix: rename one of them")
            elif name:
                seen[name] = e.sourceline
    return out


def locate_rejection(root: Any, path: Path, exc: BaseException) -> str:
    """The one-line message of a file yourdfpy refuses for a reason :func:`element_problems`
    does not know: the first ``<link>``, ``<joint>`` or ``<material>`` that yourdfpy's own
    element parser refuses, with its line and name (else the ``<robot>`` element's line)."""
    import yourdfpy

    parsers = {"link": yourdfpy.URDF._parse_link, "joint": yourdfpy.URDF._parse_joint,
               "material": yourdfpy.URDF._parse_material}
    for tag, parse in parsers.items():
        for k, e in enumerate(root.findall(tag), start=1):
            try:
                parse(e)
            except Exception as err:  # yourdfpy raises assorted errors on malformed elements
                why = f"{type(err).__name__}: {err}" if str(err) else type(err).__name__
                return (f"{path}:{e.sourceline}: {_label(e, k)}: yourdfpy cannot read this "
                        f"element ({why[:160]}); fix: correct it against the URDF "
                        "specification (wiki.ros.org/urdf/XML)")
    why = f"{type(exc).__name__}: {exc}"
    return (f"{path}:{root.sourceline}: robot: not a valid URDF ({why[:160]}); fix: correct it "
            "against the URDF specification (wiki.ros.org/urdf/XML)")


def nonfinite_numbers(root: Any, path: Any, attrs: dict[str, tuple[str, ...]]) -> list[str]:
    """One line per numeric attribute (``attrs``: element tag -> attribute names) of an lxml
    tree that is not all finite numbers (``nan``, ``inf``, ``1e999``, a word), located at its
    element and named from the nearest named element (``joint[j1].origin.xyz``,
    ``body[b2].pos``): a NaN in an origin would otherwise surface after the import as several
    lines about derived values."""
    from mechkin.config.load import short_str

    out = []
    for el in root.iter():
        names = attrs.get(el.tag) if isinstance(el.tag, str) else None
        for a in names or ():
            raw = el.get(a)
            if raw is None:
                continue
            try:
                ok = bool(raw.split()) and all(math.isfinite(float(x)) for x in raw.split())
            except ValueError:
                ok = False
            if not ok:
                out.append(f"{path}:{el.sourceline}: {_owner(el)}.{a}: expected finite "
                           f"numbers, got {short_str(raw, 40)!r}")
    return out


def _owner(el: Any) -> str:
    from mechkin.config.load import short_str

    parts = []
    while el is not None and isinstance(el.tag, str):
        if el.get("name") is not None:
            parts.append(f"{el.tag}[{short_str(el.get('name'), 40)}]")
            break
        parts.append(el.tag)
        el = el.getparent()
    return ".".join(reversed(parts))

"""Serial arms written as mechanism YAML from a D-H table, for the analytic IK tests."""

from __future__ import annotations


def dh_arm_yaml(name: str, rows: list[tuple], limits: tuple = (-180, 180),
                prismatic_limits: tuple = (-0.5, 0.5)) -> str:
    """A standard-D-H serial arm (lengths m, angles deg) with a ``tool`` frame on its last
    link, every joint independent. ``rows``: ``(a, alpha, d)`` for a revolute joint, or
    ``(kind, a, alpha, d, theta)`` with kind ``"R"`` or ``"P"`` (prismatic, ``prismatic_limits``
    in m)."""
    n = len(rows)
    lines = [f"name: {name}", "units: {length: m, angle: deg}", "dh_convention: standard",
             "links:", "  - name: base"]
    lines += [f"  - name: l{i + 1}" for i in range(n - 1)]
    lines += [f"  - name: l{n}", "    frames:", "      - {name: tool, xyz: [0, 0, 0]}", "joints:"]
    parents = ["base"] + [f"l{i + 1}" for i in range(n - 1)]
    for i, row in enumerate(rows):
        kind, a, al, d, th = ("R", *row, None) if len(row) == 3 else row
        typ, lim = ("revolute", limits) if kind == "R" else ("prismatic", prismatic_limits)
        dh = f"a: {a}, alpha: {al}, d: {d}" + ("" if th is None else f", theta: {th}")
        lines.append(f"  - {{name: q{i + 1}, type: {typ}, parent: {parents[i]}, "
                     f"child: l{i + 1}, dh: {{{dh}}}, limits: [{lim[0]}, {lim[1]}]}}")
    lines += [f"independent: [{', '.join(f'q{i + 1}' for i in range(n))}]",
              "end_effector: tool"]
    return "\n".join(lines) + "\n"

"""The work of ``mechkin info MECH.yaml``: coordinates, cuts, equations, degrees of freedom,
mobility (no typer: :mod:`mechkin.cli.info` is the typer command)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from mechkin.cli.shell import echo, echo_json

if TYPE_CHECKING:
    from mechkin.model import Mechanism


#: Assembly modes at home printed by the text form of ``mechkin info``.
SHOW_MODES = 8


def show_info(mechanism: Path, json_out: bool) -> None:
    """Print the counts of ``mechkin info`` (text, or JSON with ``json_out``)."""
    info = run_info(mechanism=mechanism)
    if json_out:
        echo_json(info)
        return
    echo(f"{info['name']}: {info['description']}".rstrip(": "))
    echo(f"  joint coordinates (NC)    {info['n_coordinates']} "
         f"({info['n_revolute']} revolute, {info['n_prismatic']} prismatic)")
    echo(f"  links                     {info['n_links']}")
    echo(f"  cuts                      {info['n_cuts']}")
    if info.get("floating_base"):
        echo("  base                      floating (6-DOF virtual chain from the world: "
             "base_x, base_y, base_z, base_yaw, base_pitch, base_roll)")
    if info.get("couplings"):
        echo(f"  joint couplings           {len(info['couplings'])} ("
             + ", ".join(f"{c['joint']} = {c['multiplier']:g} {c['master']} {c['offset']:+g}"
                         for c in info["couplings"][:6])
             + (", ..." if len(info["couplings"]) > 6 else "") + ")")
    echo(f"  constraint equations (NE) {info['n_equations']} "
         f"(rank {info['constraint_rank']} at home)")
    ab = info["absolute"]
    echo(f"  absolute coordinates      NC {ab['n_coordinates']}, NE {ab['n_equations']} "
         f"({ab['formulation']}; kim1995 Table 10 after Haug 1989)")
    echo(f"  degrees of freedom        {info['dof']}")
    echo(f"  Grubler-Kutzbach mobility {info['mobility']}")
    if info.get("mobility_note"):
        echo(f"    note: {info['mobility_note']}")
    echo(f"  independent               {', '.join(info['independent'])}")
    echo(f"  dependent                 {', '.join(info['dependent']) or '-'}")
    echo(f"  end effector              {info['end_effector'] or '-'}"
         + (f" ({info['end_effector_note']})" if info.get("end_effector_note") else ""))
    for line in rate_limit_lines(info):
        echo(line)
    sing = info.get("singularity_at_home") or {}
    if sing:
        echo(f"  at home                   {sing.get('class', '?')}")
    modes = info.get("assembly_modes_at_home")
    if modes:
        echo(f"  assembly modes at home    {modes['count']} ({modes['within_limits']} within "
             "the limits; nearest home first; passive joints in rad / m)")
        for k, md in enumerate(modes["modes"][:SHOW_MODES]):
            qs = ", ".join(f"{n} {v:.6g}" for n, v in md["q_w"].items())
            echo(f"    {k}: {qs}{'' if md['within_limits'] else '  (outside limits)'}")
        if modes["count"] > SHOW_MODES:
            echo(f"    ... {modes['count'] - SHOW_MODES} more (--json lists them all)")


def run_info(*, mechanism: Path) -> dict[str, Any]:
    from mechkin.config.mechanism_file import is_robot_file, read_mechanism_spec
    from mechkin.model.build import build_mechanism

    if is_robot_file(mechanism):  # URDF / MJCF through the importers
        spec, doc = read_mechanism_spec(mechanism)
        return mechanism_info(build_mechanism(spec, doc))
    from mechkin.config.load import read_yaml
    from mechkin.errors import ConfigError

    doc = read_yaml(mechanism)
    if isinstance(doc.data, dict) and "task" in doc.data and "links" not in doc.data:
        raise ConfigError(f"{doc.where(('task',))}: this is a scenario file; 'mechkin info' "
                          "takes a mechanism file (its 'mechanism:' key names one)")
    spec, doc = read_mechanism_spec(mechanism, doc=doc)  # parsed once
    return mechanism_info(build_mechanism(spec, doc))


def mechanism_info(mech: Mechanism) -> dict[str, Any]:
    """Counts of kim1995 Table 10 (relative coordinates), dof from the rank, and mobility.

    Grubler-Kutzbach (spatial): M = 6 (N_bodies - 1) - sum(6 - f_i). With 1-DOF joints and cut
    links each merging two tree links into one body, M = n - sum over cuts of the equations.
    ``singularity_at_home``: condition numbers of d(phi)/d(q_w) and of the reduced end-effector
    Jacobian at home and the singularity class
    (:func:`mechkin.model.singularity.mechanism_singularity_at_home`).
    """
    import numpy as np

    from mechkin.model.kinematics import closure_jacobian, forward_kinematics
    from mechkin.model.singularity import mechanism_singularity_at_home

    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    _, J = closure_jacobian(mech, forward_kinematics(mech, q0))
    rank = int(np.linalg.matrix_rank(J[0], tol=1e-9)) if J.shape[1] else 0
    dof = mech.n - rank
    mobility = mech.n - mech.n_equations
    note = None
    if mobility != dof:
        note = (f"the constraint equations are dependent (rank {rank} < {mech.n_equations}): "
                "a planar or spherical loop, or an overconstrained mechanism; the degrees of "
                "freedom come from the rank")
    n_bodies = mech.n_links - mech.n_cuts - len(mech.virtual_links)
    kin0 = forward_kinematics(mech, q0)
    return {
        "name": mech.name,
        "description": mech.description,
        "source": str(mech.source) if mech.source else None,
        "n_coordinates": mech.n,
        "n_revolute": int((mech.s == 0).sum()),
        "n_prismatic": int((mech.s == 1).sum()),
        "n_links": mech.n_links,
        "n_bodies": n_bodies,
        "n_cuts": mech.n_cuts,
        "n_equations": mech.n_equations,
        "constraint_rank": rank,
        "dof": dof,
        "mobility": mobility,
        "mobility_note": note,
        "independent": mech.independent_names,
        "dependent": mech.dependent_names,
        "end_effector": mech.frame_names[mech.end_effector]
        if mech.end_effector is not None else None,
        "end_effector_note": getattr(mech, "end_effector_note", "") or None,
        "joints": [
            {"name": g.name, "type": g.type,
             "coordinates": [mech.joint_names[j] for j in g.joints],
             "velocity_limit": _given(mech.velocity_limit, g.joints),
             "torque_limit": _given(mech.torque_limit, g.joints)}
            for g in mech.groups
        ],
        "cuts": [
            {"name": c.name, "frames": [mech.frame_names[c.a], mech.frame_names[c.b]],
             "equations": int(c.mask.sum())}
            for c in mech.cuts
        ],
        "floating_base": bool(getattr(mech, "floating", False)),
        "couplings": [
            {"joint": mech.joint_names[c.joint], "master": mech.joint_names[c.master],
             "multiplier": c.multiplier, "offset": c.offset}
            for c in mech.couplings
        ],
        "absolute": absolute_counts(mech, kin0.axes()[0][0], n_bodies, J[0]),
        "singularity_at_home": mechanism_singularity_at_home(mech),
        "assembly_modes_at_home": modes_at_home(mech),
    }


def _given(values: Any, joints: tuple[int, ...]) -> list[float | None]:
    """The file's rate limit of each coordinate (SI), None where it gives none."""
    import math

    out: list[float | None] = []
    for j in joints:
        v = float(values[j]) if values is not None else math.inf
        out.append(v if math.isfinite(v) else None)
    return out


def rate_limit_lines(info: dict[str, Any]) -> list[str]:
    """The text lines of the mechanism's own velocity / torque limits (none if it gives none):
    what ``export`` writes into URDF ``<limit>``; a track scenario plans with its own
    ``limits:`` only."""
    rows = []
    for g in info["joints"]:
        for name, vel, tau, kind in zip(g["coordinates"], g["velocity_limit"],
                                        g["torque_limit"], [g["type"]] * len(g["coordinates"]),
                                        strict=True):
            if vel is None and tau is None:
                continue
            pris = kind == "prismatic"
            v = "-" if vel is None else f"{vel:.6g} {'m/s' if pris else 'rad/s'}"
            t = "-" if tau is None else f"{tau:.6g} {'N' if pris else 'N m'}"
            rows.append(f"    {name}: velocity {v}, torque {t}")
    if not rows:
        return []
    return ["  velocity / torque limits  from the file (export writes them; track uses only "
            "its scenario's limits:)"] + rows


def modes_at_home(mech: Mechanism) -> dict[str, Any] | None:
    """Every assembly mode found at the home independent joints
    (:func:`mechkin.solvers.assembly.assembly_modes`, 64 seeded starts and the limit corners;
    nearest home first), with its passive joints [SI] and whether it is within the
    limits; None for a mechanism without loops."""
    if not mech.is_closed or len(mech.dependent) == 0:
        return None
    import numpy as np

    from mechkin.solvers.assembly import assembly_modes

    home = np.where(np.isfinite(mech.home), mech.home, 0.0)
    with np.errstate(all="ignore"):
        m = assembly_modes(mech, home[mech.independent], starts=64, continuation=False)
    return {"count": m.count, "within_limits": int(np.sum(m.within_limits)),
            "modes": [{"q_w": {mech.joint_names[j]: float(m.q[k, j]) for j in mech.dependent},
                       "within_limits": bool(m.within_limits[k])} for k in range(m.count)]}


# Equations per joint in Haug's absolute coordinates (kim1995 ref. 13): spatial R and P 5, U 4,
# S 3; planar R and P 2.
_SPATIAL_EQ = {"revolute": 5, "prismatic": 5, "universal": 4, "spherical": 3, "floating": 0}


def absolute_counts(mech: Mechanism, axes: Any, n_bodies: int, J: Any) -> dict[str, Any]:
    """NC and NE of the same mechanism in absolute (Cartesian) coordinates, as kim1995 Table 10
    counts them after Haug (1989).

    Spatial: every body including the ground has 7 coordinates (position and 4 Euler
    parameters), with one normalisation equation per body, 6 equations fixing the ground, and
    5 / 4 / 3 equations per revolute or prismatic / universal / spherical joint. Planar: 3
    coordinates per body, 3 fixing the ground, 2 per revolute or prismatic joint. A cut link is
    one body, so the joints are the joint groups of the tree.

    kim1995 counts a mechanism whose loops are planar (every joint of a loop, i.e. every
    column of the closure Jacobian ``J`` (NE, n) at home that is not zero, about one axis
    direction, revolute or prismatic) in planar coordinates: the direct-drive arm's 18 / 15. The
    spatial counts are given too (``spatial``).
    """
    import numpy as np

    types = [g.type for g in mech.groups]
    nk = len(mech.couplings)  # a joint coupling is one equation in either formulation
    spatial = {"n_coordinates": 7 * n_bodies,
               "n_equations": n_bodies + 6 + sum(_SPATIAL_EQ[t] for t in types) + nk}
    planar = None
    z = np.asarray(axes, dtype=float).reshape(-1, 3)
    J = np.asarray(J, dtype=float)
    J = J[: J.shape[0] - nk] if J.ndim == 2 else J  # the loops: cut rows (couplings come last)
    in_loop = np.flatnonzero(np.linalg.norm(J, axis=0) > 1e-12) if J.size else np.zeros(0, int)
    if in_loop.size and np.all(mech.s[in_loop] <= 1):
        zl = z[in_loop]
        if np.all(np.linalg.norm(np.cross(zl, zl[0]), axis=1) < 1e-9) and all(
                t in ("revolute", "prismatic") for t in types):
            planar = {"n_coordinates": 3 * n_bodies, "n_equations": 3 + 2 * len(types) + nk}
    main = planar if planar is not None else spatial
    return {**main, "formulation": "planar (3 per body)" if planar is not None else
            "spatial (7 per body: position and Euler parameters)",
            "spatial": spatial, "planar": planar, "n_bodies_with_ground": n_bodies}

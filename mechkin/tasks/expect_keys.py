"""What the summary of each task holds below its top-level keys, for checking ``expect:`` keys at
any depth before the run (:func:`deep_key_problem`; :mod:`mechkin.tasks.validate` calls it).

A template is a nested dict of the keys a summary section holds; its leaves say what a key
holds: :data:`NUM` a number, :data:`STR` a word (a status: compared with a word ``value``),
:data:`VEC` a list of numbers (a key may go one index deeper), :data:`MAT` a list of rows
(two indices), :class:`Items` a list of records, :class:`Names` a mapping keyed by joint
names, :data:`ANY` a section whose inner keys vary with the run (not checked below it). The
templates are read from the tasks' summary builders (``mechkin.tasks.fk``, ``ik``, ``track``,
``workspace``); tests/cli/test_check_predicts_run.py compares them with real summaries.

Imports: the standard library only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

NUM, STR, VEC, MAT, ANY = "number", "word", "list of numbers", "matrix", "any"


@dataclass(frozen=True)
class Vec:
    """A list of ``n`` numbers (a 3-vector, a rotation matrix's row): an index must be < n."""

    n: int


V3 = Vec(3)
JV = Vec(-1)  # one number per joint of the mechanism
M3 = ("rows", 3)  # a 3 x 3 matrix
WORDS = "group of words"  # text (definitions, names): nothing to compare with a number


@dataclass(frozen=True)
class Counts:
    """Numbers keyed by status words (``()``: any words); a status that does not occur has no
    entry (an expect on it then fails in the run, exit 5)."""

    words: tuple[str, ...]


_IK_STATUSES = Counts(("ok", "not converged", "singular", "unreachable", "at a limit",
                       "infeasible"))
LIMIT_USAGE = "limit usage"  # <family>_<k>: the scenario's limit families and q, k = 1..n


@dataclass(frozen=True)
class Items:
    """A list of records, each like ``item``; ``count`` names the scenario's bound (or None)."""

    item: Any


@dataclass(frozen=True)
class Names:
    """A mapping keyed by joint names (``which``: all, independent or actuated joints)."""

    item: Any
    which: str = "all"


_POSE = {"frame": STR, "xyz_m": V3, "R": M3}
_STATS = {"count": NUM, "min": NUM, "max": NUM, "mean": NUM, "median": NUM, "p05": NUM,
          "p95": NUM}

FK = {
    "scenario": STR, "task": STR, "mechanism": STR, "status": STR, "n_steps": NUM,
    "steps": {"converged": NUM, "not converged": NUM, "singular": NUM,
              "constraint singularity": NUM, "outside limits": NUM},
    "first_failure_step": NUM, "assembly_start": STR,
    "closure": {"n_cuts": NUM, "n_equations": NUM, "max_residual": NUM, "iterations_mean": NUM,
                "iterations_max": NUM, "max_condition": NUM},
    "joints_outside_limits": WORDS, "solve_time_s": NUM, "time_per_step_s": NUM, "t_s": VEC,
    "final": {"q": Names(NUM), "end_effector": _POSE, "end_effector_in_base": _POSE},
    "singularity": {"counts": Counts(()),  # classes of mechkin.model.singularity
                    "max_cond_constraint": NUM, "max_cond_reduced": NUM,
                    "first_singular_step": NUM, "first_singular_t_s": NUM,
                    "first_near_step": NUM, "length_scale_m": NUM,
                    "thresholds": {"singular": NUM, "near": NUM}},
    "rates_time_s": NUM, "assembly_modes": ANY, "n_assembly_modes": NUM,
    "n_assembly_modes_within_limits": NUM, "assembly_mode_followed": ANY,
    "assembly_mode_from_home": ANY,
    "assembly_search": ANY, "assembly_at": ANY,
    "base": {"world_frame": STR, "source": STR, "final": {"xyz_m": V3, "R": M3},
             "max_speed_m_s": NUM, "max_angular_speed_rad_s": NUM,
             "max_acceleration_m_s2": NUM},
}

_IK_TARGET = {
    "name": STR, "status": STR, "q": Names(NUM), "q_v": Names(NUM, "independent"),
    "position_error": NUM, "orientation_error": NUM, "weights": Vec(6), "f": NUM,
    "grad_norm": NUM, "iterations": NUM, "evaluations": NUM, "time_s": NUM,
    "closure_residual": NUM, "joints_at_limit": WORDS, "target": {"xyz_m": V3, "R": M3},
    "end_effector": {"xyz_m": V3, "R": M3}, "restarts_used": NUM, "solutions": ANY,
    "n_solutions": NUM, "solutions_source": STR,
}
IK = {
    "scenario": STR, "task": STR, "mechanism": STR, "method": STR, "status": STR,
    "n_targets": NUM, "counts": _IK_STATUSES, "max_position_error": NUM,
    "max_orientation_error": NUM, "solve_time_s": NUM, "median_time_per_target_s": NUM,
    "end_effector": STR, "targets": Items(_IK_TARGET), "solutions": ANY,
    "methods_used": WORDS, "analytic_structure": WORDS,
    # target sets (mechkin.tasks.ik_frames)
    "n_target_sets": NUM, "floating_base": NUM,
    "target_sets": Items({"name": STR, "status": STR, "base_pose": ANY, "q": Names(NUM),
                          "frames": ANY, "closure_residual": NUM, "iterations": NUM,
                          "restarts_used": NUM, "time_s": NUM}),
}

_LIMITS = {"min": JV, "max": JV}
_DP = {"step_time": STR, "wait_cost": NUM, "jerk_ends": NUM}
_TRACK_RUN = {
    "status": STR, "message": STR, "t_a_s": NUM, "t_start_s": NUM, "duration_s": NUM,
    "peak_torque": JV, "limits_ok": NUM, "active_limits": WORDS, "cost": NUM,
    "blocked_at_r": NUM, "blocking_limits": WORDS, "solve_time_s": NUM,
}
TRACK = {
    "scenario": STR, "task": STR, "mechanism": STR, "dynamics": STR, "objective": STR,
    **_TRACK_RUN,
    "limit_usage": LIMIT_USAGE,
    "grid": {"N1": NUM, "N2": NUM, "Nt": NUM, "x2_max_1_s": NUM},
    "time_penalty": NUM, "dp": _DP, "planner": STR, "intercept_r": NUM,
    "actuated_joints": WORDS, "peak_torque_by_joint": Names(NUM, "actuated"),
    "path": {"type": STR, "start_m": V3, "end_m": V3, "via_m": V3, "points_m": MAT,
             "length_m": NUM, "frame": STR, "orientation": STR, "mask": WORDS, "task_rank": NUM,
             "redundancy": NUM, "max_position_error_m": NUM, "max_orientation_error_rad": NUM,
             "max_rotation_from_start_rad": NUM, "orientations": ANY, "centre_m": V3,
             "radius_m": NUM, "normal": V3, "angle_deg": NUM, "via_r": VEC,
             "orientation_blend": STR, "constraint_singularities_crossed": NUM},
    "reference": {"r0": NUM, "rd_1_s": NUM, "t_f_s": NUM, "rdd_1_s2": NUM},
    "limits_si": {"torque": _LIMITS, "qd": _LIMITS, "qdd": _LIMITS, "jerk": _LIMITS,
                  "q": _LIMITS},
    "grid_study": Items({"N1": NUM, "N2": NUM, "Nt": NUM, "x2_max_1_s": NUM, **_TRACK_RUN}),
    "cases": Items({"name": STR, "dp": _DP, "time_penalty": NUM, **_TRACK_RUN}),
    "n_samples": NUM, "csv_notes": STR,
}

_SWEEP_COMMON = {
    "scenario": STR, "task": STR, "kind": STR, "status": STR, "mechanism": STR, "method": STR,
    "seed": NUM, "frame": STR, "n_samples": NUM, "n_reachable": NUM, "reachable_fraction": NUM,
    "definition": WORDS, "compute_time_s": NUM, "manipulability": _STATS, "isotropy": _STATS,
    "isotropy_position": _STATS, "isotropy_normalized": _STATS,
    "characteristic_length": {"value_m": NUM, "source": STR},
    "execution": {"executor": STR, "workers": NUM, "jobs": NUM, "chunk": NUM},
}
JOINT_SWEEP = {
    **_SWEEP_COMMON, "swept_joints": WORDS, "full_turn_joints": WORDS, "closed_chain": NUM,
    "n_not_converged": NUM,
    "n_outside_limits": NUM, "bounding_box": {"min_m": V3, "max_m": V3, "size_m": V3},
    "volume": {"voxel_m3": NUM, "voxel_edge_m": NUM, "occupied_voxels": NUM,
               "convex_hull_m3": NUM},
    "sample": ANY, "continuation": {"seed_from": STR, "mode_jump": NUM, "n_roots": NUM,
                                    "n_mode_changes": NUM, "n_closure_failures": NUM,
                                    "n_reseeded_from_home": NUM,
                                    "n_constraint_singularities_crossed": NUM},
}
TASK_SPACE = {
    **_SWEEP_COMMON, "restarts": NUM, "n_poses": NUM, "status_counts": _IK_STATUSES,
    "condition_number": _STATS, "iterations": _STATS, "max_position_error_m": NUM,
    "max_orientation_error_rad": NUM,
    "reachable_bounding_box": {"min_m": V3, "max_m": V3, "size_m": V3},
}


#: What every task's summary may hold: a --max-time stop (mechkin.tasks.budget.mark_stopped),
#: the run's time estimate (``estimated_time_s``).
RUN = {"stopped": {"reason": STR, "limit_s": NUM, "after_s": NUM, "done": NUM, "total": NUM,
                   "unit": STR},
       "estimated_time_s": NUM}
for _tpl in (FK, IK, TRACK, JOINT_SWEEP, TASK_SPACE):
    _tpl.update(RUN)


def template(sc: Any) -> dict[str, Any] | None:
    """The summary template of scenario ``sc`` (None: only the top-level keys are known)."""
    name = sc.section_name
    if name == "fk":
        return FK
    if name == "ik":
        return IK
    if name == "track":
        return TRACK
    if name == "workspace":
        kind = sc.section.kind
        if kind == "joint_sweep":
            return JOINT_SWEEP
        if kind == "task_space":
            return TASK_SPACE
    return None  # biped, lee_spherical: the top-level keys only


def deep_key_problem(sc: Any, mech: Any | None, parts: list[str],
                     word: bool = False) -> str | None:
    """Why ``.``-joined ``parts`` cannot name a value the summary of ``sc`` will hold (None if
    it can); ``word``: the expect gives a status word, so the key must hold a word."""
    tpl = template(sc)
    if tpl is None:
        return None
    if parts[0] not in tpl:
        return None  # the top-level keys are validate.summary_top_keys' to judge
    node: Any = tpl
    for k, part in enumerate(parts):
        here = ".".join(parts[:k]) or "the summary"
        if node == ANY:
            return None
        if node == WORDS:
            return f"{here} holds words, not numbers"
        if node == LIMIT_USAGE:
            allowed = _limit_usage_keys(sc, mech)
            if allowed is not None and part not in allowed:
                return (f"{here} has no key {part[:40]!r} (keys: "
                        f"{', '.join(allowed)[:200]})")
            node = NUM
            continue
        if isinstance(node, Counts):
            if node.words and part not in node.words:
                return f"{here} has no key {part[:40]!r} (keys: {', '.join(node.words)})"
            node = NUM
            continue
        if isinstance(node, dict):
            if part not in node:
                return (f"{here} has no key {part[:40]!r} (keys: "
                        f"{', '.join(sorted(node))[:200]})")
            node = node[part]
        elif isinstance(node, Items):
            if not part.isdigit():
                return f"{here} is a list: expected an index 0, 1, ..., got {part[:40]!r}"
            node = node.item
        elif isinstance(node, Names):
            names = _names(mech, node.which)
            if names is not None and part not in names:
                return (f"{here} has no joint {part[:40]!r} (joints: "
                        f"{', '.join(names)[:200]})")
            node = node.item
        elif node == VEC or isinstance(node, Vec):
            n = node.n if isinstance(node, Vec) else None
            if n == -1:
                n = None if mech is None else int(mech.n)
            if not part.isdigit() or (n is not None and int(part) >= n):
                many = n if n else "the run's"
                return (f"{here} is a list of {many} numbers: expected an index"
                        f"{f' 0..{n - 1}' if n else ''}, got {part[:40]!r}")
            node = NUM
        elif node in (MAT, M3):
            n = 3 if node == M3 else None
            if not part.isdigit() or (n is not None and int(part) >= n):
                return (f"{here} is a matrix: expected a row index"
                        f"{f' 0..{n - 1}' if n else ''}, got {part[:40]!r}")
            node = V3 if n else VEC
        else:  # a number or a word: nothing below it
            return f"{here} is a {node}: it has no key {part[:40]!r}"
    key = ".".join(parts)
    if node == WORDS:
        return f"{key} holds words, not numbers"
    if isinstance(node, (dict, Items, Names, Counts)) or node == LIMIT_USAGE:
        inner = (", ".join(sorted(node))[:200] if isinstance(node, dict)
                 else "an index" if isinstance(node, Items)
                 else ", ".join(node.words) if isinstance(node, Counts)
                 else "a key" if node == LIMIT_USAGE else "a joint name")
        return f"{key} is a group of values, not one: name one of them ({inner})"
    if isinstance(node, Vec) or node == M3:
        node = VEC
    if word and node not in (STR, ANY):
        return f"{key} holds a {node}, not a word: give a number value (or min/max)"
    if not word and node == STR:
        return f"{key} holds a word: give the expected word as value (no tol, min or max)"
    return None


def _limit_usage_keys(sc: Any, mech: Any | None) -> list[str] | None:
    """``torque_1, ..., q_n``: the scenario's limit families and the joint limits q."""
    if mech is None:
        return None
    lim = sc.section.limits
    fams = [f for f in ("torque", "qd", "qdd", "jerk") if getattr(lim, f, None) is not None]
    return [f"{f}_{k}" for f in [*fams, "q"] for k in range(1, int(mech.n) + 1)]


def _names(mech: Any | None, which: str) -> list[str] | None:
    if mech is None:
        return None
    if which == "independent":
        return list(mech.independent_names)
    if which == "actuated":
        return None  # the actuated joints depend on the dynamics: checked by the run
    return list(mech.joint_names)

"""The one-line summary each run command prints (``mechkin fk|ik|track|workspace``), from the
run's summary.json (no typer, no numpy; ``mechkin run`` prints them too)."""

from __future__ import annotations

from typing import Any


def _fk_line(s: dict[str, Any]) -> str:
    # a failed run says how many steps failed how, and which passive joints left their limits
    bad = [f"{v} {k}" for k, v in (s.get("steps") or {}).items() if k != "converged" and v]
    joints = s.get("joints_outside_limits") or []
    why = ("" if s["status"] == "ok" or not bad else
           ": " + ", ".join(bad) + (f" ({', '.join(joints)})" if joints else ""))
    return (f"{s['scenario']}: {s['status']} ({s['n_steps']} steps{why}, max ||phi|| "
            f"{s['closure']['max_residual']:.3g}); wrote {s['out_dir']}")


def _ik_line(s: dict[str, Any]) -> str:
    if "counts" not in s:  # a biped run
        return f"{s['scenario']}: {s.get('status', '?')}; wrote {s['out_dir']}"
    c = s["counts"]
    n, what = ((s["n_targets"], "targets") if "n_targets" in s
               else (s["n_target_sets"], "target sets"))
    return (f"{s['scenario']}: {s['status']} ({c.get('ok', 0)}/{n} {what} ok, "
            f"max errors {s['max_position_error']:.3g} m, {s['max_orientation_error']:.3g} "
            f"rad); wrote {s['out_dir']}")


def _track_line(s: dict[str, Any]) -> str:
    if s["status"] != "ok":
        return f"{s['scenario']}: {s['status']}; wrote {s['out_dir']}"
    head = (f"t_a = {s['t_a_s']:.4g} s" if s["t_a_s"] is not None
            else f"duration {s['duration_s']:.4g} s")
    peaks = ", ".join(f"{v:.4g}" for v in s["peak_torque"])
    act, by = s.get("actuated_joints"), s.get("peak_torque_by_joint")
    if act and by and len(act) < len(by):  # a closed chain: the motors (passive joints: 0)
        peaks = ", ".join(f"{n} {by[n]:.4g}" for n in act)
    g = s["grid"]
    how = (f"TOPP-RA on {g['N1'] + 1} points" if s.get("planner") == "topp"
           else f"{g['N1']}x{g['N2']} grid")
    return (f"{s['scenario']}: ok, {head}, peak torques [{peaks}], limits "
            f"{'ok' if s['limits_ok'] else 'EXCEEDED'}, {how} "
            f"in {s['solve_time_s']:.3g} s; wrote {s['out_dir']}")


def workspace_line(s: dict[str, Any]) -> str:
    if "design" in s:
        d = s["design"]
        parts = []
        for v in d["per_value"]:
            fr = [f"{k} {e['volume_fraction']:.3f}" for k, e in v.get("isotropy", {}).items()]
            if "gamma_range" in v:
                fr.append(f"gamma range {v['gamma_range']['defined_fraction']:.3f}")
            parts.append(f"{d['parameter']} = {v['value']:g}: {', '.join(fr)}")
        body = "volume fractions " + "; ".join(parts)
    elif s.get("kind") == "task_space":
        body = (f"{s['n_reachable']}/{s['n_poses']} poses reached, isotropy median "
                f"{s['isotropy'].get('median', 0.0):.3f}")
    elif s.get("kind") == "lee_spherical":
        parts = [f"{name}: volume fraction {e['volume_fraction']:.3f}"
                 for name, e in s.get("isotropy", {}).items()]
        if "gamma_range" in s:
            parts.append(f"gamma range defined on {s['gamma_range']['defined_fraction']:.3f}")
        body = "; ".join(parts)
    else:
        body = (f"{s['n_reachable']}/{s['n_samples']} samples reachable, voxel volume "
                f"{s['volume']['voxel_m3']:.4g} m^3")
    failed = [c["key"] for c in s.get("expect", []) if not c["ok"]]
    tail = f"; expect failed: {', '.join(failed)}" if failed else ""
    return f"{s['scenario']}: {s['status']} ({body}){tail}; wrote {s['out_dir']}"


def _naming_failed_expects(fn: Any) -> Any:
    """``fn``'s line with the keys of the failed ``expect:`` entries before ``; wrote``."""

    def line(s: dict[str, Any]) -> str:
        text = fn(s)
        failed = [str(c.get("key", "?")) for c in s.get("expect", []) or []
                  if isinstance(c, dict) and not c.get("ok", True)]
        if not failed or "expect failed:" in text:
            return text
        keys = ", ".join(failed)
        keys = keys if len(keys) <= 120 else keys[:117] + "..."
        wrote = f"; wrote {s.get('out_dir')}"
        head = text[: -len(wrote)] if text.endswith(wrote) else text
        return f"{head}; expect failed: {keys}{wrote if text.endswith(wrote) else ''}"

    line.__name__ = line.__qualname__ = fn.__name__.lstrip("_")
    return line


fk_line = _naming_failed_expects(_fk_line)
ik_line = _naming_failed_expects(_ik_line)
track_line = _naming_failed_expects(_track_line)

#: the line function of each run command
LINES = {"fk": fk_line, "ik": ik_line, "track": track_line, "workspace": workspace_line}

"""What ``mechkin track`` refuses after loading and before planning, computed for ``mechkin
check``: the hand path and its start pose (the path inverse kinematics at r = 0, park Eq. (9):
an unreachable start position or orientation), the conveyor against that path (park Eq. (16)-
(17)). :func:`mechkin.tasks.validate.track_problems` calls :func:`preflight_problems` once the
cheaper checks pass, so a file that checks ok is not refused by the run for these.

Imports: tasks.track (the same functions the run calls), config, errors.
"""

from __future__ import annotations

from typing import Any

from mechkin.errors import ConfigError


def preflight_problems(sc: Any, mech: Any) -> list[str]:
    """The run's own refusals of the hand path, its start pose and the conveyor (one line
    each; empty if the run gets past them)."""
    import numpy as np

    from mechkin.config.track_spec import point_si
    from mechkin.solvers.track.dpct import ConveyorReference
    from mechkin.tasks.track import hand_ik

    spec = sc.section
    try:
        with np.errstate(all="ignore"):
            path = hand_ik(sc, mech)
            if spec.conveyor is not None:
                units = sc.spec.units
                acc = spec.conveyor.belt_acceleration
                ref = ConveyorReference(
                    part_start=point_si(spec.conveyor.part_start, units),
                    belt_velocity=point_si(spec.conveyor.belt_velocity, units),
                    belt_acceleration=None if acc is None else point_si(acc, units))
                try:
                    ref.motion(path)
                except ConfigError as exc:
                    raise ConfigError(f"{sc.doc.where(('track', 'conveyor'))}: {exc}") from None
    except ConfigError as exc:
        return list(exc.problems)
    return []

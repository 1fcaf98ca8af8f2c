"""Foxglove layouts: ``<task>.layout.json`` beside ``<task>.mcap`` (import it in Foxglove with
"Layouts -> Import from file").

A layout is Foxglove's layout JSON: ``configById`` (panel id ``"<Type>!<suffix>"`` -> panel
settings), ``layout`` (a binary mosaic tree ``{"first", "second", "direction",
"splitPercentage"}`` whose leaves are panel ids), ``globalVariables``, ``userNodes`` and
``playbackConfig``. Every layout written here has

* a 3D panel following the MCAP's root frame, showing ``/scene`` and ``/tf``;
* a Plot panel of the ``/joint_states`` positions (one series per joint, at most 12);
* a Plot panel of the task's key figures (``/mechkin/state`` fields, or joint efforts).

Topics named by a layout are listed by :func:`layout_topics`, so a test can check each against
the MCAP's channels.

Imports: io.topics (topic names) only.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mechkin.io.topics import TOPIC_JOINTS, TOPIC_SCENE, TOPIC_STATE, TOPIC_TF

__all__ = ["Series", "joint_path", "layout", "layout_topics", "state_path"]

MAX_JOINT_SERIES = 12
Series = tuple[str, str]  # (message path, legend label)


def joint_path(joint: str, field: str = "position") -> str:
    """Message path of one joint's ``field`` in ``/joint_states`` (filtered by name)."""
    return f'{TOPIC_JOINTS}.joints[:]{{name=="{joint}"}}.{field}'


def state_path(key: str) -> str:
    """Message path of a ``/mechkin/state`` field."""
    return f"{TOPIC_STATE}.{key}"


def _plot(title: str, series: Sequence[Series]) -> dict[str, Any]:
    return {
        "title": title,
        "paths": [{"value": p, "label": lab, "enabled": True, "timestampMethod": "receiveTime"}
                  for p, lab in series],
        "showLegend": True,
        "legendDisplay": "floating",
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "isSynced": True,
        "xAxisVal": "timestamp",
    }


def _three_d(root_frame: str) -> dict[str, Any]:
    return {
        "followTf": root_frame,
        "followMode": "follow-pose",
        "scene": {},
        "transforms": {},
        "topics": {TOPIC_SCENE: {"visible": True}, TOPIC_TF: {"visible": True}},
        "layers": {"grid": {"layerId": "foxglove.Grid", "visible": True, "frameLocked": True,
                            "label": "Grid", "instanceId": "grid", "frameId": root_frame}},
        "publish": {"type": "point"},
        "imageMode": {},
    }


def _stack(ids: Sequence[str]) -> Any:
    """A column of panels as a binary mosaic tree, every panel the same height."""
    if len(ids) == 1:
        return ids[0]
    return {"first": ids[0], "second": _stack(ids[1:]), "direction": "column",
            "splitPercentage": round(100.0 / len(ids), 2)}


def layout(
    root_frame: str,
    joint_names: Sequence[str],
    key_plots: Sequence[tuple[str, Sequence[Series]]],
) -> dict[str, Any]:
    """The Foxglove layout of one MCAP.

    Parameters
    ----------
    root_frame : str
        The MCAP's root frame (the base frame of the mechanism, or ``world``).
    joint_names : sequence of str
        The ``/joint_states`` joints; the first 12 are plotted.
    key_plots : sequence of (title, sequence of (path, label))
        One Plot panel per entry: the task's key figures (message paths from
        :func:`state_path`, :func:`joint_path`); entries without series are left out.

    Returns
    -------
    dict
        Foxglove layout JSON (``configById``, ``layout``, ``globalVariables``, ``userNodes``,
        ``playbackConfig``): the 3D panel on the left, the plots stacked on the right.
    """
    three_d = "3D!mechkin"
    config: dict[str, Any] = {three_d: _three_d(root_frame)}
    plots = []
    if joint_names:
        config["Plot!joints"] = _plot("joint positions [rad | m]",
                                      [(joint_path(j), j)
                                       for j in joint_names[:MAX_JOINT_SERIES]])
        plots.append("Plot!joints")
    for k, (title, series) in enumerate(key_plots):
        if series:
            config[f"Plot!key{k}"] = _plot(title, series)
            plots.append(f"Plot!key{k}")
    tree: Any = three_d
    if plots:
        tree = {"first": three_d, "second": _stack(plots), "direction": "row",
                "splitPercentage": 60}
    return {
        "configById": config,
        "globalVariables": {},
        "userNodes": {},
        "linkedGlobalVariables": [],
        "playbackConfig": {"speed": 1.0, "messageOrder": "receiveTime"},
        "layout": tree,
    }


def layout_topics(lay: dict[str, Any]) -> set[str]:
    """Every topic a layout names (3D panel topics and the topic of every plotted path)."""
    topics: set[str] = set()
    for cfg in lay["configById"].values():
        topics.update(cfg.get("topics", {}))
        for p in cfg.get("paths", ()):
            topics.add(p["value"].split(".", 1)[0])
    return topics

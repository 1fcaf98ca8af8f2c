"""Foxglove layouts: ``<task>.layout.json`` beside ``<task>.mcap`` (import it in Foxglove or
Lichtblick with "Layouts -> Import from file").

A layout is the layout JSON both apps import: ``configById`` (panel id ``"<Type>!<suffix>"`` ->
panel config), ``layout`` (a binary mosaic tree ``{"first", "second", "direction",
"splitPercentage"}`` whose leaves are panel ids), ``globalVariables``, ``userNodes`` and
``playbackConfig``. The panel configs are built with the Foxglove SDK's layout classes
(``foxglove.layouts.ThreeDeeConfig``, ``PlotConfig``, ``BaseRendererUrdfLayerSettings``), so
their keys are the ones the apps read. A panel's title is not part of a Plot config: the apps
read it from the key ``foxglovePanelTitle`` of the panel's entry in ``configById`` (Foxglove,
Lichtblick ``PANEL_TITLE_CONFIG_KEY`` in ``suite-base/src/util/layout.ts``; newer Lichtblick
releases name it ``lichtblickPanelTitle``): both are written. Every layout has

* a 3D panel following the MCAP's root frame, showing ``/scene`` and ``/tf``, and a URDF layer
  reading the robot from ``/robot_description`` with its joints driven by ``/joint_states``
  (when the MCAP carries a robot);
* a Plot panel of the ``/joint_states`` positions (one series per joint, at most 12; joints that
  are not motors are listed but switched off);
* Plot panels of the task's key figures (``/mechkin/state`` fields, or joint efforts).

Topics named by a layout are listed by :func:`layout_topics`, so a test can check each against
the MCAP's channels.

Imports: io.topics (topic names), foxglove.layouts (lazily).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from mechkin.io.topics import TOPIC_JOINTS, TOPIC_ROBOT, TOPIC_SCENE, TOPIC_STATE, TOPIC_TF

__all__ = ["PANEL_TITLE_KEYS", "Series", "joint_path", "layout", "layout_topics", "state_path"]

MAX_JOINT_SERIES = 12
#: Keys of a panel's title in its ``configById`` entry (Foxglove / Lichtblick, newer Lichtblick).
PANEL_TITLE_KEYS = ("foxglovePanelTitle", "lichtblickPanelTitle")
URDF_LAYER_ID = "mechkin-robot"
#: (message path, legend label) or (path, label, enabled)
Series = tuple[str, str] | tuple[str, str, bool]


def joint_path(joint: str, field: str = "position") -> str:
    """Message path of one joint's ``field`` in ``/joint_states`` (filtered by name)."""
    return f'{TOPIC_JOINTS}.joints[:]{{name=="{joint}"}}.{field}'


def state_path(key: str) -> str:
    """Message path of a ``/mechkin/state`` field."""
    return f"{TOPIC_STATE}.{key}"


def _sdk_dict(obj: Any) -> dict[str, Any]:
    """A foxglove.layouts config object as the JSON dict the apps read."""
    return dict(json.loads(obj.to_json()))


def _plot(title: str, series: Sequence[Series], y_label: str = "") -> dict[str, Any]:
    import foxglove.layouts as fl

    paths = [fl.PlotSeries(value=s[0], label=s[1], enabled=bool(s[2]) if len(s) > 2 else True,
                           timestamp_method="receiveTime") for s in series]
    cfg = _sdk_dict(fl.PlotConfig(
        paths=paths, show_legend=True, legend_display="floating", show_x_axis_labels=True,
        show_y_axis_labels=True, is_synced=True, x_axis_val="timestamp",
        y_axis_label=y_label or None))
    return {**cfg, **dict.fromkeys(PANEL_TITLE_KEYS, title)}


def _three_d(root_frame: str, robot: bool, extra_topics: Sequence[str],
             title: str) -> dict[str, Any]:
    import foxglove.layouts as fl

    topics: dict[str, Any] = {
        TOPIC_SCENE: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        TOPIC_TF: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
    }
    for t in extra_topics:
        topics[t] = fl.BaseRendererPointCloudTopicSettings(
            visible=True, point_size=6.0, color_mode="colormap", color_field="isotropy",
            color_map="turbo")
    layers: dict[str, Any] = {"grid": fl.BaseRendererGridLayerSettings(
        visible=True, instance_id="grid", label="Grid", frame_id=root_frame)}
    if robot:
        # the custom layer draws the robot; the built-in /robot_description entry stays off so
        # the model is not drawn twice
        topics[TOPIC_ROBOT] = fl.BaseRendererUrdfTopicSettings(visible=False)
        layers[URDF_LAYER_ID] = fl.BaseRendererUrdfLayerSettings(
            visible=True, instance_id=URDF_LAYER_ID, label="robot (URDF)", source_type="topic",
            topic=TOPIC_ROBOT, control_mode="jointStates", joint_states_topic=TOPIC_JOINTS,
            display_mode="visual", show_axis=False, opacity=0.9)
    cfg = _sdk_dict(fl.ThreeDeeConfig(follow_tf=root_frame, follow_mode="follow-pose",
                                      topics=topics, layers=layers))
    cfg.setdefault("scene", {})
    cfg.setdefault("transforms", {})
    return {**cfg, **dict.fromkeys(PANEL_TITLE_KEYS, title)}


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
    *,
    motors: Sequence[str] | None = None,
    robot: bool = False,
    extra_topics: Sequence[str] = (),
    title: str = "mechanism",
) -> dict[str, Any]:
    """The Foxglove layout of one MCAP.

    Parameters
    ----------
    root_frame : str
        The MCAP's root frame (the base frame of the mechanism, or ``world``).
    joint_names : sequence of str
        The ``/joint_states`` joints; the first 12 are plotted.
    key_plots : sequence of (title, sequence of series)
        One Plot panel per entry: the task's key figures (message paths from
        :func:`state_path`, :func:`joint_path`); entries without series are left out. The
        title's bracketed unit, if any, is also the y-axis label.
    motors : sequence of str, optional
        The actuated joints; the others' series are switched off (default: all are motors).
    robot : bool
        The MCAP carries ``/robot_description``: add the URDF layer.
    extra_topics : sequence of str
        Point-cloud topics to show in the 3D panel (coloured by their ``isotropy`` field).
    title : str
        Title of the 3D panel.

    Returns
    -------
    dict
        Layout JSON (``configById``, ``layout``, ``globalVariables``, ``userNodes``,
        ``playbackConfig``): the 3D panel on the left, the plots stacked on the right.
    """
    three_d = "3D!mechkin"
    config: dict[str, Any] = {three_d: _three_d(root_frame, robot, extra_topics, title)}
    plots = []
    on = set(joint_names if motors is None else motors)
    if joint_names:
        config["Plot!joints"] = _plot("joint positions [rad | m]",
                                      [(joint_path(j), j, j in on)
                                       for j in joint_names[:MAX_JOINT_SERIES]], "rad | m")
        plots.append("Plot!joints")
    for k, (ptitle, series) in enumerate(key_plots):
        if series:
            unit = ptitle[ptitle.rfind("[") + 1:ptitle.rfind("]")] if "[" in ptitle else ""
            config[f"Plot!key{k}"] = _plot(ptitle, series, unit)
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
    """Every topic a layout names: 3D panel topics, URDF layer topics and the topic of every
    plotted path."""
    topics: set[str] = set()
    for cfg in lay["configById"].values():
        topics.update(t for t, s in cfg.get("topics", {}).items() if s.get("visible", True))
        for lay_cfg in cfg.get("layers", {}).values():
            for key in ("topic", "jointStatesTopic"):
                if lay_cfg.get(key):
                    topics.add(lay_cfg[key])
        for p in cfg.get("paths", ()):
            topics.add(p["value"].split(".", 1)[0])
    return topics

"""Foxglove layouts beside each MCAP, explicit state schemas, and plots that read right
(issue 16 items 4 and 5).

Four small scenarios (fk, ik, track, biped) are run once through the public API and written
without plots (cheap); the plot tests rebuild the figures from the same records with
``Figure.savefig`` replaced by a recorder, so nothing is rendered.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from mechkin.io.foxglove_layout import layout_topics
from mechkin.io.plots import convergence_figure, targets_figure

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = {
    "fk": "kim1995_direct_drive_fk",
    "ik": "kim1995_table3_direct_drive_ik",
    "track": "planar3r_track_line",
    "biped": "hwang2023_fig7_a",
}
_JOINT_PATH = re.compile(r'^/joint_states\.joints\[:\]\{name=="([^"]+)"\}\.(\w+)$')
_STATE_PATH = re.compile(r"^/mechkin/state\.(\w+)$")


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, tuple[Any, Path]]:
    """task -> (report, output folder) of each scenario, written without plots."""
    from mechkin.api import run

    out: dict[str, tuple[Any, Path]] = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MECHKIN_JIT", "0")
        if "NUMBA_CACHE_DIR" not in os.environ:
            mp.setenv("NUMBA_CACHE_DIR", str(tmp_path_factory.mktemp("numba")))
        for task, name in SCENARIOS.items():
            report = run(ROOT / "scenarios" / f"{name}.yaml")
            folder = tmp_path_factory.mktemp(task)
            report.write(folder, plots=False)
            out[task] = (report, folder)
    return out


def _mcap_name(task: str) -> str:
    return "biped" if task == "biped" else task


def _read_mcap(path: Path) -> dict[str, Any]:
    """Channels, the state schema, decoded state documents, joint names, /tf parent->child."""
    info: dict[str, Any] = {"topics": set(), "state": [], "joints": set(), "edges": set(),
                            "schemas": {}}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        for ch in summary.channels.values():
            info["topics"].add(ch.topic)
            info["schemas"][ch.topic] = summary.schemas[ch.schema_id].name
            if ch.topic == "/mechkin/state":
                info["schema"] = json.loads(summary.schemas[ch.schema_id].data)
        f.seek(0)
        for _, channel, message in make_reader(f).iter_messages():
            if channel.topic == "/mechkin/state":
                info["state"].append(json.loads(message.data))
        f.seek(0)
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(topics=["/joint_states", "/tf"]):
            if channel.topic == "/joint_states":
                info["joints"].update(j.name for j in msg.joints)
            else:
                info["edges"].update((t.parent_frame_id, t.child_frame_id)
                                     for t in msg.transforms)
    return info


# Keys the apps read from a panel's entry in configById, typed in from their sources:
# - the title: PANEL_TITLE_CONFIG_KEY = "foxglovePanelTitle" (Lichtblick
#   packages/suite-base/src/util/layout.ts; Foxglove the same), "lichtblickPanelTitle" in newer
#   Lichtblick releases; a "title" inside the Plot config is read by neither.
# - Plot: foxglove-sdk 0.30.3 foxglove.layouts.PlotConfig._to_dict / PlotSeries._to_dict.
# - 3D: foxglove.layouts.ThreeDeeConfig / BaseRendererConfig; the URDF layer:
#   BaseRendererUrdfLayerSettings (layerId "foxglove.Urdf", sourceType url | filePath | param |
#   topic, controlMode transforms | jointStates, jointStatesTopic) and Lichtblick
#   renderables/Urdfs.ts LayerSettingsCustomUrdf (layerId, sourceType, url, filePath, parameter,
#   topic, framePrefix, displayMode, fallbackColor; BaseSettings visible, frameLocked;
#   CustomLayerSettings instanceId, label, order).
TITLE_KEYS = {"foxglovePanelTitle", "lichtblickPanelTitle"}
PLOT_KEYS = {"paths", "minXValue", "maxXValue", "minYValue", "maxYValue", "showLegend",
             "legendDisplay", "floatingLegendPosition", "showPlotValuesInLegend",
             "showXAxisLabels", "showYAxisLabels", "isSynced", "xAxisVal", "xAxisPath",
             "xAxisLabel", "yAxisLabel", "timeWindowMode", "followingViewWidth"}
SERIES_KEYS = {"value", "label", "enabled", "timestampMethod", "color", "lineSize",
               "showLine", "timestampPath", "xValuePath", "id"}
THREE_D_KEYS = {"cameraState", "followTf", "fixedFrame", "followMode", "scene", "transforms",
                "topics", "layers", "publish", "imageMode"}
URDF_LAYER_KEYS = {"visible", "frameLocked", "instanceId", "layerId", "label", "order",
                   "sourceType", "url", "filePath", "parameter", "topic", "framePrefix",
                   "displayMode", "fallbackColor", "controlMode", "jointStatesTopic", "showAxis",
                   "axisScale", "showOutlines", "opacity", "links"}
GRID_LAYER_KEYS = {"visible", "frameLocked", "instanceId", "layerId", "label", "order",
                   "frameId", "size", "divisions", "lineWidth", "color", "position", "rotation"}


def _check_panel_keys(lay: dict[str, Any]) -> None:
    for pid, cfg in lay["configById"].items():
        kind = pid.split("!", 1)[0]
        titles = {cfg.get(k) for k in TITLE_KEYS}
        assert len(titles) == 1 and isinstance(titles.pop(), str) and cfg["foxglovePanelTitle"]
        keys = set(cfg) - TITLE_KEYS
        assert "title" not in keys, pid
        if kind == "Plot":
            assert keys <= PLOT_KEYS, (pid, keys - PLOT_KEYS)
            for series in cfg["paths"]:
                assert set(series) <= SERIES_KEYS, series
                assert series["label"] and isinstance(series["enabled"], bool)
        else:
            assert kind == "3D"
            assert keys <= THREE_D_KEYS, (pid, keys - THREE_D_KEYS)
            for iid, layer in cfg["layers"].items():
                allowed = URDF_LAYER_KEYS if layer["layerId"] == "foxglove.Urdf" else \
                    GRID_LAYER_KEYS
                assert layer["instanceId"] == iid
                assert set(layer) <= allowed, (iid, set(layer) - allowed)
    # unit-bearing titles on the plots
    plot_titles = [c["foxglovePanelTitle"] for p, c in lay["configById"].items()
                   if p.startswith("Plot!")]
    assert plot_titles and all("[" in t and "]" in t for t in plot_titles), plot_titles


def _leaves(tree: Any) -> list[str]:
    if isinstance(tree, str):
        return [tree]
    assert set(tree) >= {"first", "second", "direction"}, tree
    assert tree["direction"] in ("row", "column")
    assert 0 < tree.get("splitPercentage", 50) < 100
    return _leaves(tree["first"]) + _leaves(tree["second"])


@pytest.mark.parametrize("task", list(SCENARIOS))
def test_layout_beside_the_mcap_names_only_what_the_mcap_has(runs, task):
    _, folder = runs[task]
    base = _mcap_name(task)
    lay = json.loads((folder / f"{base}.layout.json").read_text())
    mc = _read_mcap(folder / f"{base}.mcap")

    assert set(lay) >= {"configById", "layout", "globalVariables", "userNodes",
                        "playbackConfig"}
    leaves = _leaves(lay["layout"])
    assert sorted(leaves) == sorted(lay["configById"]), "every panel placed exactly once"
    kinds = [pid.split("!", 1)[0] for pid in leaves]
    assert kinds.count("3D") == 1 and kinds.count("Plot") >= 2, kinds

    # the 3D panel follows the MCAP's root frame and shows /scene and /tf
    children = {c for _, c in mc["edges"]}
    roots = {p for p, _ in mc["edges"]} - children
    assert len(roots) == 1
    three_d = next(c for pid, c in lay["configById"].items() if pid.startswith("3D!"))
    assert three_d["followTf"] == roots.pop()
    visible = {t for t, c in three_d["topics"].items() if c.get("visible", True)}
    assert visible == {"/scene", "/tf"}
    # ... and the robot from /robot_description through a URDF layer driven by /joint_states
    # (the built-in /robot_description entry off, so the model is drawn once)
    assert three_d["topics"]["/robot_description"] == {"visible": False}
    urdf = [c for c in three_d["layers"].values() if c["layerId"] == "foxglove.Urdf"]
    assert len(urdf) == 1
    assert urdf[0]["sourceType"] == "topic" and urdf[0]["topic"] == "/robot_description"
    assert urdf[0]["controlMode"] == "jointStates"
    assert urdf[0]["jointStatesTopic"] == "/joint_states"
    assert {"/robot_description", "/joint_states"} <= mc["topics"]
    assert mc["schemas"]["/robot_description"] == "std_msgs/msg/String"
    _check_panel_keys(lay)

    # every topic named exists, and so does every field a plot reads
    assert layout_topics(lay) <= mc["topics"]
    state_keys = set().union(*(d.keys() for d in mc["state"]))
    paths = [p["value"] for c in lay["configById"].values() for p in c.get("paths", ())]
    assert any(_JOINT_PATH.match(p) and p.endswith(".position") for p in paths)
    plotted_state = 0
    for p in paths:
        if m := _JOINT_PATH.match(p):
            assert m.group(1) in mc["joints"], p
            assert m.group(2) in ("position", "velocity", "effort"), p
        else:
            m = _STATE_PATH.match(p)
            assert m, f"unexpected message path {p!r}"
            assert m.group(1) in state_keys, p
            assert m.group(1) in mc["schema"]["properties"], p
            plotted_state += 1
    # the key figure of each task
    want = {"fk": {"closure_residual"}, "ik": {"closure_residual", "position_error"},
            "track": {"tracking_error_m"}, "biped": {"position_error_right_m"}}[task]
    assert want <= {_STATE_PATH.match(p).group(1) for p in paths if _STATE_PATH.match(p)}
    if task == "track":
        assert any(p.endswith(".effort") for p in paths)
        assert any("torque_max_" in p for p in paths)
        # torques of the motors only are on (the passive joints' are listed but off)
        report = runs[task][0]
        motors = set(report.data.motors)
        for c in lay["configById"].values():
            for p in c.get("paths", ()):
                if m := _JOINT_PATH.match(p["value"]):
                    assert p["enabled"] == (m.group(1) in motors), p
    assert plotted_state >= 1


def _types(schema: dict[str, Any], where: str) -> None:
    t = schema.get("type")
    assert t is not None, f"{where}: no type"
    ts = t if isinstance(t, list) else [t]
    assert "null" not in ts and len(ts) == 1, f"{where}: type {t!r}"
    for k, sub in schema.get("properties", {}).items():
        _types(sub, f"{where}.{k}")
    if "items" in schema:
        _types(schema["items"], f"{where}[]")


@pytest.mark.parametrize("task", list(SCENARIOS))
def test_state_schema_is_explicit_and_covers_every_message(runs, task):
    _, folder = runs[task]
    mc = _read_mcap(folder / f"{_mcap_name(task)}.mcap")
    schema = mc["schema"]
    _types(schema, "state")
    assert mc["state"]
    strict = {**schema, "additionalProperties": False}
    for doc in mc["state"]:
        jsonschema.validate(doc, strict)  # every key declared, every value of its type


@pytest.mark.parametrize("task", ["fk", "ik", "track"])
def test_the_mcap_carries_the_explicit_schema_not_an_inferred_one(runs, task):
    """The written schema is the task's fixed table (plus the timestamp), field for field."""
    from mechkin.io import motion_out, track_out

    report, folder = runs[task]
    written = _read_mcap(folder / f"{task}.mcap")["schema"]
    table = (track_out.state_schema(report.data) if task == "track"
             else motion_out.state_schema(task))
    props = dict(written["properties"])
    assert set(props.pop("timestamp")["properties"]) == {"sec", "nsec"}
    assert props == table["properties"]
    assert all("description" in v for v in props.values())


# ---- plots ------------------------------------------------------------------------------------


class _Od:
    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def path_for(self, name: str) -> Path:
        return self.folder / name


@pytest.fixture
def saved(monkeypatch) -> dict[str, dict[str, Any]]:
    """Replace ``Figure.savefig`` by a recorder: file name -> what the figure shows."""
    seen: dict[str, dict[str, Any]] = {}

    def record(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        path = Path(fname)
        m = re.match(r"^\.(.+)\.[0-9a-f]+\.part\.png$", path.name)  # atomic_path temp names
        name = f"{path.parent.name}/{m.group(1) if m else path.name}"
        axes = fig.get_axes()
        legends = [ax.get_legend() for ax in axes] + list(fig.legends)  # figure legends too
        seen[name] = {
            "engine": fig.get_layout_engine(),
            "xticks": [[t.get_text() for t in ax.get_xticklabels()] for ax in axes],
            "xlabels": [ax.get_xlabel() for ax in axes],
            "legend": [t.get_text() for lg in legends if lg is not None for t in lg.get_texts()],
            "empty": [not (ax.lines or ax.collections or ax.patches) for ax in axes],
        }
        Path(fname).write_bytes(b"")

    monkeypatch.setattr(Figure, "savefig", record)
    return seen


def _by_stem(seen: dict[str, Any], stem: str) -> dict[str, Any]:
    hits = [v for k, v in seen.items() if k == stem or k.endswith(f"/{stem}.png")]
    assert len(hits) == 1, (stem, sorted(seen))
    return hits[0]


def test_ik_joints_are_drawn_per_target_with_a_target_marker(runs, saved, tmp_path):
    from mechkin.io.motion_out import write_plots

    report, _ = runs["ik"]
    rec = report.data
    write_plots(_Od(tmp_path), rec)
    joints = _by_stem(saved, "joints")
    names = [str(v) for v in rec.columns["target"]]
    assert joints["xticks"][-1] == names
    assert "t [s]" not in joints["xlabels"]
    stick = _by_stem(saved, "stick")
    assert "target" in stick["legend"] and "links" in stick["legend"]
    assert not any(stick["empty"])
    assert rec.targets is not None and rec.targets.shape == (len(names), 3)
    np.testing.assert_allclose(rec.targets[:, 0], rec.columns["target_x_m"])


def test_every_figure_uses_constrained_layout(runs, saved, tmp_path):
    from mechkin.io.biped_out import plot_biped
    from mechkin.io.motion_out import write_plots
    from mechkin.io.track_out import _plots as track_plots

    for task in ("fk", "ik", "track", "biped"):
        (tmp_path / task).mkdir()
    write_plots(_Od(tmp_path / "fk"), runs["fk"][0].data)
    write_plots(_Od(tmp_path / "ik"), runs["ik"][0].data)
    track_plots(_Od(tmp_path / "track"), runs["track"][0].data)
    plot_biped(tmp_path / "biped" / "biped.png", runs["biped"][0].data)
    assert {"fk/joints.png", "fk/stick.png", "ik/joints.png", "ik/stick.png",
            "ik/convergence.png", "track/phase.png", "track/torques.png",
            "biped/biped.png"} <= set(saved)
    for name, info in saved.items():
        assert isinstance(info["engine"], ConstrainedLayoutEngine), name
        assert not any(info["empty"]), f"{name}: an empty panel"
    assert saved["fk/joints.png"]["xlabels"][-1] == "t [s]"


def test_no_io_module_uses_another_layout_engine():
    """Source check of the writers that build figures themselves (track, workspace)."""
    for path in sorted((ROOT / "mechkin" / "io").glob("*.py")):
        text = path.read_text()
        assert "tight_layout" not in text and "bbox_inches" not in text, path.name
        calls = re.findall(r"\bFigure\((.*)$", text, flags=re.MULTILINE)
        for call in calls:
            assert 'layout="constrained"' in call, f"{path.name}: Figure({call}"


def test_convergence_every_target_up_to_twelve_with_distinct_colours():
    hist = {f"P{i}": 10.0 ** -np.arange(i + 3.0) for i in range(12)}
    fig = convergence_figure(hist, "f")
    ax = fig.axes[0]
    assert len(ax.lines) == 12
    colours = {tuple(np.round(np.asarray(__import__("matplotlib").colors.to_rgba(
        ln.get_color())), 6)) for ln in ax.lines}
    assert len(colours) == 12
    assert [t.get_text() for t in ax.get_legend().get_texts()] == list(hist)
    assert isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)


def test_convergence_summary_beyond_twelve():
    rng = np.random.default_rng(3)
    hist = {f"T{i}": np.cumprod(rng.uniform(0.05, 0.5, size=rng.integers(2, 9)))
            for i in range(40)}
    fig = convergence_figure(hist, "f")
    ax = fig.axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "median" in legend and "worst" in legend and any("10-90" in s for s in legend)
    assert len(ax.lines) == 2 and len(ax.collections) == 1
    # the median line equals the median of the padded histories at iteration 0
    med = next(ln for ln in ax.lines if ln.get_label() == "median").get_ydata()
    assert med[0] == pytest.approx(np.median([v[0] for v in hist.values()]))


def test_targets_figure_ticks_are_the_target_names():
    names = ["home", "left", "reach"]
    fig = targets_figure(names, np.arange(6.0).reshape(3, 2), ["q1 [rad]", "q2 [rad]"],
                         "q [rad]", "t", errors={"position error [m]": np.array([1e-9, 0, 2e-9])})
    assert [t.get_text() for t in fig.axes[-1].get_xticklabels()] == names
    assert len(fig.axes) == 2
    assert isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)

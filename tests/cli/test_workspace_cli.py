"""`mechkin workspace`: the four lee scenarios (Figs. 2-5) exit 0 and write their figures; the
joint sweep on the PUMA 560 and the Stewart platform; bad sections exit 2 naming file:line: key."""

import csv
import json
import math
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()

LEE = ["lee_fig2_gamma_range_r075.yaml", "lee_fig3_isotropy_r025.yaml",
       "lee_fig4_isotropy_r050.yaml", "lee_fig5_isotropy_r075.yaml"]


def _coarse_copy(tmp_path: Path, name: str) -> Path:
    """The bundled scenario on a coarser grid, mechanism path made absolute."""
    d = yaml.safe_load((SCEN / name).read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    ws = d["workspace"]
    for ax in ("alpha", "beta"):
        if ax in ws:
            ws[ax]["n"] = 21
    if "gamma_range" in ws:
        ws["gamma_range"].update(n=61, n_alpha=21, n_beta=21)
        # regression bounds belong to the full grid
        d["expect"] = [e for e in d["expect"] if not e["key"].startswith("gamma_range")]
    if "samples" in ws:
        ws["samples"] = 300
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _run(scenario: Path, out: Path, *extra: str):
    return runner.invoke(app, ["workspace", str(scenario), "--out", str(out), *extra])


def _no_nan_in_csvs(out: Path) -> None:
    for f in out.glob("*.csv"):
        with f.open() as fh:
            rows = list(csv.reader(fh))
        assert len(rows) > 1, f
        for row in rows[1:]:
            for v in row:
                assert v.lower() not in ("nan", "inf", "-inf"), f"{f.name}: {row}"


@pytest.mark.parametrize("name", LEE)
def test_lee_scenarios_exit_0_and_write_figures(tmp_path, name):
    out = tmp_path / "o"
    res = _run(_coarse_copy(tmp_path, name), out)
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "ok" and s["kind"] == "lee_spherical"
    assert s["expect"] and all(c["ok"] for c in s["expect"])
    for f in s["files"]:
        assert (out / f).is_file(), f
    if "gamma_range" in yaml.safe_load((SCEN / name).read_text())["workspace"]:
        assert (out / "gamma_range.png").stat().st_size > 10_000
        assert (out / "gamma_range.csv").is_file()
    else:
        for set_name in ("text", "captions"):
            assert (out / f"sigma_ki_{set_name}.png").stat().st_size > 10_000
        gam = [p["gamma_deg"] for p in s["isotropy"]["text"]["per_gamma"]]
        assert gam == [20.0, 30.0, 40.0]
        assert [p["gamma_deg"] for p in s["isotropy"]["captions"]["per_gamma"]] == [20, 40, 60]
    _no_nan_in_csvs(out)


def test_bundled_fig3_unmodified_sigma_at_origin(tmp_path):
    out = tmp_path / "o"
    res = _run(SCEN / "lee_fig3_isotropy_r025.yaml", out, "--no-plots")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["r"] == 0.25 and s["design_source"]["r"] == "scenario"
    assert s["design_source"]["stroke"] == "mechanism" and s["stroke"] == [0.5, 2.0]
    g20 = s["isotropy"]["text"]["per_gamma"][0]
    expected = min(math.sqrt(2) * math.sin(math.radians(20)),
                   1 / (math.sqrt(2) * math.sin(math.radians(20))))
    assert abs(g20["sigma_ki_at_origin"] - expected) < 1e-12
    assert abs(g20["sigma_ki_at_origin"] - 0.483690) <= 5e-7
    assert all(c["ok"] for c in s["expect"])
    _no_nan_in_csvs(out)


def test_failed_expect_exits_5_with_outputs(tmp_path):
    d = yaml.safe_load(_coarse_copy(tmp_path, "lee_fig5_isotropy_r075.yaml").read_text())
    d["expect"] = [{"key": "isotropy.text.per_gamma.0.sigma_ki_at_origin", "value": 0.5,
                    "tol": 1e-6}]
    p = tmp_path / "bad_expect.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    out = tmp_path / "o"
    res = _run(p, out, "--no-plots")
    assert res.exit_code == 5  # an expect failed
    s = json.loads((out / "summary.json").read_text())
    assert s["expect"][0]["ok"] is False
    assert "expect isotropy.text.per_gamma.0.sigma_ki_at_origin" in res.output


BAD = {
    "unknown key": ("  colour: red\n", r"\.yaml:\d+: workspace\.colour: unknown key"),
    "bad grid": ("  alpha: {range: [10, -10], n: 5}\n", r"\.yaml:\d+: workspace\.alpha"),
    "n too small": ("  beta: {range: [-10, 10], n: 1}\n", r"\.yaml:\d+: workspace\.beta\.n"),
    "wrong type": ("  threshold: small\n", r"\.yaml:\d+: workspace\.threshold"),
    "component without ref": ("  gamma_range: {range: [-90, 90], n: 5, mode: component}\n",
                              r"\.yaml:\d+: workspace"),
    "sweep key in lee": ("  samples: 10\n", r"\.yaml:\d+: workspace: .*samples"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_workspace_section_exit_2(tmp_path, case):
    import re

    extra, pattern = BAD[case]
    mech = (ROOT / "mechanisms" / "lee_spherical_rrps.yaml").resolve()
    p = tmp_path / "bad.yaml"
    p.write_text(f"name: bad\ntask: workspace\nmechanism: {mech}\nunits: {{angle: deg}}\n"
                 "workspace:\n  kind: lee_spherical\n  isotropy_maps: {text: [20]}\n" + extra)
    out = tmp_path / "o"
    res = _run(p, out)
    assert res.exit_code == 2, res.output
    assert re.search(pattern, res.output), res.output
    assert not out.exists()


def test_sweep_unknown_joint_exit_2(tmp_path):
    d = yaml.safe_load((SCEN / "puma560_workspace.yaml").read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    d["workspace"]["joints"] = {"q9": {"range": [0, 1]}}
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    res = _run(p, tmp_path / "o")
    assert res.exit_code == 2
    assert re_search(r"s\.yaml:\d+: workspace\.joints\.q9: 'q9' is not an independent "
                     r"joint", res.output)


def re_search(pattern: str, text: str) -> bool:
    import re

    return re.search(pattern, text) is not None


def test_puma_joint_sweep(tmp_path):
    out = tmp_path / "o"
    res = _run(_coarse_copy(tmp_path, "puma560_workspace.yaml"), out)
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["n_samples"] == 300 and s["n_reachable"] == 300
    assert 0 < s["volume"]["voxel_m3"] <= s["volume"]["convex_hull_m3"]
    assert 0 <= s["isotropy"]["min"] <= s["isotropy"]["max"] <= 1
    assert (out / "workspace_slices.png").is_file()
    _no_nan_in_csvs(out)
    # seeded: the same cloud twice
    out2 = tmp_path / "o2"
    assert _run(_coarse_copy(tmp_path, "puma560_workspace.yaml"), out2, "--no-plots").exit_code == 0
    assert (out / "points.csv").read_text() == (out2 / "points.csv").read_text()


def test_stewart_joint_sweep_closed_chain(tmp_path):
    d = yaml.safe_load((SCEN / "kim1995_stewart_workspace.yaml").read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    for j in d["workspace"]["joints"].values():
        j["n"] = 2
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    out = tmp_path / "o"
    res = _run(p, out, "--no-plots")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["closed_chain"] and s["n_samples"] == 64
    assert s["n_reachable"] + s["n_not_converged"] + s["n_outside_limits"] == 64
    assert s["n_reachable"] > 0 and s["manipulability"]["min"] > 0
    with (out / "points.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 64  # unreachable samples are marked, not dropped
    _no_nan_in_csvs(out)


# --------------------------------------------------------------------------- design sweeps


def _design_copy(tmp_path: Path, **ws_extra) -> Path:
    """The bundled r design sweep on small grids."""
    d = yaml.safe_load((SCEN / "lee_design_sweep_r.yaml").read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    ws = d["workspace"]
    ws["alpha"]["n"] = ws["beta"]["n"] = 9
    ws["gamma_range"].update(n=25, n_alpha=7, n_beta=7)
    ws.update(ws_extra)
    p = tmp_path / "design.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def test_design_sweep_side_by_side_and_table(tmp_path):
    out = tmp_path / "o"
    res = _run(_design_copy(tmp_path), out, "--workers", "1")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["design"]["parameter"] == "r" and s["design"]["values"] == [0.25, 0.5, 0.75]
    assert [v["r"] for v in s["design"]["per_value"]] == [0.25, 0.5, 0.75]
    assert s["design_source"]["r"] == "design"
    assert s["expect"] and all(c["ok"] for c in s["expect"])
    for f in s["files"]:
        assert (out / f).is_file(), f
    for name in ("design_sigma_ki_text.png", "design_sigma_ki_captions.png",
                 "design_gamma_range.png"):
        assert (out / name).stat().st_size > 20_000
    assert (out / "r_0.25" / "sigma_ki_text.csv").is_file()
    with (out / "design_comparison.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 * 6  # 3 values x (3 + 3) gammas
    assert rows[0]["r"] == "0.25" and rows[0]["gamma_set"] == "text"
    assert abs(float(rows[0]["sigma_ki_at_origin"]) - 0.483690) <= 5e-7
    assert len(s["comparison"]) == 18
    _no_nan_in_csvs(out)


def test_design_sweep_workers_1_and_2_identical(tmp_path):
    p = _design_copy(tmp_path)
    o1, o2 = tmp_path / "o1", tmp_path / "o2"
    assert _run(p, o1, "--no-plots", "--workers", "1").exit_code == 0
    assert _run(p, o2, "--no-plots", "--workers", "2").exit_code == 0
    for f in sorted(o1.rglob("*.csv")):
        assert f.read_bytes() == (o2 / f.relative_to(o1)).read_bytes(), f
    s1, s2 = (json.loads((o / "summary.json").read_text()) for o in (o1, o2))
    assert s1["design"] == s2["design"] and s1["comparison"] == s2["comparison"]
    assert s2["execution"] == {"executor": "process", "workers": 2, "jobs": 3}


def test_progress_bar_never_touches_stdout(tmp_path):
    res = _run(_design_copy(tmp_path, workers=1), tmp_path / "o", "--no-plots", "--json",
               "--progress")
    assert res.exit_code == 0
    s = json.loads(res.stdout)  # stdout is exactly the JSON summary
    assert s["design"]["values"] == [0.25, 0.5, 0.75]
    assert "r sweep" in res.stderr and "3/3" in res.stderr
    quiet = _run(_design_copy(tmp_path, workers=1), tmp_path / "o2", "--no-plots",
                 "--no-progress")
    assert quiet.exit_code == 0 and quiet.stderr == ""
    assert quiet.stdout.startswith("lee_design_sweep_r: ok (volume fractions r = 0.25")


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_design_sweep_on_dask_scheduler_option(tmp_path):
    pytest.importorskip("dask")
    distributed = pytest.importorskip("distributed")
    p = _design_copy(tmp_path)
    ref = tmp_path / "ref"
    assert _run(p, ref, "--no-plots", "--workers", "1").exit_code == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address="127.0.0.1:0") as cluster:
        out = tmp_path / "o"
        res = _run(p, out, "--no-plots", "--scheduler", cluster.scheduler_address)
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["execution"]["executor"] == "dask"
    assert (out / "design_comparison.csv").read_bytes() == \
        (ref / "design_comparison.csv").read_bytes()


BAD_DESIGN = {
    "unknown parameter": ("{parameter: d, values: [1]}", r"workspace\.design\.parameter"),
    "repeated values": ("{parameter: r, values: [0.5, 0.5]}", r"workspace\.design"),
    "l_min above stroke": ("{parameter: l_min, values: [3.0]}", r"workspace\.design\.values"),
}


@pytest.mark.parametrize("case", sorted(BAD_DESIGN))
def test_bad_design_exit_2(tmp_path, case):
    import re

    value, pattern = BAD_DESIGN[case]
    mech = (ROOT / "mechanisms" / "lee_spherical_rrps.yaml").resolve()
    p = tmp_path / "bad.yaml"
    p.write_text(f"name: bad\ntask: workspace\nmechanism: {mech}\nunits: {{angle: deg}}\n"
                 "workspace:\n  kind: lee_spherical\n  isotropy_maps: {text: [20]}\n"
                 f"  alpha: {{range: [-10, 10], n: 3}}\n  design: {value}\n")
    res = _run(p, tmp_path / "o")
    assert res.exit_code == 2, res.output
    assert re.search(pattern, res.output), res.output
    assert not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- task space


def _reach_copy(tmp_path: Path, n: int = 4) -> Path:
    d = yaml.safe_load((SCEN / "puma560_reachability.yaml").read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    ws = d["workspace"]
    ws["positions"]["x"]["n"] = ws["positions"]["y"]["n"] = n
    ws["chunk"] = 8
    d["expect"] = [e for e in d["expect"] if e["key"] != "n_poses"]
    p = tmp_path / "reach.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def test_puma_task_space_sweep(tmp_path, monkeypatch):
    # the numpy back end in this process and in the workers: which back end a process runs
    # depends on what it ran before (rent or buy, solvers/ik/accel.py), and the compiled and
    # numpy lm agree to tolerance, not bit for bit (as in tests/tasks/conftest.py)
    monkeypatch.setenv("MECHKIN_JIT", "0")
    out = tmp_path / "o"
    res = _run(_reach_copy(tmp_path), out, "--workers", "1")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["kind"] == "task_space" and s["n_poses"] == 16
    assert 0 < s["n_reachable"] < 16 and sum(s["status_counts"].values()) == 16
    assert s["max_position_error_m"] <= 1e-6
    assert 0 < s["isotropy"]["min"] <= s["isotropy"]["max"] <= 1
    assert s["condition_number"]["min"] >= 1 and s["manipulability"]["min"] > 0
    with (out / "task_points.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 16  # unreached poses are marked, not dropped
    assert {r["reachable"] for r in rows} == {"True", "False"} or \
        {r["reachable"] for r in rows} == {"1", "0"}
    assert all(abs(float(r["z_m"]) - 0.87183) < 1e-12 for r in rows)  # 0.2 + d1
    assert (out / "task_space.png").stat().st_size > 10_000
    _no_nan_in_csvs(out)
    out2 = tmp_path / "o2"
    assert _run(_reach_copy(tmp_path), out2, "--workers", "2", "--no-plots").exit_code == 0
    assert (out / "task_points.csv").read_bytes() == (out2 / "task_points.csv").read_bytes()


def test_task_space_monte_carlo_random_orientation(tmp_path):
    mech = (ROOT / "mechanisms" / "puma560.yaml").resolve()
    p = tmp_path / "mc.yaml"
    p.write_text(f"name: mc\ntask: workspace\nmechanism: {mech}\nunits: {{angle: deg}}\n"
                 "workspace:\n  kind: task_space\n  method: monte_carlo\n  samples: 6\n"
                 "  seed: 4\n  restarts: 2\n  orientation: {random: true}\n"
                 "  positions: {x: {range: [0.3, 0.5]}, y: {range: [-0.2, 0.2]}, "
                 "z: {value: 0.1}}\n")
    out = tmp_path / "o"
    res = _run(p, out, "--no-plots", "--workers", "1")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["n_poses"] == 6 and s["seed"] == 4


@pytest.mark.parametrize("extra, pattern", [
    ("  method: grid\n  positions: {x: {value: 0}, y: {value: 0}}\n", r"workspace: positions"),
    ("  method: grid\n  positions: {x: {range: [0, 1]}, y: {value: 0}, z: {value: 0}}\n",
     r"needs n for x"),
    ("  method: grid\n  joints: {q1: {n: 2}}\n  positions: {x: {value: 0}, y: {value: 0}, "
     "z: {value: 0}}\n", r"joints: not used by kind task_space"),
])
def test_bad_task_space_exit_2(tmp_path, extra, pattern):
    import re

    mech = (ROOT / "mechanisms" / "puma560.yaml").resolve()
    p = tmp_path / "bad.yaml"
    p.write_text(f"name: bad\ntask: workspace\nmechanism: {mech}\n"
                 "workspace:\n  kind: task_space\n" + extra)
    res = _run(p, tmp_path / "o")
    assert res.exit_code == 2, res.output
    assert re.search(pattern, res.output), res.output


@pytest.mark.parametrize("name", ["puma560_workspace.yaml", "lee_fig3_isotropy_r025.yaml"])
def test_wrong_scheduler_fails_before_work(tmp_path, name, monkeypatch):
    # joint sweeps and single lee maps run on a scheduler too (issue 16); a wrong address is
    # one line, exit 2, before the output folder exists
    monkeypatch.setenv("MECHKIN_DASK_TIMEOUT", "3")
    res = _run(_coarse_copy(tmp_path, name), tmp_path / "o", "--no-plots",
               "--scheduler", "tcp://127.0.0.1:1")
    assert res.exit_code == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "--scheduler " in lines[0]
    assert "no Dask scheduler answered" in lines[0]
    assert not (tmp_path / "o").exists()


def test_progress_for_joint_sweeps_and_single_lee_maps(tmp_path):
    res = _run(_coarse_copy(tmp_path, "puma560_workspace.yaml"), tmp_path / "o", "--no-plots",
               "--json", "--progress")
    assert res.exit_code == 0
    s = json.loads(res.stdout)
    assert "samples" in res.stderr and f"{s['n_samples']}/{s['n_samples']}" in res.stderr
    res = _run(_coarse_copy(tmp_path, "lee_fig2_gamma_range_r075.yaml"), tmp_path / "o2",
               "--no-plots", "--progress")
    n_maps = len(yaml.safe_load((SCEN / "lee_fig2_gamma_range_r075.yaml").read_text())
                 ["workspace"].get("isotropy_maps") or {}) + 1  # + the gamma range
    assert res.exit_code == 0 and "maps" in res.stderr and f"{n_maps}/{n_maps}" in res.stderr

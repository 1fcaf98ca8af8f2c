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


def test_failed_expect_exits_1_with_outputs(tmp_path):
    d = yaml.safe_load(_coarse_copy(tmp_path, "lee_fig5_isotropy_r075.yaml").read_text())
    d["expect"] = [{"key": "isotropy.text.per_gamma.0.sigma_ki_at_origin", "value": 0.5,
                    "tol": 1e-6}]
    p = tmp_path / "bad_expect.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    out = tmp_path / "o"
    res = _run(p, out, "--no-plots")
    assert res.exit_code == 1
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
    assert re_search(r"s\.yaml:\d+: workspace\.joints\.q9: not an independent joint", res.output)


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

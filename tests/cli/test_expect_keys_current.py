"""`mechkin check` refuses `expect:` keys the summary cannot have (mechkin.tasks.validate); its
lists of summary keys must follow the tasks. This runs one scenario of every task and kind and
asserts that each top-level summary key is one the validator knows."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from mechkin.config.scenario import load_scenario
from mechkin.tasks import run
from mechkin.tasks.validate import summary_top_keys

ROOT = Path(__file__).resolve().parents[2]


def _small(name: str, tmp_path: Path) -> Path:
    d = yaml.safe_load((ROOT / "scenarios" / name).read_text())
    if d.get("mechanism"):
        d["mechanism"] = str((ROOT / "scenarios" / d["mechanism"]).resolve())
    w = d.get("workspace")
    if w is not None:
        if "samples" in w:
            w["samples"] = 200
        for ax in ("alpha", "beta"):
            if ax in w:
                w[ax]["n"] = 11
        if "gamma_range" in w:
            w["gamma_range"].update(n=31, n_alpha=9, n_beta=9)
        if "positions" in w:
            for v in w["positions"].values():
                if "n" in v:
                    v["n"] = 3
    d["outputs"] = {"csv": False, "plots": False, "mcap": False}
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.mark.parametrize("name", [
    "kim1995_direct_drive_fk.yaml", "kim1995_table6_stewart_ik.yaml",
    "park_conveyor_none.yaml", "hwang2023_fig7_a.yaml", "lee_fig2_gamma_range_r075.yaml",
    "puma560_workspace.yaml", "puma560_reachability.yaml", "biped_floating_ik.yaml"])
def test_summary_keys_are_known_to_check(name, tmp_path):
    sc = load_scenario(_small(name, tmp_path))
    rep = run(sc)
    unknown = set(rep.summary) - set(summary_top_keys(sc)) - {"expect"}
    assert not unknown, f"add {sorted(unknown)} to mechkin/tasks/validate.py's key lists"

"""Validation computes what the run needs once and hands it on (issue 23): following a
scenario into ``tasks.run``, the closed form is recognised once and the biped legs are read
from the mechanism once, by the validation, and the run uses them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

import mechkin.solvers.biped.sequence as sequence
import mechkin.solvers.closed_form.recognise as recognise
from mechkin.config.scenario import load_scenario
from mechkin.model import load_mechanism
from mechkin.tasks import run, run_file
from mechkin.tasks.ik import run as run_ik
from mechkin.tasks.prepare import UNCHECKED, prepare

ROOT = Path(__file__).resolve().parents[2]


def _counting(monkeypatch, module, name):
    calls = []
    real = getattr(module, name)

    def counted(*a, **k):
        calls.append(a)
        return real(*a, **k)

    monkeypatch.setattr(module, name, counted)
    return calls


def _closed_form_scenario(tmp_path: Path, solutions: str = "one") -> Path:
    """kim1995's Stewart platform at one pose (Table 5's P1), method closed-form."""
    path = ROOT / "mechanisms" / "kim1995_stewart.yaml"
    mech = load_mechanism(path)
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, 8.0]
    targets = [{"name": "P1", "matrix": T.tolist()}]
    d = {"name": "cf", "task": "ik", "mechanism": str(path),
         "units": {"length": "m", "angle": "rad"},
         "ik": {"method": "closed-form", "targets": targets, "solutions": solutions},
         "outputs": {"csv": False, "plots": False, "mcap": False}}
    assert mech.end_effector is not None
    p = tmp_path / "cf.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def test_closed_form_is_recognised_once_per_run(tmp_path, monkeypatch):
    calls = _counting(monkeypatch, recognise, "recognise_closed_form")
    rep = run_file(_closed_form_scenario(tmp_path, solutions="all"), "ik")
    assert rep.status == "ok"
    assert len(calls) == 1  # by the validation; the run and solutions: all reuse it


def test_a_task_run_alone_recognises_it_itself(tmp_path, monkeypatch):
    calls = _counting(monkeypatch, recognise, "recognise_closed_form")
    rep = run_ik(load_scenario(_closed_form_scenario(tmp_path)))
    assert rep.status == "ok" and len(calls) == 1


def test_biped_legs_are_read_once_per_run(monkeypatch):
    calls = _counting(monkeypatch, sequence, "geometry_from_mechanism")
    rep = run(load_scenario(ROOT / "scenarios" / "hwang2023_fig7_a.yaml"))
    assert rep.status == "ok"
    assert len(calls) == 1


def test_prepare_keeps_the_validated_mechanism():
    sc = load_scenario(ROOT / "scenarios" / "kim1995_table6_stewart_ik.yaml")
    prep = prepare(sc)
    assert prep.mechanism is load_mechanism(sc.mechanism_path)
    assert prep.closed_form == UNCHECKED  # method lm: nobody asked for a closed form
    assert prep.recognise_closed_form() == "stewart"

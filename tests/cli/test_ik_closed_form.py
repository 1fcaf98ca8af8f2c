"""`method: closed-form` chosen by structure, not by name: a 6-6 Stewart platform that is not
bundled, through the ik task, equals lm to 1e-9; a mechanism without a closed form is refused
in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import frame_poses
from mechkin.tasks import run_file

ROOT = Path(__file__).resolve().parents[2]


def _scenario(tmp_path: Path, mech: Path, method: str, poses: np.ndarray) -> Path:
    targets = [{"name": f"P{k + 1}", "matrix": T.tolist()} for k, T in enumerate(poses)]
    d = {"name": f"cf_{method}", "task": "ik", "mechanism": str(mech),
         "units": {"length": "m", "angle": "rad"},
         "ik": {"method": method, "targets": targets,
                "tolerances": {"position": 1e-12, "orientation": 1e-12}},
         "outputs": {"csv": False, "plots": False, "mcap": False}}
    p = tmp_path / f"{method}.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def test_unbundled_66_stewart_closed_form_equals_lm(tmp_path):
    path = ROOT / "tests" / "data" / "stewart_66.yaml"
    mech = load_mechanism(path)
    rng = np.random.default_rng(3)
    home = mech.home[mech.independent]
    qv = home + rng.uniform(-0.03, 0.03, size=(3, len(home)))
    res = solve_closure(mech, qv, np.repeat(mech.home[mech.dependent][None], 3, axis=0))
    assert res.ok.all()
    poses = frame_poses(mech, res.q, [mech.end_effector])[:, 0]
    cf = run_file(_scenario(tmp_path, path, "closed-form", poses), "ik")
    lm = run_file(_scenario(tmp_path, path, "lm", poses), "ik")
    assert cf.status == "ok" and lm.status == "ok"
    q_cf = np.array([list(t["q_v"].values()) for t in cf.summary["targets"]])
    q_lm = np.array([list(t["q_v"].values()) for t in lm.summary["targets"]])
    np.testing.assert_allclose(q_cf, q_lm, atol=1e-9)
    np.testing.assert_allclose(q_cf, qv, atol=1e-9)


def test_no_closed_form_is_one_line(tmp_path):
    path = ROOT / "mechanisms" / "puma560.yaml"
    with pytest.raises(ConfigError, match="no closed form fits mechanism 'puma560'") as exc:
        run_file(_scenario(tmp_path, path, "closed-form", np.eye(4)[None]), "ik")
    assert len(str(exc.value).splitlines()) == 1

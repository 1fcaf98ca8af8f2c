"""The README's newcomer material runs as written: the five scenario examples (one per task)
pass ``mechkin check``, the ik one (rpy targets, an asserted ``unreachable``) runs to exit 0,
and the API's main-guard example runs a sweep on worker processes from a script file."""

import os
import re
import subprocess
import sys
from pathlib import Path

import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
runner = CliRunner()


def _examples() -> dict[str, str]:
    part = README.split("## Scenario examples (one per task)", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```yaml\n(.*?)```", part, flags=re.S)
    return {yaml.safe_load(b)["task"] + ("/biped" if "biped:" in b else ""): b for b in blocks}


def _place(tmp_path: Path, text: str) -> Path:
    name = yaml.safe_load(text)["name"]
    p = tmp_path / "scenarios" / f"{name}.yaml"
    p.parent.mkdir(exist_ok=True)
    p.write_text(text.replace("../mechanisms/", f"{ROOT / 'mechanisms'}/"))
    return p


def test_one_example_per_task_and_each_checks_ok(tmp_path):
    ex = _examples()
    assert sorted(ex) == ["fk", "ik", "ik/biped", "track", "workspace"]
    paths = [_place(tmp_path, t) for t in ex.values()]
    res = runner.invoke(app, ["check", *map(str, paths)])
    assert res.exit_code == 0, res.output
    assert res.stdout.count(": ok") == 5


def test_ik_example_runs_and_its_asserted_failure_passes(tmp_path):
    p = _place(tmp_path, _examples()["ik"])
    res = runner.invoke(app, ["run", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 0, res.output
    assert "3/3 expects" in res.stdout and "unreachable" in res.stdout


def test_api_main_guard_example_runs_from_a_script(tmp_path):
    part = README.split("## Python API", 1)[1].split("\n## ", 1)[0]
    block = [b for b in re.findall(r"```python\n(.*?)```", part, flags=re.S)
             if "__main__" in b][0]
    script = tmp_path / "sweep.py"
    script.write_text(block)
    proc = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                               "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"],
                               "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["ok", "1.0"]

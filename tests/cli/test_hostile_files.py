"""Hostile files of every kind and the exit-3 list (issue 28 items 4, 8, 9, 10): every input
file kind is read through one guard (regular files only, size and element caps), every case
ends in one located line and exit 2 within the time limit (a FIFO never hangs a run), no file
content is echoed, and nothing is written."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAX_LINE = 300

PLANAR = """name: arm
units: {length: m, angle: deg}
links:
  - name: base
  - name: l1
  - name: l2
    frames:
      - {name: hand, xyz: [0.3, 0, 0]}
joints:
  - {name: q1, type: revolute, parent: base, child: l1, limits: [-170, 170]}
  - {name: JOINT2, type: prismatic, parent: l1, child: l2, origin: {xyz: [0.6, 0, 0]},
     axis: [1, 0, 0], limits: [0, 0.5]}
independent: [q1, JOINT2]
end_effector: hand
"""
FK = """name: s
task: fk
mechanism: MECH
units: {length: m, angle: deg}
fk:
  time: {start: 0, stop: 1, step: 0.5}
  motion:
    q1: {type: ramp, from: 0, to: 10}
"""
FK_CSV = """name: s
task: fk
mechanism: m.yaml
fk:
  csv: CSV
"""
URDF = """<robot name="bot"><link name="a"/><link name="b"/>
<joint name="j" type="TYPE"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
<limit lower="LO" upper="HI" effort="1" velocity="1"/></joint></robot>
"""
MJCF_INCLUDE = """<mujoco><include file="part.xml"/><worldbody><body name="a">
<joint name="j" type="hinge" axis="0 0 1"/><geom size="0.1"/></body></worldbody></mujoco>
"""
MJCF_MESH = """<mujoco><asset><mesh name="m" file="arm.stl"/></asset><worldbody><body name="a">
<joint name="j" type="hinge" axis="0 0 1"/><geom type="mesh" mesh="m"/></body></worldbody>
</mujoco>
"""


def _env(tmp_path: Path, **extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MECHKIN_JIT="0",
               NUMBA_CACHE_DIR=str(tmp_path / "numba"), **extra)
    return env


def _mechkin(tmp_path: Path, *args: str, cwd: Path | None = None, timeout: float = 60,
             **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mechkin", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd or tmp_path,
                          env=_env(tmp_path, **env))


def _one_line(r: subprocess.CompletedProcess, names: str, key: str = "") -> str:
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr
    assert len(lines[0]) <= MAX_LINE, len(lines[0])
    assert names in lines[0], (names, lines[0])
    assert key in lines[0], (key, lines[0])
    return lines[0]


def _special(p: Path, kind: str) -> None:
    if kind == "fifo":
        os.mkfifo(p)
    else:
        p.symlink_to("/dev/zero")


# ---- item 4: robot files, includes, meshes, tables, a previous summary ------------------------


@pytest.mark.parametrize("kind", ["fifo", "zero"])
@pytest.mark.parametrize("name", ["r.urdf", "r.xml", "r.mjcf"])
def test_a_special_robot_file_is_refused_at_once(tmp_path, kind, name):
    robot = tmp_path / name
    _special(robot, kind)
    r = _mechkin(tmp_path, "import", str(robot))
    _one_line(r, str(robot), "FIFO" if kind == "fifo" else "device")
    (tmp_path / "s.yaml").write_text(FK.replace("MECH", name))
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o")
    _one_line(r, name)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["fifo", "zero"])
@pytest.mark.parametrize("what", ["include", "mesh"])
def test_mjcf_includes_and_meshes_are_checked_before_mujoco_opens_them(tmp_path, kind, what):
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF_INCLUDE if what == "include" else MJCF_MESH)
    bad = tmp_path / ("part.xml" if what == "include" else "arm.stl")
    _special(bad, kind)
    r = _mechkin(tmp_path, "import", str(robot))
    _one_line(r, str(bad), "FIFO" if kind == "fifo" else "device")


@pytest.mark.parametrize("kind", ["fifo", "zero", "large"])
def test_a_motion_csv_that_is_special_or_too_large_is_refused(tmp_path, kind):
    (tmp_path / "m.yaml").write_text(PLANAR)
    (tmp_path / "s.yaml").write_text(FK_CSV.replace("CSV", "q.csv"))
    csv = tmp_path / "q.csv"
    if kind == "large":
        row = "0.5,1.0,0.1\n"
        csv.write_text("t_s,q1_deg,JOINT2_m\n" + row * (2 * 1024 * 1024 // len(row)))
        r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o", MECHKIN_MAX_TABLE_MB="1")
        _one_line(r, "q.csv", "more than the limit")
    else:
        _special(csv, kind)
        r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o")
        _one_line(r, "s.yaml", "csv")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["fifo", "zero"])
def test_a_previous_summary_that_is_special_never_hangs_a_run(tmp_path, kind):
    out = tmp_path / "o"
    out.mkdir()
    _special(out / "summary.json", kind)
    fk = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    for extra in ([], ["--force"]):
        r = _mechkin(tmp_path, "fk", str(fk), "--out", str(out), "--no-plots", *extra)
        _one_line(r, "o", "summary.json" if extra else "not empty")
    assert (out / "summary.json").is_symlink() or (out / "summary.json").is_fifo()
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def _long_urdf(n: int) -> str:
    parts = ['<robot name="big">', '<link name="l0"/>']
    for i in range(1, n + 1):
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="revolute"><parent '
                     f'link="l{i - 1}"/><child link="l{i}"/><axis xyz="0 0 1"/></joint>')
    return "\n".join(parts + ["</robot>"])


def _long_mjcf(n: int) -> str:
    body = '<body name="b{i}"><joint name="j{i}" type="hinge"/><geom size="0.1"/>'
    return ("<mujoco><worldbody>" + "".join(body.format(i=i) for i in range(n))
            + "</body>" * n + "</worldbody></mujoco>")


@pytest.mark.parametrize("fmt", ["urdf", "mjcf"])
def test_a_robot_beyond_the_joint_limit_is_refused_before_parsing(tmp_path, fmt):
    """1e5 links grew to 3 GB (URDF) or ran >150 s (MJCF); a file over the limit is refused
    from its text, in well under a second of parsing and a little memory."""
    robot = tmp_path / f"big.{'urdf' if fmt == 'urdf' else 'xml'}"
    robot.write_text(_long_urdf(101) if fmt == "urdf" else _long_mjcf(101))
    r = _mechkin(tmp_path, "import", str(robot), MECHKIN_MAX_ROBOT_JOINTS="100")
    _one_line(r, str(robot), "more than the limit of 100")


# ---- item 8: colliding columns; the importer refuses what the YAML reader refuses -------------


@pytest.mark.parametrize("name", ["ee_x", "position_error", "ee_qw"])
def test_a_joint_whose_column_collides_is_refused_naming_both(tmp_path, name):
    (tmp_path / "m.yaml").write_text(PLANAR.replace("JOINT2", name))
    (tmp_path / "s.yaml").write_text(FK.replace("MECH", "m.yaml"))
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o")
    line = _one_line(r, "m.yaml", f"joint '{name}'")
    assert f"'{name}_m'" in line and "column" in line
    r = _mechkin(tmp_path, "check", "m.yaml")
    assert r.returncode == 2 and f"'{name}_m'" in r.stderr


@pytest.mark.parametrize("lo,hi,key", [("1", "-1", "joint[j].limit"),
                                        ("nan", "1", "joint[j].limit"),
                                        ("0", "inf", "joint[j].limit")])
def test_the_urdf_importer_refuses_inverted_or_nonfinite_limits(tmp_path, lo, hi, key):
    robot = tmp_path / "r.urdf"
    robot.write_text(URDF.replace("TYPE", "revolute").replace("LO", lo).replace("HI", hi))
    r = _mechkin(tmp_path, "import", str(robot))
    _one_line(r, f"{robot}:3:", key)  # at the <limit> element's own line


# ---- item 9: the exit-3 list ------------------------------------------------------------------


def test_urdf_ball_joint_is_a_located_exit_2(tmp_path):
    robot = tmp_path / "r.urdf"
    robot.write_text(URDF.replace("TYPE", "ball").replace("LO", "-1").replace("HI", "1"))
    r = _mechkin(tmp_path, "import", str(robot))
    _one_line(r, f"{robot}:2:", "joint[j].type: ball joints are not supported")


def test_max_memory_of_1e308_terabytes_is_exit_2(tmp_path):
    fk = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    r = _mechkin(tmp_path, "fk", str(fk), "--out", "o", "--max-memory", "1e308T")
    _one_line(r, "--max-memory")


@pytest.mark.parametrize("edit", ["stop: 1.7e+308, step: 0.5e+308", "table"])
def test_fk_times_near_1e308_are_a_located_exit_2(tmp_path, edit):
    (tmp_path / "m.yaml").write_text(PLANAR)
    if edit == "table":
        sc = FK.replace("MECH", "m.yaml").replace(
            "  time: {start: 0, stop: 1, step: 0.5}\n  motion:\n    q1: {type: ramp, from: 0, "
            "to: 10}\n", "  table: {t: [0, 1, 2, 1.7e+308], q1: [0, 1, 2, 3], "
                         "JOINT2: [0, 0, 0, 0]}\n")
    else:
        sc = FK.replace("MECH", "m.yaml").replace("stop: 1, step: 0.5", edit)
    (tmp_path / "s.yaml").write_text(sc)
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o")
    _one_line(r, "s.yaml", "fk")


def test_a_sinusoid_frequency_of_1e308_is_not_an_internal_error(tmp_path):
    (tmp_path / "m.yaml").write_text(PLANAR)
    sc = FK.replace("MECH", "m.yaml").replace(
        "{type: ramp, from: 0, to: 10}", "{type: sinusoid, amplitude: 10, frequency: 1.0e+308}")
    (tmp_path / "s.yaml").write_text(sc)
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o", "--no-plots")
    assert r.returncode in (0, 1, 2) and "internal error" not in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


def test_a_deleted_working_directory_is_a_located_exit_2(tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    fk = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    code = ("import os, sys, runpy; os.chdir(sys.argv[1]); os.rmdir(sys.argv[1]); "
            "sys.argv = ['mechkin', 'fk', sys.argv[2], '--no-plots']; "
            "runpy.run_module('mechkin', run_name='__main__')")
    r = subprocess.run([sys.executable, "-c", code, str(gone), str(fk)], capture_output=True,
                       text=True, timeout=60, cwd=tmp_path, env=_env(tmp_path))
    _one_line(r, "--out", "working directory")


# ---- item 10: messages ------------------------------------------------------------------------

PASSWD = ("root:x:0:0:root:/root:/bin/bash\n"
          "daemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n"
          "bin:x:2:2:bin:/bin:/usr/sbin/nologin\n")


def test_a_motion_csv_that_is_not_a_table_is_never_echoed(tmp_path):
    (tmp_path / "m.yaml").write_text(PLANAR)
    (tmp_path / "s.yaml").write_text(FK_CSV.replace("CSV", "passwd"))
    (tmp_path / "passwd").write_text(PASSWD)
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o")
    line = _one_line(r, "passwd")
    for field in ("root", "daemon", "nologin", "/bin"):
        assert field not in line.split("passwd", 1)[1], line


def test_a_bad_workers_value_is_one_line(tmp_path):
    fk = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    for bad in ("0", "abc"):
        r = _mechkin(tmp_path, "fk", str(fk), "--workers", bad)
        _one_line(r, "--workers")
        assert "╭" not in r.stderr and "Usage" not in r.stderr


def test_mujoco_never_writes_its_log_into_the_working_directory(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF_INCLUDE.replace('<include file="part.xml"/>', ""))
    code = ("import sys, mujoco; from mechkin.config.mjcf import read_mjcf_spec; "
            "read_mjcf_spec(sys.argv[1]); m = mujoco.MjModel.from_xml_path(sys.argv[1]); "
            "d = mujoco.MjData(m); d.qvel[:] = float('nan'); mujoco.mj_step(m, d)")
    r = subprocess.run([sys.executable, "-c", code, str(robot)], capture_output=True,
                       text=True, timeout=60, cwd=tmp_path, env=_env(tmp_path))
    assert r.returncode == 0, r.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert mujoco is not None


def test_an_import_problem_names_the_file_not_the_robot(tmp_path):
    robot = tmp_path / "r.urdf"
    robot.write_text('<robot name="bot"><link name="a"/><link name="b"/><joint name="j" '
                     'type="fixed"><parent link="a"/><child link="b"/></joint></robot>')
    r = _mechkin(tmp_path, "import", str(robot))
    _one_line(r, str(robot), "joint")


def test_summary_json_of_a_good_run_is_still_json(tmp_path):
    """The guards leave a plain run alone."""
    fk = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    r = _mechkin(tmp_path, "fk", str(fk), "--out", "o", "--no-plots")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["status"] == "ok"


def test_a_failed_expect_names_its_key_on_stdout(tmp_path):
    text = (ROOT / "scenarios" / "five_bar_fk.yaml").read_text()
    text = text.replace("../mechanisms/", f"{ROOT}/mechanisms/").replace(
        "frequency: 0.5}", "frequency: 0.7}", 1)
    (tmp_path / "s.yaml").write_text(text)
    r = _mechkin(tmp_path, "fk", "s.yaml", "--out", "o", "--no-plots")
    assert r.returncode == 5, r.stderr  # exit 5: an expect did not hold
    assert "expect failed: final.end_effector.xyz_m" in r.stdout, r.stdout

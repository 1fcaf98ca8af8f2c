"""``mechkin check`` predicts the run: a scenario that checks ok is not refused by the run, and
its ``expect:`` keys (at any depth) name values the run's summary holds.

The run validates with the same function as check (:func:`mechkin.tasks.validate.
scenario_problems`), so what check refuses the run refuses too. The other direction is tested
here on real runs: one scenario per summary template (fk, ik, track, both workspace sweeps)
is run once; 200 mutated expect keys (seeded) are judged by check and looked up in the real
summaries, and must agree both ways. The track start pose, refused by the run before it
plans, is refused by check too."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.cli.check_files import check_file_status
from mechkin.config.scenario import ExpectSpec, load_scenario
from mechkin.model import load_mechanism
from mechkin.tasks.common import evaluate_expect, lookup
from mechkin.tasks.validate import expect_problems

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()
# one bundled scenario per summary template, the cheapest of each
SAMPLE = ["delta_fk", "five_bar_ik", "planar3r_track_line", "delta_workspace",
          "puma560_reachability"]


def _copy(tmp_path: Path, name: str, edit=None) -> Path:
    d = yaml.safe_load((SCEN / f"{name}.yaml").read_text())
    if d.get("mechanism"):
        d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    if edit is not None:
        edit(d)
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """name -> (scenario, mechanism, summary of a real run)."""
    tmp = tmp_path_factory.mktemp("runs")
    out = {}
    for name in SAMPLE:
        res = runner.invoke(app, ["run", str(SCEN / f"{name}.yaml"), "--out", str(tmp),
                                  "--no-plots"])
        assert res.exit_code == 0, res.output
        summary = json.loads((tmp / name / "summary.json").read_text())
        sc = load_scenario(SCEN / f"{name}.yaml")
        mech = load_mechanism(sc.mechanism_path) if sc.mechanism_path else None
        out[name] = (sc, mech, summary)
    return out


def _leaves(obj, pre=()):
    """Every key path of a summary down to a number, a word or a list of numbers."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, (*pre, str(k)))
    elif isinstance(obj, list):
        if obj and all(isinstance(x, (int, float)) for x in obj):
            yield pre
        for i, v in enumerate(obj[:4]):
            yield from _leaves(v, (*pre, str(i)))
    elif obj is not None:
        yield pre


def _mutants(runs, n: int, seed: int = 0):
    """n (scenario name, key, word) triples: real keys and keys one edit away from them."""
    rng = np.random.default_rng(seed)
    pools = {name: [p for p in _leaves({k: v for k, v in s.items()
                                       if k not in ("expect", "files", "out_dir")}) if p]
             for name, (_, _, s) in runs.items()}
    typos = ["z", "x", "0", "3", "7", "xyz", "q9", "status", "min", "max_m", "R", "leg1", "q1"]
    out = []
    for _ in range(n):
        name = SAMPLE[int(rng.integers(len(SAMPLE)))]
        parts = list(pools[name][int(rng.integers(len(pools[name])))])
        op = int(rng.integers(5))
        if op == 1:  # one key deeper
            parts.append(typos[int(rng.integers(len(typos)))])
        elif op == 2 and len(parts) > 1:  # the group above the value
            parts.pop()
        elif op == 3:  # one part replaced
            k = int(rng.integers(len(parts)))
            parts[k] = typos[int(rng.integers(len(typos)))]
        elif op == 4 and parts[-1].isdigit():  # another index
            parts[-1] = str(int(rng.integers(6)))
        out.append((name, ".".join(parts), parts[-1] == "status" and bool(rng.integers(2))))
    return out


def _with_expect(sc, key: str, word: bool):
    """``sc`` with one expect entry on ``key`` (a status word, or any number)."""
    entry = {"key": key, "value": "ok"} if word else {"key": key, "min": -1e300}
    spec = sc.spec.model_copy(update={"expect": [ExpectSpec(**entry)]})
    return dataclasses.replace(sc, spec=spec)


def _value_dependent(summary, key: str) -> bool:
    """The key names a status count (present only for statuses that occur) or a value that
    is null in this run (e.g. first_failure_step when every step converged)."""
    parts = key.split(".")
    if len(parts) >= 2 and parts[-2] in ("counts", "status_counts"):
        return True
    try:
        return lookup(summary, key) is None
    except KeyError:
        return False


def test_check_and_run_agree_on_200_mutated_expect_keys(runs):
    disagree = []
    n_ok = n_refused = 0
    for name, key, word in _mutants(runs, 200):
        sc, mech, summary = runs[name]
        sc2 = _with_expect(sc, key, word)
        check_ok = not expect_problems(sc2, mech)
        held = evaluate_expect(summary, sc2.spec.expect)[0]
        run_found = held.get("actual") is not None and "no " not in held.get("message", "")
        if check_ok and not run_found and _value_dependent(summary, key):
            continue  # a count of a status that did not occur, a null value: exit 5, not 2
        n_ok += check_ok
        n_refused += not check_ok
        if check_ok != run_found:
            disagree.append((name, key, word, check_ok, held))
    if disagree:
        pytest.fail("check and run disagree:\n" + "\n".join(str(d[:4]) for d in disagree))
    assert n_ok > 40 and n_refused > 40  # both kinds of mutant occur


def test_the_issue_examples(tmp_path):
    # a deep key that passed check and failed the run: now check refuses it, the run too
    p = _copy(tmp_path, "delta_fk", lambda d: d["expect"].append(
        {"key": "final.end_effector.z", "value": 0.1, "tol": 0.01}))
    problems, _ = check_file_status(p)
    assert len(problems) == 1 and "final.end_effector is" not in problems[0]
    assert "final.end_effector has no key 'z'" in problems[0] and ":" in problems[0]
    res = runner.invoke(app, ["fk", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 2 and "final.end_effector has no key 'z'" in res.output
    # an unreachable track start pose: refused by check as by the run (before planning)
    q = _copy(tmp_path, "planar3r_track_line", lambda d: d["track"]["path"].update(
        start=[5.0, 0.0, 0.0]))
    problems, _ = check_file_status(q)
    assert problems and "track.path" in problems[0], problems
    res = runner.invoke(app, ["run", str(q), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 2
    assert problems[0] in res.output.replace("\n", " ") or "reach" in res.output


def test_group_and_word_keys(tmp_path):
    p = _copy(tmp_path, "five_bar_ik", lambda d: d["expect"].extend([
        {"key": "targets.0.q_v", "value": 1.0, "tol": 0.1},
        {"key": "targets.0.status", "value": 1.0, "tol": 0.1},
        {"key": "counts.leg1", "value": 1.0, "tol": 0.1},
        {"key": "targets.0.target.xyz_m.3", "value": 1.0, "tol": 0.1},
    ]))
    problems, _ = check_file_status(p)
    text = "\n".join(problems)
    assert "targets.0.q_v is a group of values, not one" in text
    assert "targets.0.status holds a word" in text
    assert "counts has no key 'leg1'" in text
    assert "targets.0.target.xyz_m is a list of 3 numbers: expected an index 0..2" in text
    assert len(problems) == 4
    # a word value is compared only with a status key (the file schema)
    q = _copy(tmp_path, "delta_fk", lambda d: d["expect"].append(
        {"key": "n_steps", "value": "ok"}))
    problems, _ = check_file_status(q)
    assert len(problems) == 1 and "is compared only with a status key" in problems[0]


# ---- mutated scenarios: check ok -> not refused by the run ----------------------------------

CHEAP = ["delta_fk", "five_bar_fk", "five_bar_ik", "delta_workspace", "hwang2023_fig7_h",
         "planar_3rrr_fk"]


def _numeric_paths(obj, pre=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _numeric_paths(v, (*pre, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _numeric_paths(v, (*pre, i))
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield pre


def _set(d, path, value):
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


def _mutate(d, rng):
    """One edit of a scenario dict: a number scaled, negated, zeroed or made a string; a joint
    or key renamed; a key dropped."""
    d = json.loads(json.dumps(d))
    section = next(k for k in ("fk", "ik", "biped", "workspace", "track") if k in d)
    paths = [p for p in _numeric_paths(d[section])]
    op = int(rng.integers(5))
    if op <= 2 and paths:
        p = (section, *paths[int(rng.integers(len(paths)))])
        cur = d
        for k in p:
            cur = cur[k]
        new = [cur * 10.0, -cur, 0, cur * 0.5, "1e-3", cur + 1000.0][int(rng.integers(6))]
        _set(d, p, new)
    elif op == 3:  # rename a key of a mapping in the section
        maps = [p for p in _dict_paths(d[section])]
        p = maps[int(rng.integers(len(maps)))]
        m = d[section]
        for k in p:
            m = m[k]
        if m:
            k = list(m)[int(rng.integers(len(m)))]
            m[k + "x"] = m.pop(k)
    else:  # drop a key of the section
        keys = list(d[section])
        d[section].pop(keys[int(rng.integers(len(keys)))])
    return d


def _dict_paths(obj, pre=()):
    if isinstance(obj, dict):
        yield pre
        for k, v in obj.items():
            yield from _dict_paths(v, (*pre, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _dict_paths(v, (*pre, i))


def test_200_mutated_scenarios_check_ok_means_the_run_accepts(tmp_path):
    rng = np.random.default_rng(1)
    base = {}
    for name in CHEAP:
        d = yaml.safe_load((SCEN / f"{name}.yaml").read_text())
        d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
        base[name] = d
    ok, refused = [], []
    for k in range(200):
        name = CHEAP[k % len(CHEAP)]
        d = _mutate(base[name], rng)
        d["name"] = f"m{k:03d}_{name}"
        p = tmp_path / f"{d['name']}.yaml"
        p.write_text(yaml.safe_dump(d, sort_keys=False))
        problems, internal = check_file_status(p)
        assert not internal, problems
        (refused if problems else ok).append(p)
    assert len(ok) > 20 and len(refused) > 20
    # a sample of each runs for real: refused by check -> refused by the run (exit 2);
    # ok by check -> the run starts (exit 0, 1 or 5: a solver or an expect may fail)
    for p in ok[:6] + refused[:3]:
        res = runner.invoke(app, ["run", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
        assert (res.exit_code == 2) == (p in refused), (p.name, res.output)


# ---- held joints (ik: fixed:): what the run refuses, check refuses ---------------------------


def _panda_fixed(tmp_path: Path, **ik) -> Path:
    d = {"name": "panda_held", "task": "ik", "mechanism": str(ROOT / "mechanisms" / "panda.yaml"),
         "units": {"length": "m", "angle": "deg"},
         "ik": {"method": "auto", "fixed": {"q7": 20}, "random_targets": {"count": 2, "seed": 1},
                **ik}}
    p = tmp_path / "panda_held.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.mark.parametrize(("ik", "words"), [
    # the held route solves the whole pose: position-only weights would be ignored
    ({"weights": [1, 1, 1, 0, 0, 0]}, "ik.weights: fixed: solves the whole pose"),
    ({"weights": [1, 1, 1, 0, 0, 0], "method": "analytic"}, "ik.weights: fixed:"),
    # method auto: the held set that does not decompose (check looked only at analytic)
    ({"fixed": {"q1": 20}}, "ik.fixed: no subproblem decomposition"),
    ({"fixed": {"nope": 20}}, "ik.fixed.nope: not an independent joint"),
])
def test_held_joints_check_refuses_what_the_run_refuses(tmp_path, ik, words):
    p = _panda_fixed(tmp_path, **ik)
    problems, internal = check_file_status(p)
    assert not internal and len(problems) == 1 and words in problems[0], problems
    res = runner.invoke(app, ["ik", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 2 and words in res.output, res.output
    assert not (tmp_path / "o").exists()


def test_held_joints_with_framed_targets_are_refused_not_ignored(tmp_path):
    p = _panda_fixed(tmp_path)
    d = yaml.safe_load(p.read_text())
    d["ik"].pop("random_targets")
    d["ik"]["targets"] = [{"frame": "panda_hand", "xyz": [0.4, 0, 0.5], "rpy": [180, 0, 0]}]
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    problems, _ = check_file_status(p)
    assert len(problems) == 1 and "fixed: holds joints for the end effector" in problems[0]


def test_random_targets_with_held_joints_are_poses_of_the_held_values(tmp_path):
    p = _panda_fixed(tmp_path, random_targets={"count": 12, "seed": 1})
    assert check_file_status(p) == ([], False)
    res = runner.invoke(app, ["ik", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["counts"]["ok"] == 12
    assert all(t["q_v"]["q7"] == pytest.approx(np.radians(20.0)) for t in s["targets"])


def test_check_with_max_time_refuses_what_the_run_would_refuse(tmp_path):
    """`check --max-time` applies the run's limit to the estimate: the same one line as the
    run's refusal (exit 2); with --max-time-policy stop it accepts, as the run would run."""
    sc = SCEN / "lee_fig2_gamma_range_r075.yaml"  # estimated about 12 s
    res = runner.invoke(app, ["check", str(sc), "--max-time", "5s"])
    assert res.exit_code == 2 and "estimated 12 s > --max-time 5 s" in res.output
    run = runner.invoke(app, ["workspace", str(sc), "--out", str(tmp_path / "o"),
                              "--no-plots", "--max-time", "5s"])
    assert run.exit_code == 2 and res.output.strip() == run.output.strip()
    res = runner.invoke(app, ["check", str(sc), "--max-time", "5s", "--max-time-policy",
                              "stop"])
    assert res.exit_code == 0 and "estimated to take about 12 s" in res.output
    assert runner.invoke(app, ["check", str(sc), "--max-time", "1h"]).exit_code == 0

"""Property-based: random and mutated mechanism files never crash the loader.

Whatever the file holds, loading either succeeds or raises ConfigError whose every line names
the file; nothing else escapes (no traceback for the user)."""

from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechkin.config.mechanism_file import read_mechanism_spec
from mechkin.errors import ConfigError
from mechkin.model.build import build_mechanism

ROOT = Path(__file__).resolve().parents[2]
BASES = [yaml.safe_load((ROOT / p).read_text()) for p in
         ("tests/data/fourbar.yaml", "mechanisms/puma560.yaml")]

scalars = st.one_of(st.none(), st.booleans(), st.integers(-5, 5),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8))
values = st.recursive(scalars, lambda c: st.one_of(st.lists(c, max_size=4),
                                                   st.dictionaries(st.text(max_size=6), c,
                                                                   max_size=4)), max_leaves=12)


def _paths(d, prefix=()):
    yield prefix
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from _paths(v, prefix + (i,))


def _load(tmp: Path, text: str) -> None:
    p = tmp / "fuzz.yaml"
    p.write_text(text)
    try:
        spec, doc = read_mechanism_spec(p)
        build_mechanism(spec, doc)
    except ConfigError as exc:
        assert exc.problems
        assert all(line.startswith(str(p)) or line.startswith("fuzz") for line in exc.problems)


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(base=st.sampled_from(BASES), data=st.data())
def test_mutated_files_never_crash(tmp_path, base, data):
    import copy

    d = copy.deepcopy(base)
    paths = [p for p in _paths(d) if p]
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        cur = d
        try:
            for k in path[:-1]:
                cur = cur[k]
            action = data.draw(st.sampled_from(["replace", "delete", "add"]))
            if action == "replace":
                cur[path[-1]] = data.draw(values)
            elif action == "delete" and isinstance(cur, dict):
                del cur[path[-1]]
            elif isinstance(cur, dict):
                cur[data.draw(st.text(min_size=1, max_size=6))] = data.draw(values)
        except (KeyError, IndexError, TypeError):
            continue
    _load(tmp_path, yaml.safe_dump(d, sort_keys=False))


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(max_size=200))
def test_random_text_never_crashes(tmp_path, text):
    _load(tmp_path, text)


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=values)
def test_random_yaml_documents_never_crash(tmp_path, doc):
    _load(tmp_path, yaml.safe_dump(doc))


# ---- the bounded loader: hostile YAML text and mutated bundled scenarios ----------------------

TOKENS = ["&a ", "&b ", "*a", "*b", "[", "]", "{", "}", ", ", ": ", "- ", "\n", "  ", "<<: ",
          "? ", "!!str ", "!!python/object ", "x", "1", "1.0e+400", ".nan", "'q'", '"\\u0000"',
          "---\n", "#c", "\t", "|\n  ", "k", "null", "0x1F", "2001-01-01"]


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(parts=st.lists(st.sampled_from(TOKENS), max_size=60),
       repeat=st.integers(1, 40))
def test_hostile_yaml_text_is_read_or_refused_in_one_line(tmp_path, parts, repeat):
    """Anchors, aliases, brackets, tags and merge keys in any order (repeated to build nesting):
    the loader returns data or raises one ConfigError line naming the file, quickly, and the
    data is what PyYAML builds whenever PyYAML accepts the text without expanding aliases."""
    import time

    from mechkin.config.load import read_yaml

    text = "".join(parts) * repeat
    p = tmp_path / "h.yaml"
    p.write_text(text, encoding="utf-8")
    t0 = time.process_time()
    try:
        read_yaml(p)
    except ConfigError as exc:
        assert len(exc.problems) == 1
        assert exc.problems[0].startswith(str(p)), exc.problems
        assert len(exc.problems[0]) <= 400
    assert time.process_time() - t0 < 2.0


SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(which=st.sampled_from(SCENARIOS), data=st.data())
def test_mutated_scenarios_never_crash_check(tmp_path, which, data):
    """A bundled scenario with 1-3 random mutations (values replaced, keys deleted or added),
    its mechanism copied alongside: ``mechkin check`` reports ok or problems naming a file,
    never an internal error."""
    import copy
    import shutil

    from mechkin.cli.check import check_file_status

    d = copy.deepcopy(yaml.safe_load(which.read_text()))
    mech = d.get("mechanism")
    if mech:
        shutil.copy(which.parent / mech, tmp_path / "m.yaml")
        d["mechanism"] = "m.yaml"
    paths = [p for p in _paths(d) if p and p != ("mechanism",)]
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        cur = d
        try:
            for k in path[:-1]:
                cur = cur[k]
            action = data.draw(st.sampled_from(["replace", "delete", "add"]))
            if action == "replace":
                cur[path[-1]] = data.draw(values)
            elif action == "delete" and isinstance(cur, dict):
                del cur[path[-1]]
            elif isinstance(cur, dict):
                cur[data.draw(st.text(min_size=1, max_size=6))] = data.draw(values)
        except (KeyError, IndexError, TypeError):
            continue
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    problems, internal = check_file_status(p)
    assert not internal, problems
    for line in problems:
        assert line.startswith(str(tmp_path)), line
        assert "Traceback" not in line

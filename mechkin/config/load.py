"""Read YAML with line numbers, so every problem can be reported as ``file:line: key.path: ...``.

DESIGN
------
Files come from users and may be hostile, so reading one is bounded in time and memory:

* only regular files are read (``os.stat`` first: a directory, device, FIFO or socket is
  refused before it is opened), at most ``MAX_FILE_BYTES`` (the file is opened non-blocking and
  at most limit + 1 bytes are read, so ``/dev/zero`` or a file growing while read cannot
  balloon);
* the text is scanned by libyaml's C parser (``yaml.CParser``) where installed, else by the
  pure-Python parser, into events, and the document is composed and constructed here, from the
  events, without recursion: a nesting deeper than ``MAX_DEPTH`` is refused; an alias is the
  same Python object as its anchor (as in PyYAML), but the nodes each alias would repeat if
  expanded are counted as the events arrive and a document whose aliases stand for more than
  ``MAX_ALIAS_NODES`` nodes is refused (alias "bombs"); an alias inside its own anchor (a
  self-referential sequence or mapping) is refused;
* merge keys (``<<: *base`` or ``<<: [*a, *b]``) work as in YAML 1.1: explicit keys win, then
  the merged mappings in order;
* only the safe tags (null, bool, int, float, str, binary, timestamp, seq, map) are accepted.

Every refusal is a ConfigError of one line ``file:line: key.path: message``. Strings echoed in
messages (keys, values, names) go through :func:`short` so a 1 MB name cannot flood the line.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from mechkin.errors import ConfigError

KeyPath = tuple[str | int, ...]

#: Largest file read, bytes (the bundled files are below 10 kB; a long motion goes in a CSV
#: file). ``MECHKIN_MAX_YAML_MB`` in the environment raises it.
MAX_FILE_BYTES = 2 * 1024 * 1024
#: Deepest nesting of sequences and mappings (the bundled files nest 6 deep).
MAX_DEPTH = 64
#: Most nodes the aliases of a document may stand for (each alias counts the scalars, sequences
#: and mappings it would repeat if expanded; the literal nodes are bounded by the file size).
MAX_ALIAS_NODES = 100_000
#: Longest string echoed in a message.
ECHO_CHARS = 60

_SAFE_SCALAR_TAGS = {
    "tag:yaml.org,2002:null", "tag:yaml.org,2002:bool", "tag:yaml.org,2002:int",
    "tag:yaml.org,2002:float", "tag:yaml.org,2002:str", "tag:yaml.org,2002:binary",
    "tag:yaml.org,2002:timestamp", "tag:yaml.org,2002:merge",
}
_SEQ_TAG = "tag:yaml.org,2002:seq"
_MAP_TAG = "tag:yaml.org,2002:map"
_MERGE_TAG = "tag:yaml.org,2002:merge"


def short(value: Any, n: int = ECHO_CHARS) -> str:
    """``repr`` of a value for a message, cut to ``n`` characters with an ellipsis."""
    s = repr(value)
    return s if len(s) <= n else s[: n - 3] + "..."


def short_str(value: Any, n: int = ECHO_CHARS) -> str:
    """``str`` of a value for a message (no quotes; control characters escaped, so a message
    stays one line), cut to ``n`` characters."""
    s = str(value)
    if not s.isprintable():
        s = repr(s)[1:-1]
    return s if len(s) <= n else s[: n - 3] + "..."


def short_tail(value: Any, n: int = ECHO_CHARS) -> str:
    """``str`` of a value (a path) cut from the left to ``n`` characters: ``...end/of/it``."""
    s = short_str(value, 10**9)
    return s if len(s) <= n else "..." + s[-(n - 3):]


def short_list(names: Any, n_chars: int = 100, n: int = 30) -> str:
    """``a, b, c, ... (N in all)``: the names that fit in about ``n_chars`` characters, each cut
    to ``n`` characters."""
    names = list(names)
    parts: list[str] = []
    used = 0
    for x in names:
        s = short_str(x, n)
        if parts and used + len(s) > n_chars:
            break
        parts.append(s)
        used += len(s) + 2
    out = ", ".join(parts)
    return out + (f", ... ({len(names)} in all)" if len(parts) < len(names) else "")


@dataclass(frozen=True)
class YamlDoc:
    """A parsed YAML document: plain data, its file, and the line of every key path."""

    path: Path
    data: Any
    lines: dict[KeyPath, int]

    def line_of(self, key_path: KeyPath) -> int:
        """Line (1-based) of the longest prefix of ``key_path`` that exists in the file."""
        kp = tuple(key_path)
        while kp:
            if kp in self.lines:
                return self.lines[kp]
            kp = kp[:-1]
        return self.lines.get((), 1)

    def where(self, key_path: KeyPath) -> str:
        """``file:line: key.path`` prefix for a message."""
        return f"{self.path}:{self.line_of(key_path)}: {format_key_path(key_path)}"


def format_key_path(key_path: KeyPath) -> str:
    """``("joints", 3, "axis")`` -> ``joints[3].axis``; the empty path -> ``(top level)``.

    Each key is cut to ``ECHO_CHARS`` characters."""
    parts = [f"[{k}]" if isinstance(k, int) and not isinstance(k, bool) else short_str(k)
             for k in key_path]
    if len(parts) > 10:  # a deep path: its head and tail
        parts = parts[:4] + [f"[...{len(parts) - 7} more]"] + parts[-3:]
    out = ""
    for part in parts:
        out += part if (part.startswith("[") or not out) else "." + part
    return out or "(top level)"


# ---- reading the bytes ------------------------------------------------------------------------


def _mib(n: int) -> str:
    return f"{n / 1024 / 1024:.3g} MiB"


def _read_text(path: Path, limit: int) -> str:
    """The file's text through the one guarded reader (:mod:`mechkin.config.guarded_read`):
    ConfigError for anything but a readable regular UTF-8 file of at most ``limit`` bytes."""
    from mechkin.config.guarded_read import read_text

    return read_text(path, what="YAML file", limit=limit,
                     hint="a long motion goes in a CSV file; MECHKIN_MAX_YAML_MB raises the "
                          "limit")


# ---- composing and constructing from events ---------------------------------------------------


class _Frame:
    """An open sequence or mapping while its events arrive."""

    __slots__ = ("kind", "path", "anchor", "line", "size", "items", "key", "key_line",
                 "explicit", "merges", "merge_line")

    def __init__(self, kind: str, path: KeyPath, anchor: str | None, line: int) -> None:
        self.kind = kind  # "seq" or "map"
        self.path = path
        self.anchor = anchor
        self.line = line
        self.size = 1
        self.items: list[Any] = []
        self.key: Any = _NO_KEY
        self.key_line = 0
        self.explicit: dict[Any, Any] = {}
        self.merges: list[Any] = []
        self.merge_line = 0

    def child_path(self) -> KeyPath:
        if self.kind == "seq":
            return self.path + (len(self.items),)
        return self.path + (_path_key(self.key),)


_NO_KEY = object()
_MERGE_KEY = object()


def _path_key(key: Any) -> str | int:
    if isinstance(key, str):
        return key
    if isinstance(key, int) and not isinstance(key, bool):
        return key
    return str(key)


class _Composer:
    """Builds plain Python data and the line of every key path from a parser's events."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.text = text
        cls = getattr(yaml, "CSafeLoader", None) if yaml.__with_libyaml__ else None
        self.loader = (cls or yaml.SafeLoader)(text)
        self.constructor = yaml.constructor.SafeConstructor()
        self.anchors: dict[str, tuple[Any, int]] = {}  # name -> (object, expanded size)
        self.open_anchors: set[str] = set()
        self.lines: dict[KeyPath, int] = {(): 1}
        self.total = 0

    def fail(self, line: int, key_path: KeyPath | None, msg: str) -> ConfigError:
        where = f"{self.path}:{line}: "
        if key_path is not None:
            where += f"{format_key_path(key_path)}: "
        return ConfigError(where + msg)

    def run(self) -> Any:
        p = self.loader
        try:
            return self._events(p)
        finally:
            p.dispose()

    def _count(self, n: int, line: int, kp: KeyPath) -> None:
        self.total += n
        if self.total > MAX_ALIAS_NODES:
            raise self.fail(line, kp, f"the aliases expand to more than {MAX_ALIAS_NODES} "
                            "nodes (an alias bomb?); refusing to read the file")

    def _scalar(self, ev: Any, line: int, kp: KeyPath) -> Any:
        tag = ev.tag
        if tag is None or tag == "!":
            tag = self.loader.resolve(yaml.ScalarNode, ev.value, ev.implicit)
        if tag not in _SAFE_SCALAR_TAGS:
            raise self.fail(line, kp, f"unsupported tag {short(tag)} (plain values only)")
        if tag == _MERGE_TAG:
            return _MERGE_KEY
        node = yaml.ScalarNode(tag, ev.value, ev.start_mark, ev.end_mark, ev.style)
        try:
            return self.constructor.yaml_constructors[tag](self.constructor, node)
        except Exception as exc:  # noqa: BLE001 - a scalar the safe constructor rejects
            msg = getattr(exc, "problem", None) or str(exc)
            raise self.fail(line, kp, f"cannot read value {short(ev.value)}: "
                            f"{short_str(msg, 100)}") from None

    def _events(self, p: Any) -> Any:
        stack: list[_Frame] = []
        root: Any = None
        n_docs = 0
        while True:
            try:
                ev = p.get_event()
            except yaml.YAMLError as exc:
                # newer libyaml refuses deep nesting itself: the same refusal, with the key path
                if "nesting depth" not in str(getattr(exc, "problem", None) or exc):
                    raise
                mark = getattr(exc, "problem_mark", None)
                top = stack[-1] if stack else None
                kp = None if top is None else (
                    top.path if top.kind == "map" and top.key is _NO_KEY else top.child_path())
                raise self.fail(mark.line + 1 if mark is not None else 1, kp,
                                f"nesting deeper than {MAX_DEPTH} levels") from None
            line = ev.start_mark.line + 1 if ev.start_mark is not None else 1
            if isinstance(ev, yaml.StreamEndEvent):
                break
            if isinstance(ev, (yaml.StreamStartEvent, yaml.DocumentEndEvent)):
                continue
            if isinstance(ev, yaml.DocumentStartEvent):
                n_docs += 1
                if n_docs > 1:
                    raise self.fail(line, None, "expected a single document in the file, "
                                    "found another one")
                continue
            top = stack[-1] if stack else None
            in_key = top is not None and top.kind == "map" and top.key is _NO_KEY
            kp = top.child_path() if (top is not None and not in_key) else (
                top.path if top is not None else ())
            if isinstance(ev, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                fr = stack.pop()
                value = self._close(fr)
                if fr.anchor is not None:
                    self.open_anchors.discard(fr.anchor)
                    self.anchors[fr.anchor] = (value, fr.size)
                self._deliver(stack, value, fr.size, fr.line)
                if not stack:
                    root = value
                continue
            if isinstance(ev, yaml.AliasEvent):
                if ev.anchor in self.open_anchors:
                    raise self.fail(line, kp, f"alias *{short_str(ev.anchor)} refers to a "
                                    "node that contains it (self-referential structure)")
                if ev.anchor not in self.anchors:
                    raise self.fail(line, kp, f"undefined alias *{short_str(ev.anchor)}")
                value, size = self.anchors[ev.anchor]
                if in_key and isinstance(value, (list, dict)):
                    raise self.fail(line, kp, "a sequence or mapping as a mapping key is not "
                                    "supported")
                self._count(size, line, kp)  # what the alias would repeat
                if not in_key:
                    self.lines.setdefault(kp, line)
                self._deliver(stack, value, size, line)
                if not stack:
                    root = value
                continue
            if isinstance(ev, yaml.ScalarEvent):
                value = self._scalar(ev, line, kp)
                if ev.anchor is not None:
                    self.anchors[ev.anchor] = (value, 1)
                if not in_key and value is not _MERGE_KEY:
                    self.lines.setdefault(kp, line)
                elif value is _MERGE_KEY and not in_key:
                    raise self.fail(line, kp, "'<<' (merge) is only valid as a mapping key")
                self._deliver(stack, value, 1, line)
                if not stack:
                    root = value
                continue
            # a sequence or mapping starts
            if in_key:
                raise self.fail(line, kp, "a sequence or mapping as a mapping key is not "
                                "supported")
            if len(stack) >= MAX_DEPTH:
                raise self.fail(line, kp, f"nesting deeper than {MAX_DEPTH} levels")
            kind = "seq" if isinstance(ev, yaml.SequenceStartEvent) else "map"
            tag = ev.tag
            if tag not in (None, "!", _SEQ_TAG if kind == "seq" else _MAP_TAG):
                raise self.fail(line, kp, f"unsupported tag {short(tag)} (plain values only)")
            if stack:
                self.lines.setdefault(kp, line)
            if ev.anchor is not None:
                self.open_anchors.add(ev.anchor)
            stack.append(_Frame(kind, kp, ev.anchor, line))
        return root

    def _deliver(self, stack: list[_Frame], value: Any, size: int, line: int) -> None:
        """Hand a finished value to the open collection on top of the stack."""
        if not stack:
            return
        fr = stack[-1]
        fr.size += size
        if fr.kind == "seq":
            fr.items.append(value)
            return
        if fr.key is _NO_KEY:
            if value is not _MERGE_KEY:
                try:
                    hash(value)
                except TypeError:
                    raise self.fail(line, fr.path, "unhashable mapping key") from None
            fr.key, fr.key_line = value, line
            if value is not _MERGE_KEY:
                kp = fr.path + (_path_key(value),)
                if value in fr.explicit:
                    raise self.fail(line, kp, "duplicate key")
                self.lines.setdefault(kp, line)
            return
        key, fr.key = fr.key, _NO_KEY
        if key is _MERGE_KEY:
            srcs = value if isinstance(value, list) else [value]
            if not all(isinstance(s, dict) for s in srcs):
                raise self.fail(fr.key_line, fr.path + ("<<",), "a merge key '<<' takes a "
                                "mapping or a sequence of mappings")
            fr.merges.extend(srcs)
            fr.merge_line = fr.key_line
            return
        fr.explicit[key] = value

    def _close(self, fr: _Frame) -> Any:
        if fr.kind == "seq":
            return fr.items
        if not fr.merges:
            return fr.explicit
        out: dict[Any, Any] = {}
        for src in fr.merges:
            for k, v in src.items():
                if k not in out and k not in fr.explicit:
                    out[k] = v
                    self.lines.setdefault(fr.path + (_path_key(k),), fr.merge_line)
        out.update(fr.explicit)
        return out


def parse_yaml_text(path: Path, text: str) -> tuple[Any, dict[KeyPath, int]]:
    """Data and key-path lines of one YAML document (``path`` only names it in messages)."""
    comp = _Composer(path, text)
    try:
        data = comp.run()
    except ConfigError:
        raise
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else 1
        problem = exc.problem or exc.context or "invalid YAML"
        raise ConfigError(f"{path}:{line}: YAML syntax error: {short_str(problem, 120)}") \
            from None
    except yaml.reader.ReaderError as exc:
        pos = getattr(exc, "position", 0) or 0
        line = text.count("\n", 0, pos) + 1
        raise ConfigError(f"{path}:{line}: YAML syntax error: special characters are not "
                          f"allowed ({short_str(exc.reason, 80)})") from None
    except yaml.YAMLError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "invalid YAML"
        raise ConfigError(f"{path}:1: YAML syntax error: {short_str(msg, 120)}") from None
    return data, comp.lines


def max_file_bytes() -> int:
    """``MAX_FILE_BYTES``, or ``MECHKIN_MAX_YAML_MB`` MiB when that is set to a number > 0."""
    env = os.environ.get("MECHKIN_MAX_YAML_MB", "")
    try:
        mb = float(env) if env else 0.0
    except ValueError:
        mb = 0.0
    return int(mb * 1024 * 1024) if 0 < mb < 1e6 else MAX_FILE_BYTES


def read_yaml(path: str | Path, max_bytes: int | None = None) -> YamlDoc:
    """Parse a YAML file with the limits of this module; raise ConfigError (one line) on a
    missing, non-regular or too large file, bad YAML, an alias bomb or too deep nesting."""
    path = Path(path)
    text = _read_text(path, max_file_bytes() if max_bytes is None else max_bytes)
    data, lines = parse_yaml_text(path, text)
    return YamlDoc(path=path, data=data, lines=lines)


#: notes already written: (file, its mtime and size, the line)
_NOTED: set[tuple[str, object, str]] = set()


def note_once(path: Path, line: str) -> None:
    """Write the note ``line`` (``robot.urdf: note: ...``) to stderr once per file version: a
    robot file read twice in one run (``check``'s spec read and the run's cached build) says
    it once. The same file changed on disk (a new mtime or size) says it again."""
    try:
        st = os.stat(path)
        version: object = (st.st_mtime_ns, st.st_size)
    except (OSError, ValueError):
        version = None
    key = (os.path.realpath(path), version, line)
    if key in _NOTED:
        return
    if len(_NOTED) > 10_000:  # a long-lived process reading many files: forget the oldest
        _NOTED.clear()
    _NOTED.add(key)
    sys.stderr.write(line if line.endswith("\n") else line + "\n")

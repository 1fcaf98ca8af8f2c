"""Read YAML with line numbers, so every problem can be reported as ``file:line: key.path: ...``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from mechkin.errors import ConfigError

KeyPath = tuple[str | int, ...]


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
    """``("joints", 3, "axis")`` -> ``joints[3].axis``; the empty path -> ``(top level)``."""
    out = ""
    for k in key_path:
        if isinstance(k, int):
            out += f"[{k}]"
        else:
            out += ("." if out else "") + str(k)
    return out or "(top level)"


def _walk(node: yaml.Node, path: KeyPath, lines: dict[KeyPath, int], dups: list[str]) -> None:
    if isinstance(node, yaml.MappingNode):
        seen: set[str] = set()
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else str(k.value)
            sub = path + (key,)
            if key in seen:
                dups.append(f"{k.start_mark.line + 1}: {format_key_path(sub)}: duplicate key")
            seen.add(key)
            lines.setdefault(sub, k.start_mark.line + 1)
            _walk(v, sub, lines, dups)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            sub = path + (i,)
            lines[sub] = item.start_mark.line + 1
            _walk(item, sub, lines, dups)


def read_yaml(path: str | Path) -> YamlDoc:
    """Parse a YAML file; raise ConfigError (one line per problem) on a missing file or bad YAML."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a YAML file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read: {exc}") from None
    try:
        loader = yaml.SafeLoader(text)
        try:
            node = loader.get_single_node()
            data = loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else 1
        problem = exc.problem or exc.context or "invalid YAML"
        raise ConfigError(f"{path}:{line}: YAML syntax error: {problem}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}:1: YAML syntax error: {exc}") from None
    lines: dict[KeyPath, int] = {(): 1}
    dups: list[str] = []
    if node is not None:
        _walk(node, (), lines, dups)
    if dups:
        raise ConfigError([f"{path}:{d}" for d in dups])
    return YamlDoc(path=path, data=data, lines=lines)

"""YAML loading that remembers where every mapping, key and list item came from."""

from __future__ import annotations

from pathlib import Path

import yaml

from assembly.errors import TreeError


class Located(dict):
    """A mapping from YAML with the line of the mapping and of each key (1-based)."""

    file: str = ""
    line: int = 0
    key_lines: dict

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)


class LocatedList(list):
    file: str = ""
    line: int = 0
    item_lines: list


class _Loader(yaml.SafeLoader):
    """SafeLoader that builds `Located` mappings and lists and rejects duplicate keys."""


def _construct_mapping(loader: _Loader, node: yaml.MappingNode) -> Located:
    loader.flatten_mapping(node)
    out = Located()
    out.file, out.line, out.key_lines = loader.name, node.start_mark.line + 1, {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if not isinstance(key, (str, int, float, bool, type(None))):
            raise TreeError(f"a mapping key must be a plain value, got {key!r}", loader.name,
                            key_node.start_mark.line + 1)
        if key in out:
            raise TreeError(f"duplicate key {key!r}", loader.name, key_node.start_mark.line + 1)
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[key] = key_node.start_mark.line + 1
    return out


def _construct_sequence(loader: _Loader, node: yaml.SequenceNode) -> LocatedList:
    out = LocatedList(loader.construct_object(child, deep=True) for child in node.value)
    out.file, out.line = loader.name, node.start_mark.line + 1
    out.item_lines = [child.start_mark.line + 1 for child in node.value]
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def load_text(text: str, name: str):
    """Parse YAML text; syntax errors become a TreeError with the line."""
    loader = None
    try:
        loader = _Loader(text)  # checks every character first
        loader.name = name
        return loader.get_single_data()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        raise TreeError(f"malformed YAML: {exc.problem or exc}", name, line) from None
    except yaml.reader.ReaderError as exc:
        raise TreeError(f"malformed YAML: character #x{exc.character:04x}: {exc.reason}", name,
                        text.count("\n", 0, exc.position) + 1) from None
    finally:
        if loader is not None:
            loader.dispose()


def load_file(path: str | Path):
    """Read and parse a YAML file; a missing or unreadable file becomes a TreeError."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise TreeError("no such file", str(path)) from None
    except UnicodeDecodeError:
        raise TreeError("not a text file (UTF-8)", str(path)) from None
    except OSError as exc:
        raise TreeError(f"cannot read: {exc.strerror}", str(path)) from None
    return load_text(text, str(path))


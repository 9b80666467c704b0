"""Reading input files that cannot hurt: YAML with the line of every mapping, key and list item,
hardened against hostile or broken input.

Every problem is a located `SourceError` (file, line; exit code 2), never another exception and
never a hang: only regular files are opened (a FIFO or a device is refused from `stat`, before
opening), files and texts are capped at `MAX_BYTES`, text must be UTF-8 without control characters,
nesting is capped at `MAX_DEPTH` levels (deeper input would exhaust Python's stack), aliases may
not expand the document beyond `MAX_NODES` nodes nor refer to themselves (a "billion laughs" file is
refused after composing, before anything is built from it), keys must be plain values and unique,
and numbers must be finite (`.nan` and `.inf` are refused wherever they stand).
"""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path
from typing import Any, overload

import yaml

from fvfiles.errors import FvtreeError

MAX_BYTES = 1 << 20  # 1 MiB: the largest tree, design or cell file we read
MAX_DEPTH = 100  # nesting levels of mappings and lists
MAX_NODES = 200_000  # YAML nodes after expanding aliases


class SourceError(FvtreeError):
    """An input file cannot be read or parsed safely; names the file and, where known, the line."""


class Located(dict):
    """A mapping from YAML with the line of the mapping and of each key (1-based)."""

    file: str = ""
    line: int = 0
    key_lines: dict

    def line_of(self, key: Any) -> int:
        return self.key_lines.get(key, self.line)


class LocatedList(list):
    """A list from YAML with the line of the list and of each item (1-based)."""

    file: str = ""
    line: int = 0
    item_lines: list


@overload
def _line(mark: yaml.Mark) -> int: ...
@overload
def _line(mark: yaml.Mark | None) -> int | None: ...
def _line(mark: yaml.Mark | None) -> int | None:
    return mark.line + 1 if mark is not None else None


class _Loader(yaml.SafeLoader):
    """SafeLoader that caps nesting depth, refuses non-finite numbers, and builds `Located`
    mappings (plain, unique keys) and `LocatedList`s."""

    def __init__(self, text: str, name: str):
        super().__init__(text)
        self.name = name
        self._depth = 0

    def fetch_flow_collection_start(self, TokenClass):
        """A `[` or `{` one level deeper than MAX_DEPTH is refused at once, by the scanner: composing
        would refuse it too, but the scanner first looks up to 1024 characters ahead for a simple key
        at every open bracket, which costs 0.23 s of CPU for a line of brackets (more when loaded)."""
        if self.flow_level >= MAX_DEPTH:
            raise SourceError(f"nested more than {MAX_DEPTH} levels deep", self.name, _line(self.get_mark()))
        super().fetch_flow_collection_start(TokenClass)

    def compose_node(self, parent, index):
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise SourceError(f"nested more than {MAX_DEPTH} levels deep", self.name,
                                  _line(self.peek_event().start_mark))
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _construct_mapping(loader: _Loader, node: yaml.MappingNode) -> Located:
    loader.flatten_mapping(node)
    out = Located()
    out.file, out.line, out.key_lines = loader.name, _line(node.start_mark), {}
    for key_node, value_node in node.value:
        line = _line(key_node.start_mark)
        if not isinstance(key_node, yaml.ScalarNode):
            raise SourceError("a mapping key must be a plain value, not a mapping or a list", loader.name, line)
        key = loader.construct_object(key_node, deep=True)
        try:
            duplicate = key in out
        except TypeError:  # an unhashable scalar (e.g. !!binary is fine, !!set is not a scalar)
            raise SourceError(f"a mapping key must be a plain value, got {key!r}", loader.name, line) from None
        if duplicate:
            raise SourceError(f"duplicate key {key!r}", loader.name, line)
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[key] = line
    return out


def _construct_sequence(loader: _Loader, node: yaml.SequenceNode) -> LocatedList:
    out = LocatedList(loader.construct_object(child, deep=True) for child in node.value)
    out.file, out.line = loader.name, _line(node.start_mark)
    out.item_lines = [_line(child.start_mark) for child in node.value]
    return out


def _construct_float(loader: _Loader, node: yaml.ScalarNode) -> float:
    value = yaml.SafeLoader.construct_yaml_float(loader, node)
    if not math.isfinite(value):
        raise SourceError(f"{node.value!r} is not a finite number", loader.name, _line(node.start_mark),
                          hint="NaN and infinity are refused in every input")
    return value


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)
_Loader.add_constructor("tag:yaml.org,2002:float", _construct_float)


def _expanded_size(root: yaml.Node, name: str) -> int:
    """Nodes in the document once every alias is expanded (an alias shares its anchor's node
    object); refuses an anchor that contains an alias of itself. Iterative: no recursion limit."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        key = id(node)
        if key in sizes:
            continue
        children = ([n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode)
                    else node.value if isinstance(node, yaml.SequenceNode) else [])
        if children_done:
            open_nodes.discard(key)
            sizes[key] = min(1 + sum(sizes[id(c)] for c in children), MAX_NODES + 1)
            continue
        if key in open_nodes:
            raise SourceError("an alias refers to the node that contains it", name, _line(node.start_mark))
        open_nodes.add(key)
        stack.append((node, True))
        for child in children:
            if id(child) in open_nodes:
                raise SourceError("an alias refers to the node that contains it", name, _line(child.start_mark))
            if id(child) not in sizes:
                stack.append((child, False))
    return sizes[id(root)]


def load_text(text: str, name: str) -> Any:
    """Parse YAML text (one document) under the limits above; any problem is a SourceError."""
    if len(text) > MAX_BYTES:
        raise SourceError(f"larger than {MAX_BYTES // 1024} KiB", name)
    loader = None
    try:
        loader = _Loader(text, name)  # checks every character first
        root = loader.get_single_node()
        if root is None:
            return None
        if _expanded_size(root, name) > MAX_NODES:
            raise SourceError(f"more than {MAX_NODES} values once its aliases are expanded", name,
                              hint="aliases (*name) may repeat an anchor, not multiply the file")
        return loader.construct_document(root)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        raise SourceError(f"malformed YAML: {exc.problem or exc.context or exc}", name, _line(mark)) from None
    except yaml.reader.ReaderError as exc:
        raise SourceError(f"malformed YAML: character #x{exc.character:04x}: {exc.reason}", name,
                          text.count("\n", 0, exc.position) + 1) from None
    except yaml.YAMLError as exc:  # e.g. a tag PyYAML cannot construct, without a mark
        raise SourceError(f"malformed YAML: {exc}", name) from None
    finally:
        if loader is not None:
            loader.dispose()


def _kind_of(mode: int) -> str:
    for test, kind in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device")):
        if test(mode):
            return kind
    return "not a regular file"


def read_text(path: str | Path, max_bytes: int = MAX_BYTES) -> str:
    """The UTF-8 text of a regular file of at most `max_bytes`; SourceError otherwise. The file
    type is checked with `stat` before opening (opening a FIFO would block), and again on the
    opened descriptor (non-blocking) in case the path changed in between."""
    name = str(path)
    try:
        info = os.stat(name)
        if not stat.S_ISREG(info.st_mode):
            raise SourceError(f"not a regular file: {_kind_of(info.st_mode)}", name)
        fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            mode = os.fstat(f.fileno()).st_mode
            if not stat.S_ISREG(mode):
                raise SourceError(f"not a regular file: {_kind_of(mode)}", name)
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        raise SourceError("no such file", name) from None
    except OSError as exc:
        raise SourceError(f"cannot read: {exc.strerror or exc}", name) from None
    if len(data) > max_bytes:
        raise SourceError(f"larger than {max_bytes // 1024} KiB", name)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SourceError(f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset {exc.start}", name,
                          data.count(b"\n", 0, exc.start) + 1) from None


def load_file(path: str | Path) -> Any:
    """Read and parse a YAML file under the limits above; any problem is a SourceError."""
    return load_text(read_text(path), str(path))

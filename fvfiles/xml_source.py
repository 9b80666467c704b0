"""Reading XML that cannot hurt: an expat parse with the line of every element, refusing any
DOCTYPE (so no entity can be declared or expanded, internal or external) and capping size,
element count and depth, like the YAML inputs (`fvfiles.yaml_source`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn
from xml.parsers import expat

from fvfiles.yaml_source import MAX_BYTES, SourceError, read_text

MAX_ELEMENTS = 100_000
MAX_DEPTH = 200


@dataclass
class XmlNode:
    """An element: tag, attributes, 1-based line, child elements, and the processing
    instructions (target, data) and comments (text, line) directly inside it."""

    tag: str
    attrs: dict[str, str]
    line: int
    children: list[XmlNode] = field(default_factory=list)
    instructions: list[tuple[str, str]] = field(default_factory=list)
    comments: list[tuple[str, int]] = field(default_factory=list)


class _Refused(Exception):
    def __init__(self, message: str):
        super().__init__(message)
        self.message = message


def parse_xml_text(text: str, name: str) -> XmlNode:
    """The root element of an XML text; SourceError (file, line) for anything unsafe or malformed."""
    if len(text.encode("utf-8")) > MAX_BYTES:
        raise SourceError(f"larger than {MAX_BYTES // 1024} KiB", name)
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[XmlNode] = []
    roots: list[XmlNode] = []
    count = 0

    def refuse(*_args: object) -> NoReturn:
        raise _Refused("DOCTYPE and entity declarations are not read (BT.CPP files have none)")

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal count
        count += 1
        if count > MAX_ELEMENTS or len(stack) >= MAX_DEPTH:
            raise _Refused(f"more than {MAX_ELEMENTS} elements or nested deeper than {MAX_DEPTH}")
        node = XmlNode(tag, dict(attrs), parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(node)
        stack.append(node)

    def end(_tag: str) -> None:
        stack.pop()

    def instruction(target: str, data: str) -> None:
        if stack:
            stack[-1].instructions.append((target, data))

    def comment(text: str) -> None:
        if stack:
            stack[-1].comments.append((text, parser.CurrentLineNumber))

    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.ExternalEntityRefHandler = refuse
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.ProcessingInstructionHandler = instruction
    parser.CommentHandler = comment
    try:
        parser.Parse(text, True)
    except _Refused as exc:
        raise SourceError(exc.message, name, parser.CurrentLineNumber) from None
    except expat.ExpatError as exc:
        raise SourceError(f"not well-formed XML: {expat.ErrorString(exc.code)}", name, exc.lineno) from None
    return roots[0]


def parse_xml_file(path: str | Path) -> XmlNode:
    """The root element of an XML file (a regular file, size-capped, UTF-8)."""
    return parse_xml_text(read_text(path), str(path))
